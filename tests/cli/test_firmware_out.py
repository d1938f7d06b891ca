"""``ballbot firmware --out DIR`` hands the user exactly the library, its headers and the
example (a stand-in build: no cross toolchain), copies into a project folder beside
the user's files, and refuses a file given as the folder before anything is built."""

from __future__ import annotations

from types import SimpleNamespace

from ballbot_casadi.cli import firmware as cli_firmware
from ballbot_casadi.cli import main


def _fake_build(root):
    (root / "include").mkdir(parents=True)
    (root / "include" / "ballbot_fw.h").write_text("/* header */\n")
    (root / "include" / "ballbot_fw_config.h").write_text("/* config */\n")
    (root / "src").mkdir()
    (root / "src" / "example_main.c").write_text("int main(void) { return 0; }\n")
    (root / "libballbot_fw.a").write_bytes(b"!<arch>\nlib")
    return SimpleNamespace(library=root / "libballbot_fw.a", include=root / "include", folder=root,
                           example_elf=root / "example.elf", status="built")


def test_out_receives_the_library_headers_and_example(monkeypatch, capsys, tmp_path):
    fw = _fake_build(tmp_path / "build")
    monkeypatch.setattr(cli_firmware, "build_firmware", lambda *a, **k: fw)
    out = tmp_path / "deliver"
    assert main(["firmware", "--out", str(out)]) == 0
    got = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())
    assert got == ["example_main.c", "include/ballbot_fw.h", "include/ballbot_fw_config.h", "libballbot_fw.a"]
    assert (out / "libballbot_fw.a").read_bytes() == b"!<arch>\nlib"
    assert (out / "example_main.c").read_text() == "int main(void) { return 0; }\n"
    assert capsys.readouterr().out.rstrip().endswith(f"copied to {out}")


def test_out_copies_into_a_project_folder_and_refuses_a_file(monkeypatch, capsys, tmp_path):
    fw = _fake_build(tmp_path / "build")
    calls = []
    monkeypatch.setattr(cli_firmware, "build_firmware", lambda *a, **k: calls.append(a) or fw)
    project = tmp_path / "project"
    project.mkdir()
    (project / "notes.txt").write_text("mine")
    assert main(["firmware", "--out", str(project)]) == 0  # like cp -r: the user's files stay
    assert (project / "notes.txt").read_text() == "mine" and (project / "libballbot_fw.a").is_file()
    capsys.readouterr()
    calls.clear()
    assert main(["firmware", "--out", str(project / "notes.txt")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err and "existing file" in err
    assert calls == []  # refused before anything is built


def test_out_refreshes_an_earlier_copy(monkeypatch, capsys, tmp_path):
    """A second export into the same folder (its ``include/`` already there) replaces the
    earlier copy: a library and header changed since are delivered, the user's own header stays."""
    fw = _fake_build(tmp_path / "build")
    monkeypatch.setattr(cli_firmware, "build_firmware", lambda *a, **k: fw)
    out = tmp_path / "deliver"
    assert main(["firmware", "--out", str(out)]) == 0
    (out / "include" / "mine.h").write_text("/* the user's */\n")
    (fw.include / "ballbot_fw.h").write_text("/* header, rebuilt */\n")
    fw.library.write_bytes(b"!<arch>\nlib, rebuilt")
    assert main(["firmware", "--out", str(out)]) == 0
    assert (out / "libballbot_fw.a").read_bytes() == b"!<arch>\nlib, rebuilt"
    assert (out / "include" / "ballbot_fw.h").read_text() == "/* header, rebuilt */\n"
    assert (out / "include" / "mine.h").read_text() == "/* the user's */\n"
    assert capsys.readouterr().out.rstrip().endswith(f"copied to {out}")
