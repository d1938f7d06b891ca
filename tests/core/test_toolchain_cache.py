"""The generated-C build cache heals itself and is safe under concurrent builds.

Fault injection on a tiny library in a private build root: truncate, zero, delete or
alter a cached file, then build and load again.  Loading a truncated shared library
kills the process with SIGBUS, so each build-and-load after damage runs in a forked
child whose exit status is checked.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import stat
from pathlib import Path

import casadi as ca
import pytest

from ballbot_casadi.core import toolchain as tc
from ballbot_casadi.errors import BuildError

pytestmark = pytest.mark.needs_cc


def _functions() -> list[ca.Function]:
    x = ca.SX.sym("x", 2)
    return [ca.Function("ballbot_cache_probe", [x], [ca.vertcat(3 * x[0] + x[1], x[0] * x[1])],
                        ["x"], ["y"])]


def _build_and_eval(root: str) -> tuple[str, list[float]]:
    lib = tc.build_library("cache_probe", _functions(), root=Path(root))
    f = tc.load_library(lib, ["ballbot_cache_probe"])["ballbot_cache_probe"]
    return lib.status, [float(v) for v in ca.DM(f([2.0, 5.0])).full().ravel()]


@pytest.fixture()
def built(tmp_path):
    status, y = _build_and_eval(str(tmp_path))
    assert status == "built" and y == [11.0, 10.0]
    lib = tc.build_library("cache_probe", _functions(), root=tmp_path)
    assert lib.status == "cached"
    return lib


def test_sources_and_binaries_live_together_in_the_hash_folder(built, tmp_path):
    assert built.folder == tmp_path / "codegen" / built.digest
    assert sorted(p.name for p in built.folder.iterdir()) == sorted(
        [tc.MANIFEST, "cache_probe.c", "cache_probe.h", "libcache_probe.so", "libcache_probe.a"])
    # nothing else in codegen/ but the lock of this build
    assert sorted(p.name for p in (tmp_path / "codegen").iterdir()) == sorted(
        [built.digest, f".{built.digest}.lock"])
    assert tc.verify_library(built) is None


@pytest.mark.parametrize("damage", ["truncate", "zero", "delete", "flip"])
@pytest.mark.parametrize("which", ["shared", "static", "source"])
def test_damaged_cached_file_is_rebuilt_and_loads(built, tmp_path, which, damage, in_fork):
    path: Path = getattr(built, which)
    size = path.stat().st_size
    if damage == "truncate":
        with open(path, "r+b") as f:
            f.truncate(size // 3)
    elif damage == "zero":
        with open(path, "r+b") as f:
            f.truncate(0)
    elif damage == "delete":
        path.unlink()
    else:  # same size, one byte changed
        data = bytearray(path.read_bytes())
        data[size // 2] ^= 0xFF
        path.write_bytes(bytes(data))
    # a fresh process builds and loads: no SIGBUS, no CasADi load error
    code, out = in_fork(lambda: repr(_build_and_eval(str(tmp_path))))
    assert code == 0, f"child ended with {code} (negative: killed by signal {-code})"
    assert "rebuilt" in out and "[11.0, 10.0]" in out
    assert path.stat().st_size == size and tc.verify_library(built) is None
    assert tc.build_library("cache_probe", _functions(), root=tmp_path).status == "cached"


def test_missing_or_corrupt_manifest_means_rebuild(built, tmp_path):
    (built.folder / tc.MANIFEST).write_text('{"files": ')
    assert tc.build_library("cache_probe", _functions(), root=tmp_path).status.startswith(
        "rebuilt: unreadable manifest")
    (built.folder / tc.MANIFEST).unlink()
    assert tc.build_library("cache_probe", _functions(), root=tmp_path).status.startswith(
        "rebuilt: no manifest")


def test_concurrent_processes_build_once_and_all_load(tmp_path):
    ctx = mp.get_context("fork")
    with ctx.Pool(4) as pool:
        results = pool.map(_build_and_eval, [str(tmp_path)] * 4)
    assert all(y == [11.0, 10.0] for _, y in results)
    statuses = sorted(s for s, _ in results)
    assert statuses == ["built", "cached", "cached", "cached"], statuses  # one compile
    lib = tc.build_library("cache_probe", _functions(), root=tmp_path)
    assert lib.status == "cached"
    leftovers = [p.name for p in lib.folder.iterdir() if p.name.startswith(".")]
    assert leftovers == []  # no temporary build folders


def test_cc_with_a_wrapper_is_split_like_a_shell_command(tmp_path, monkeypatch):
    bindir = tmp_path / "bin"
    bindir.mkdir()
    log = tmp_path / "wrapper.log"
    wrapper = bindir / "ccache"  # a stand-in for ccache: log, then run the real compiler
    wrapper.write_text(f'#!/bin/sh\necho "$@" >> {log}\nexec "$@"\n')
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("PATH", f"{bindir}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("CC", "ccache gcc")
    assert tc.compiler_command() == ["ccache", "gcc"]
    lib = tc.build_library("cache_probe", _functions(), root=tmp_path / "b")
    assert lib.status == "built" and log.read_text().startswith("gcc ")
    assert float(tc.load_library(lib, ["ballbot_cache_probe"])["ballbot_cache_probe"](
        [1.0, 1.0])[0]) == 4.0


def test_missing_compiler_is_a_clear_build_error(tmp_path, monkeypatch):
    monkeypatch.setenv("CC", "no-such-cc-xyz -O2")
    with pytest.raises(BuildError, match="'no-such-cc-xyz'.*not found"):
        tc.build_library("cache_probe", _functions(), root=tmp_path)
    for bad in ("", "   ", "'unclosed"):
        with pytest.raises(BuildError):
            tc.compiler_command(bad)
    assert not (tmp_path / "codegen").exists()  # refused before anything was written


def test_cached_file_rebuilds_a_damaged_product(tmp_path):
    calls = []

    def make(tmp: Path) -> None:
        calls.append(tmp)
        tmp.write_bytes(b"payload" * 100)

    target = tmp_path / "tool"
    assert tc.cached_file(target, make) == target and len(calls) == 1
    tc.cached_file(target, make)
    assert len(calls) == 1
    with open(target, "r+b") as f:
        f.truncate(7)
    tc.cached_file(target, make)
    assert len(calls) == 2 and target.read_bytes() == b"payload" * 100
    tc.cached_file(target, make, key="other flags")
    assert len(calls) == 3
    with pytest.raises(BuildError, match="no file"):
        tc.cached_file(tmp_path / "x", lambda tmp: None)
