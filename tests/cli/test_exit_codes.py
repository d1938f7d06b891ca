"""Exit codes of ``ballbot``: 0 ok, 1 spec missed, 2 user error (one line), 3 internal.

Bad paths must be refused *before* any computation: the computing functions are
replaced by ones that fail the test if they are called.
"""

from __future__ import annotations

import zipfile

import pytest

from ballbot_casadi import cli
from ballbot_casadi.cli import analyze as cli_analyze
from ballbot_casadi.cli import commands as cli_commands
from ballbot_casadi.cli import study as cli_study
from ballbot_casadi.errors import ArgumentError, BuildError, CosimError, FileFormatError, ScenarioError


def _never(*_a, **_k):
    pytest.fail("the command computed before checking its paths")


@pytest.fixture()
def no_compute(monkeypatch):
    for mod, name in ((cli_analyze, "run_analysis"), (cli_study, "run_study"),
                      (cli_study, "run_all"), (cli_commands, "run_benchmarks"),
                      (cli_commands, "load_params"), (cli_commands, "DEMO_STEPS")):
        monkeypatch.setattr(mod, name, _never if name != "DEMO_STEPS" else (("x", _never),))


def _one_error_line(capsys, command: str, *needles: str) -> str:
    cap = capsys.readouterr()
    err = cap.err.strip()
    assert err.count("\n") == 0, f"expected one line on stderr, got:\n{cap.err}"
    assert err.startswith(f"ballbot {command}: error:"), err
    for n in needles:
        assert n in err, (n, err)
    assert "Traceback" not in cap.err
    return err


def test_help_documents_the_exit_codes(capsys):
    with pytest.raises(SystemExit) as ei:
        cli.main(["--help"])
    assert ei.value.code == 0
    out = capsys.readouterr().out
    for line in ("exit codes:", "0    success", "1    a study or check ran but missed",
                 "2    user error", "3    internal failure", "--debug"):
        assert line in out, line


@pytest.mark.parametrize("argv", [["no-such-command"], ["summary", "--bogus"],
                                  ["study", "no-such-study"]])
def test_usage_errors_are_one_line_and_exit_2(capsys, argv):
    with pytest.raises(SystemExit) as ei:
        cli.main(argv)
    assert ei.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "error:" in err and "--help" in err


def test_bench_only_bogus_lists_the_valid_groups(capsys, no_compute):
    with pytest.raises(SystemExit) as ei:
        cli.main(["bench", "--only", "bogus"])
    assert ei.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "'bogus'" in err
    for group in ("model", "fmu", "control"):
        assert group in err


def test_run_benchmarks_refuses_unknown_groups_before_running(tmp_path, monkeypatch):
    from ballbot_casadi import bench

    monkeypatch.setattr(bench, "BENCHMARKS", {"model": _never})
    with pytest.raises(bench.BenchmarkError, match="valid groups: model"):
        bench.run_benchmarks(tmp_path / "b.json", ["model", "bogus"])
    assert not (tmp_path / "b.json").exists()


@pytest.fixture()
def a_file(tmp_path):
    f = tmp_path / "existing.txt"
    f.write_text("not a directory")
    return f


@pytest.mark.parametrize("cmd", [["analyze", "--no-plots"], ["study", "zero"], ["demo"],
                                 ["fmu", "build"]])
def test_out_that_is_a_file_or_proc_is_refused_before_computing(capsys, no_compute, a_file,
                                                                cmd):
    command = cmd[0]
    assert cli.main([*cmd, "--out", str(a_file)]) == 2
    _one_error_line(capsys, command, "--out", "existing file")
    assert cli.main([*cmd, "--out", "/proc/ballbot-out"]) == 2
    _one_error_line(capsys, command, "--out", "/proc")
    assert cli.main([*cmd, "--out", str(a_file / "sub")]) == 2
    _one_error_line(capsys, command, "is a file")


