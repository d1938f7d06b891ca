"""The plant-FMU build cache verifies itself, heals damage and tolerates concurrent builds.

Fault injection on a private build (``out`` in a temporary folder): the published
archive, the cached archive and the unpacked binary are deleted, truncated, zeroed or
altered; the next ``build_fmu`` must detect it and rebuild or republish, never publish a
broken archive, never fail with "Directory not empty" and never load a truncated binary
(which kills the process with SIGBUS: such loads run in a forked child).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import re
import shutil
import zipfile
from pathlib import Path

import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi import build as fb
from ballbot_casadi.fmi.package import binary_member

pytestmark = pytest.mark.needs_cc


def _build_and_load(out: Path) -> str:
    b = fb.build_fmu(out)
    lib = ctypes.CDLL(str(b.binary))
    lib.fmi2GetVersion.restype = ctypes.c_char_p
    return f"{b.status}|{lib.fmi2GetVersion().decode()}|{b.digest}"


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def fmu_out(tmp_path_factory):
    """Two processes build the same FMU into one fresh folder at the same time."""
    out = tmp_path_factory.mktemp("fmu")
    pids = []
    for _ in range(2):
        pid = os.fork()
        if pid == 0:
            code = 1
            try:
                b = fb.build_fmu(out)
                (out / f"status-{os.getpid()}").write_text(b.status)
                code = 0
            finally:
                os._exit(code)
        pids.append(pid)
    codes = [os.waitstatus_to_exitcode(os.waitpid(p, 0)[1]) for p in pids]
    statuses = sorted(f.read_text() for f in out.glob("status-*"))
    for f in out.glob("status-*"):
        f.unlink()
    return out, codes, statuses, fb.build_fmu(out)


def test_concurrent_builds_compile_once_and_both_succeed(fmu_out):
    out, codes, statuses, _ = fmu_out
    assert codes == [0, 0]
    assert statuses == ["built", "cached"]  # the second waited for the first and reused it
    b = fb.build_fmu(out)
    assert b.status == "cached" and fb.verify_cache(b.unzipped.parent) is None
    assert _sha(b.fmu) == _sha(b.unzipped.parent / b.fmu.name)
    cache_root = out / "cache"
    assert [p.name for p in cache_root.iterdir() if not p.name.startswith(".")] == [b.digest]
    assert not [p for p in cache_root.iterdir() if p.name.startswith((".build-", ".trash-"))]


def _damage(path: Path, how: str) -> None:
    if how == "delete":
        path.unlink()
    elif how == "truncate":
        with open(path, "r+b") as f:
            f.truncate(path.stat().st_size // 2)
    elif how == "zero":
        with open(path, "r+b") as f:
            f.truncate(0)
    else:  # flip one byte in the middle, same size
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0xFF
        path.write_bytes(bytes(data))


@pytest.mark.parametrize("how", ["delete", "truncate", "zero", "flip"])
@pytest.mark.parametrize("what", ["archive", "binary", "xml"])
def test_every_kind_of_damage_is_detected(fmu_out, tmp_path, what, how):
    b = fmu_out[3]
    cache = tmp_path / "copy"
    shutil.copytree(b.unzipped.parent, cache)
    target = {"archive": cache / b.fmu.name,
              "binary": cache / "unzipped" / fb.binary_member(),
              "xml": cache / "unzipped" / "modelDescription.xml"}[what]
    assert fb.verify_cache(cache) is None
    _damage(target, how)
    assert fb.verify_cache(cache) is not None


def test_deleted_cached_archive_with_its_folder_left_is_rebuilt(fmu_out):
    out, _, _, _ = fmu_out
    b = fb.build_fmu(out)
    (b.unzipped.parent / b.fmu.name).unlink()  # folder remains: once "Directory not empty"
    b2 = fb.build_fmu(out)
    assert b2.status.startswith("rebuilt:") and "missing" in b2.status
    assert b2.digest == b.digest and fb.verify_cache(b2.unzipped.parent) is None
    fb.validate_fmu_archive(b2.fmu, _sha(b2.binary))


def test_truncated_unpacked_binary_is_rebuilt_before_it_is_loaded(fmu_out, in_fork):
    out, _, _, _ = fmu_out
    b = fb.build_fmu(out)
    _damage(b.binary, "truncate")
    code, res = in_fork(lambda: _build_and_load(out))
    assert code == 0, f"child ended with {code} (negative: killed by signal {-code})"
    status, version, digest = res.split("|")
    assert status.startswith("rebuilt:") and version == "2.0" and digest == b.digest
    assert fb.build_fmu(out).status == "cached"


@pytest.mark.parametrize("how", ["delete", "truncate", "flip"])
def test_damaged_published_archive_is_replaced(fmu_out, how):
    out, _, _, _ = fmu_out
    b = fb.build_fmu(out)
    _damage(b.fmu, how)
    b2 = fb.build_fmu(out)
    assert b2.status == "cached"  # the cache was intact: only republished
    assert _sha(b2.fmu) == _sha(b2.unzipped.parent / b2.fmu.name)
    assert not list(out.glob(".*.tmp"))


def test_validate_fmu_archive_checks_crc_members_and_binary_hash(fmu_out, tmp_path):
    out, _, _, _ = fmu_out
    b = fb.build_fmu(out)
    fb.validate_fmu_archive(b.fmu, _sha(b.binary))
    with pytest.raises(BuildError, match="differs from the built binary"):
        fb.validate_fmu_archive(b.fmu, "0" * 64)
    bad = tmp_path / "crc.fmu"
    shutil.copy(b.fmu, bad)
    _damage(bad, "flip")
    with pytest.raises(BuildError, match="CRC|not a valid FMU archive"):
        fb.validate_fmu_archive(bad)
    trunc = tmp_path / "trunc.fmu"
    shutil.copy(b.fmu, trunc)
    _damage(trunc, "truncate")
    with pytest.raises(BuildError, match="not a valid FMU archive"):
        fb.validate_fmu_archive(trunc)
    nobin = tmp_path / "nobin.fmu"
    with zipfile.ZipFile(nobin, "w") as zf:
        zf.writestr("modelDescription.xml",
                    '<fmiModelDescription><CoSimulation modelIdentifier="Other"/>'
                    '</fmiModelDescription>')
    with pytest.raises(BuildError, match="lacks binaries/.*/Other.so"):
        fb.validate_fmu_archive(nobin)  # the binary named by the archive's own XML
    fb.validate_fmu_archive(nobin, require_binary=False)
    noid = tmp_path / "noid.fmu"
    with zipfile.ZipFile(noid, "w") as zf:
        zf.writestr("modelDescription.xml", "<fmiModelDescription/>")
    with pytest.raises(BuildError, match="names no modelIdentifier"):
        fb.validate_fmu_archive(noid)


def _archive(path, members):
    with zipfile.ZipFile(path, "w") as zf:
        for name, text in members.items():
            zf.writestr(name, text)
    return path


def test_validate_fmu_archive_reads_the_identifier_where_the_standard_puts_it(tmp_path):
    """The binary is looked up under the model description's own identifier: the
    co-simulation one, else the model-exchange one, in the platform folder of the FMI
    version the description declares; an archive without a description or with one that
    is not XML is refused naming the file."""
    bare = _archive(tmp_path / "bare.fmu", {"resources/x.txt": "x"})
    with pytest.raises(BuildError, match=rf"^{re.escape(str(bare))} lacks modelDescription\.xml$"):
        fb.validate_fmu_archive(bare, require_binary=False)
    broken = _archive(tmp_path / "broken.fmu", {"modelDescription.xml": "<fmiModelDescription"})
    with pytest.raises(BuildError, match=rf"^{re.escape(str(broken))}: modelDescription\.xml is not valid XML"):
        fb.validate_fmu_archive(broken)
    me = _archive(tmp_path / "me.fmu", {"modelDescription.xml":
                  '<fmiModelDescription fmiVersion="2.0"><CoSimulation modelIdentifier=""/>'
                  '<ModelExchange modelIdentifier="MeOnly"/></fmiModelDescription>'})
    with pytest.raises(BuildError, match=rf"lacks {re.escape(binary_member('MeOnly', 2))}$"):
        fb.validate_fmu_archive(me)
    three = _archive(tmp_path / "three.fmu", {
        "modelDescription.xml": '<fmiModelDescription fmiVersion="3.0"><CoSimulation '
                                'modelIdentifier="Three"/></fmiModelDescription>',
        binary_member("Three", 3): b"\x7fELF"})
    fb.validate_fmu_archive(three)                       # the FMI 3.0 platform folder
    assert binary_member("Three", 3) != binary_member("Three", 2)
    with pytest.raises(BuildError, match=r"differs from the built binary"):
        fb.validate_fmu_archive(three, "0" * 64)
