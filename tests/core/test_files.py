"""core/files.py: atomic writes, staged output folders, manifests and path checks."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from ballbot_casadi.core import files as F
from ballbot_casadi.errors import BallbotError


def test_atomic_write_replaces_whole_file_and_leaves_no_temporaries(tmp_path):
    target = tmp_path / "metrics.json"
    F.atomic_write_text(target, "old\n")
    with open(target, "rb") as reader:  # a reader that opened the old file keeps it whole
        F.atomic_write_bytes(target, b"new content\n")
        assert reader.read() == b"old\n"
    assert target.read_bytes() == b"new content\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]
    assert (target.stat().st_mode & 0o777) == 0o644


def test_atomic_write_that_fails_keeps_the_old_file(tmp_path, monkeypatch):
    target = tmp_path / "a.txt"
    target.write_text("old")

    def boom(*_a, **_k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(F.os, "replace", boom)
    with pytest.raises(OSError):
        F.atomic_write_text(target, "new")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_staged_dir_replaces_the_folder_as_a_whole(tmp_path):
    out = tmp_path / "study"
    with F.staged_dir(out) as d:
        (d / "run.npz").write_bytes(b"1")
        (d / "metrics.json").write_text("{}")
    assert sorted(p.name for p in out.iterdir()) == [F.OUTPUT_MARKER, "metrics.json", "run.npz"]
    with F.staged_dir(out) as d:
        assert not out.samefile(d) and (out / "run.npz").is_file()  # old one still visible
        (d / "metrics.json").write_text('{"new": 1}')
    # the stale run.npz of the first run is gone: the new files stand alone
    assert sorted(p.name for p in out.iterdir()) == [F.OUTPUT_MARKER, "metrics.json"]
    assert json.loads((out / "metrics.json").read_text()) == {"new": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["study"]  # no stage/old folders left


def test_staged_dir_makes_the_parents_of_a_new_folder(tmp_path):
    final = tmp_path / "a" / "b" / "out"
    with F.staged_dir(final) as d:
        (d / "r.txt").write_text("x")
    assert (final / "r.txt").read_text() == "x"
    assert sorted(p.name for p in final.parent.iterdir()) == ["out"]  # no stage left behind


def test_staged_dir_leaves_the_old_folder_untouched_on_error(tmp_path):
    out = tmp_path / "study"
    with F.staged_dir(out) as d:
        (d / "metrics.json").write_text("old")
    with pytest.raises(KeyboardInterrupt):
        with F.staged_dir(out) as d:
            (d / "metrics.json").write_text("half")
            raise KeyboardInterrupt  # Ctrl-C near the end of a study
    assert (out / "metrics.json").read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["study"]


def test_staged_dir_fallback_without_rename_exchange(tmp_path, monkeypatch):
    monkeypatch.setattr(F, "_exchange", lambda a, b: False)
    out = tmp_path / "o"
    for text in ("one", "two"):
        with F.staged_dir(out) as d:
            (d / "f.txt").write_text(text)
    assert (out / "f.txt").read_text() == "two"
    assert [p.name for p in tmp_path.iterdir()] == ["o"]


def test_staged_dir_never_deletes_foreign_files(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    (home / "thesis.tex").write_text("precious")
    with pytest.raises(F.PathError, match="did not write"):
        with F.staged_dir(home, owned=("*.png", "analysis.json")):
            pytest.fail("the body must not run")
    assert (home / "thesis.tex").read_text() == "precious"
    # earlier outputs of the same kind (no marker yet) may be replaced
    (home / "thesis.tex").unlink()
    (home / "analysis.json").write_text("{}")
    with F.staged_dir(home, owned=("*.png", "analysis.json")) as d:
        (d / "analysis.json").write_text("[]")
    assert (home / "analysis.json").read_text() == "[]"
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(F.PathError, match="existing file"):
        with F.staged_dir(f):
            pass


@pytest.mark.parametrize("n, shown", [
    (1, "'a.tex'"), (3, "'a.tex', 'b.tex', 'c.tex'"), (4, "'a.tex', 'b.tex', 'c.tex' ..."),
])
def test_the_refusal_names_the_first_three_foreign_files(tmp_path, n, shown):
    home = tmp_path / "home"
    home.mkdir()
    for name in "abcd"[:n]:
        (home / f"{name}.tex").write_text("precious")
    (home / "x.png").write_text("ours")  # an output of ours is not listed
    with pytest.raises(F.PathError) as ei:
        with F.staged_dir(home, owned=("*.png",)):
            pass
    assert str(ei.value) == (f"{home} already holds files that ballbot did not write ({shown}); it "
                             "would be replaced as a whole: give a new or empty directory")


def test_manifest_detects_truncation_zeroing_deletion_and_edits(tmp_path):
    for name in ("a.so", "b.a"):
        (tmp_path / name).write_bytes(os.urandom(5000))
    F.write_manifest(tmp_path, ["a.so", "b.a"])
    assert F.check_manifest(tmp_path, ["a.so", "b.a"]) is None
    assert "not recorded" in F.check_manifest(tmp_path, ["c.so"])
    data = (tmp_path / "a.so").read_bytes()
    with open(tmp_path / "a.so", "r+b") as f:
        f.truncate(100)
    assert "100 bytes" in F.check_manifest(tmp_path)
    (tmp_path / "a.so").write_bytes(b"")
    assert "0 bytes" in F.check_manifest(tmp_path)
    (tmp_path / "a.so").write_bytes(data[:-1] + bytes([data[-1] ^ 1]))  # same size
    assert "SHA-256" in F.check_manifest(tmp_path)
    (tmp_path / "a.so").unlink()
    assert "missing" in F.check_manifest(tmp_path)
    (tmp_path / "MANIFEST.json").write_text("{trunc")
    assert "unreadable" in F.check_manifest(tmp_path)
    (tmp_path / "MANIFEST.json").unlink()
    assert "no manifest" in F.check_manifest(tmp_path)


def test_check_output_dir_refuses_files_pseudo_fs_and_files_as_parents(tmp_path):
    f = tmp_path / "existing.txt"
    f.write_text("x")
    for bad, msg in [(f, "existing file"), (f / "sub", "is a file"), ("/proc/ballbot", "pseudo"),
                     ("/sys/kernel/out", "pseudo")]:
        with pytest.raises(F.PathError, match=msg) as ei:
            F.check_output_dir(bad, "--out")
        assert isinstance(ei.value, BallbotError) and "\n" not in str(ei.value)
        assert str(ei.value).startswith("--out ")
    new = tmp_path / "a" / "b"
    assert F.check_output_dir(new) == new and not new.exists()  # nothing is created
    assert F.check_output_dir(tmp_path) == tmp_path
    with pytest.raises(F.PathError, match="directory"):
        F.check_output_file(tmp_path)
    assert F.check_output_file(tmp_path / "bench.json") == tmp_path / "bench.json"


@pytest.fixture()
def public_dir():
    """A world-traversable temporary folder (pytest's tmp_path is private to its user)."""
    d = Path(tempfile.mkdtemp(prefix="ballbot-ro-test-"))
    d.chmod(0o755)
    yield d
    for sub in d.rglob("*"):
        sub.chmod(0o755)
    shutil.rmtree(d)


def test_check_output_dir_refuses_a_read_only_directory(public_dir):
    """Root may write anywhere, so the check runs in a child that drops to 'nobody'."""
    ro = public_dir / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    pid = os.fork()
    if pid == 0:  # child
        code = 1
        try:
            if os.geteuid() == 0:
                os.setgid(65534)
                os.setuid(65534)
            try:
                F.check_output_dir(ro / "out")
                code = 2  # not refused
            except F.PathError as exc:
                code = 0 if "cannot write" in str(exc) else 3
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


def test_check_input_file(tmp_path):
    with pytest.raises(F.PathError, match="does not exist"):
        F.check_input_file(tmp_path / "nope.toml")
    with pytest.raises(F.PathError, match="is a directory"):
        F.check_input_file(tmp_path, "--params")
    p = tmp_path / "robot.toml"
    p.write_text("[body]\n")
    assert F.check_input_file(p) == p


def test_zip_bytes_depends_on_the_members_only():
    """Sorted members dated 1980-01-01, deflated, 0755 only for the executables; the same
    members in another order give the same bytes; the content reads back."""
    import io
    import zipfile

    members = {"z.txt": b"zz" * 100, "a/b.so": b"\x7fELF" * 50, "m.xml": b"<m/>"}
    data = F.zip_bytes(members, executable=["a/b.so"])
    assert F.zip_bytes(dict(reversed(list(members.items()))), executable=("a/b.so",)) == data
    assert F.zip_bytes(members) != data  # the mode is part of the archive
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        infos = zf.infolist()
        assert [i.filename for i in infos] == ["a/b.so", "m.xml", "z.txt"]
        for i in infos:
            assert i.date_time == F.ZIP_DATE_TIME == (1980, 1, 1, 0, 0, 0)
            assert i.compress_type == zipfile.ZIP_DEFLATED
            assert i.external_attr >> 16 == (0o755 if i.filename == "a/b.so" else 0o644)
            assert zf.read(i) == members[i.filename]