def test_analyze_out_holding_foreign_files_is_refused_before_computing(capsys, no_compute,
                                                                       tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    assert cli.main(["analyze", "--out", str(tmp_path)]) == 2
    _one_error_line(capsys, "analyze", "notes.txt", "did not write")
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_bench_out_that_is_a_directory_is_refused(capsys, no_compute, tmp_path):
    assert cli.main(["bench", "--out", str(tmp_path)]) == 2
    _one_error_line(capsys, "bench", "is a directory")


@pytest.mark.parametrize("cmd", [["analyze", "--no-plots"], ["summary"]])
def test_params_that_is_a_directory_or_missing_is_refused(capsys, no_compute, tmp_path, cmd):
    out = ["--out", str(tmp_path / "o")] if cmd[0] == "analyze" else []
    assert cli.main([*cmd, *out, "--params", str(tmp_path)]) == 2
    _one_error_line(capsys, cmd[0], "--params", "is a directory")
    assert cli.main([*cmd, *out, "--params", str(tmp_path / "nope.toml")]) == 2
    _one_error_line(capsys, cmd[0], "does not exist")
    assert not (tmp_path / "o").exists()


def test_fmu_info_and_validate_check_their_file(capsys, tmp_path):
    assert cli.main(["fmu", "info", str(tmp_path / "missing.fmu")]) == 2
    _one_error_line(capsys, "fmu", "does not exist")
    bad = tmp_path / "bad.fmu"
    with zipfile.ZipFile(bad, "w") as zf:
        zf.writestr("modelDescription.xml", "<x/>" * 1000)
    data = bytearray(bad.read_bytes())
    data[60] ^= 0xFF  # corrupt the compressed member
    bad.write_bytes(bytes(data))
    assert cli.main(["fmu", "validate", str(bad)]) == 2
    _one_error_line(capsys, "fmu", "bad.fmu")


def test_missed_spec_is_exit_1(monkeypatch, capsys):
    monkeypatch.setattr(cli_study, "run_study", lambda *a, **k: {"passed": False})
    monkeypatch.setattr(cli_study, "format_summary", lambda r: "zero: FAILED")
    assert cli.main(["study", "zero"]) == 1
    monkeypatch.setattr(cli_study, "run_study", lambda *a, **k: {"passed": True})
    assert cli.main(["study", "zero", "--quiet"]) == 0


def _boom(*_a, **_k):
    raise RuntimeError("unexpected state\nsecond line")


@pytest.mark.parametrize("argv", [["summary"], ["--debug", "summary"], ["summary", "--debug"]])
def test_internal_failure_is_exit_3_with_traceback_only_under_debug(monkeypatch, capsys, argv):
    monkeypatch.setattr(cli_commands, "model_summary", _boom)
    assert cli.main(argv) == 3
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last.startswith("ballbot summary: internal error: RuntimeError: unexpected state")
    if "--debug" in argv:
        assert "Traceback (most recent call last)" in err and "_boom" in err
    else:
        assert err.strip().count("\n") == 0 and "--debug" in err


def test_toolchain_failure_is_one_line_and_exit_3(monkeypatch, capsys):
    def fail(*_a, **_k):
        raise BuildError("compiling x failed (gcc ...):\nx.c:1: error: oops\nmore")

    monkeypatch.setattr(cli_commands, "run_codegen", fail)
    assert cli.main(["codegen"]) == 3
    err = _one_error_line(capsys, "codegen", "compiling x failed", "--debug")
    assert "oops" not in err


@pytest.mark.parametrize("message, printed", [
    ("compiling x failed (gcc ...):\nx.c:1: error: oops", "compiling x failed (gcc ...): [more with --debug]"),
    ("compiling x failed", "compiling x failed"),                      # nothing more to show
    ("", "BuildError"),                                                # no message: its type
])
def test_a_ballbot_error_prints_its_first_line_and_says_when_there_is_more(monkeypatch, capsys, message,
                                                                         printed):
    def fail(*_a, **_k):
        raise BuildError(message)

    monkeypatch.setattr(cli_commands, "run_codegen", fail)
    assert cli.main(["codegen"]) == 3
    assert capsys.readouterr().err == f"ballbot codegen: error: {printed}\n"


def test_interrupt_is_exit_130(monkeypatch, capsys):
    def interrupted(*_a, **_k):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_commands, "model_summary", interrupted)
    assert cli.main(["summary"]) == 130
    assert "interrupted" in capsys.readouterr().err


def test_operating_point_where_the_model_overflows_is_refused(capsys, tmp_path):
    assert cli.main(["analyze", "--no-plots", "--out", str(tmp_path / "o"),
                     "--at", "dx=1e300"]) == 2
    _one_error_line(capsys, "analyze", "operating point", "above 10 m/s")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("error, code", [
    (CosimError("libcosim stopped before t = 1 s"), 3),
    (BuildError("gcc failed"), 3),
    (FileFormatError("x.ssp is not a readable SSP archive"), 2),
    (ScenarioError("scenario 'x': duration must be > 0", key="duration_s"), 2),
    (ArgumentError("flc gains need 6 entries"), 2),
])
def test_each_error_kind_exits_with_its_own_code(monkeypatch, capsys, error, code):
    def fail(*_a, **_k):
        raise error

    monkeypatch.setattr(cli_commands, "run_codegen", fail)
    assert cli.main(["codegen"]) == code
    _one_error_line(capsys, "codegen", str(error).splitlines()[0])


@pytest.mark.parametrize("error, line", [
    (PermissionError(13, "Permission denied", "/data/out/run.npz"),
     "ballbot codegen: error: /data/out/run.npz Permission denied"),
    (OSError(28, "No space left on device"), "ballbot codegen: error: No space left on device"),
    (OSError("the disk went away"), "ballbot codegen: error: the disk went away"),
])
def test_an_os_error_the_checks_could_not_foresee_is_one_line_exit_2(monkeypatch, capsys, error, line):
    def fail(*_a, **_k):
        raise error

    monkeypatch.setattr(cli_commands, "run_codegen", fail)
    assert cli.main(["codegen"]) == 2
    assert _one_error_line(capsys, "codegen") == line


def test_debug_prints_the_traceback_of_an_os_error(monkeypatch, capsys):
    def fail(*_a, **_k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(cli_commands, "run_codegen", fail)
    assert cli.main(["--debug", "codegen"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" in err and err.rstrip().endswith("ballbot codegen: error: No space left on device")
