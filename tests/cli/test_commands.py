"""Core CLI commands run in-process."""

import json

import numpy as np

from ballbot_casadi import load_params
from ballbot_casadi.cli import main
from ballbot_casadi.model.linearization import model_summary


def test_summary_lists_unstable_tilt_poles(capsys):
    assert main(["summary"]) == 0
    out = capsys.readouterr().out
    assert "states: 12  inputs: 3  parameters: 21" in out
    eig = [complex(line.strip().replace("j", "j")) for line in out.splitlines()[2:]]
    assert sum(1 for e in eig if e.real > 1.0) == 2  # one unstable pole per tilt axis
    assert model_summary(load_params()) in out
    assert "upright" in out


def test_summary_of_an_offset_com_trims_to_the_balanced_tilt(tmp_path):
    # upright is not an equilibrium with a COM offset: the summary trims first
    text = model_summary(load_params(com_x=0.03))
    assert "upright" not in text and "balanced tilt" in text
    eig = [complex(line.strip()) for line in text.splitlines()[2:]]
    assert sum(1 for e in eig if e.real > 1.0) == 2


def test_summary_bad_params_file(capsys, tmp_path):
    assert main(["summary", "--params", str(tmp_path / "nope.toml")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_codegen_command(capsys):
    assert main(["codegen"]) == 0
    assert "ballbot_model" in capsys.readouterr().out


def test_bench_model_runs(tmp_path):
    from ballbot_casadi.bench import bench_model

    res = bench_model(n_calls=2000)
    assert res["ode_ns"] > 0 and res["jac_ns"] > 0 and res["python_call_ns"] > 0
    assert np.isfinite(res["python_over_c_ratio"])
    json.dumps(res)


def test_demo_removes_the_previous_report_before_its_steps(tmp_path, monkeypatch):
    from ballbot_casadi.cli import commands

    (tmp_path / "report.md").write_text("old report\n")
    seen = []

    def failing_step(out):
        seen.append((out / "report.md").exists())
        raise RuntimeError("step broke")

    monkeypatch.setattr(commands, "DEMO_STEPS", (("broken", failing_step),))
    assert main(["demo", "--out", str(tmp_path)]) == 3
    assert seen == [False] and not (tmp_path / "report.md").exists()


def test_demo_runs_every_step_in_order_and_exits_with_a_failed_steps_code(tmp_path, monkeypatch,
                                                                         capsys):
    from ballbot_casadi.cli import commands

    ran = []

    def step(name, rc):
        def run(out):
            ran.append((name, out))
            return rc
        return run

    steps = (("first", step("a", 0)), ("second fails", step("b", 1)), ("third", step("c", None)))
    monkeypatch.setattr(commands, "DEMO_STEPS", steps)
    out = tmp_path / "new" / "demo"  # the folder and its parents are made
    assert main(["demo", "--out", str(out)]) == 1  # a later step's success does not hide it
    assert ran == [("a", out), ("b", out), ("c", out)] and out.is_dir()
    text = capsys.readouterr().out
    assert [line for line in text.splitlines() if line.startswith("===")] == [
        "=== first ===", "=== second fails ===", "=== third ==="]
    assert "step failed with exit code 1: second fails" in text
    assert "exit code 0" not in text and text.rstrip().endswith(f"demo outputs in {out}")
    monkeypatch.setattr(commands, "DEMO_STEPS", (("ok", step("d", 0)), ("ok too", step("e", None))))
    assert main(["demo", "--out", str(out)]) == 0


def test_demo_titles_come_before_what_a_steps_child_process_prints(tmp_path):
    """A step's compilers and engines write to the same stdout from child processes: each
    title is flushed before its step starts, so a log piped to a file reads in order."""
    import os
    import subprocess
    import sys

    driver = (
        "import subprocess, sys\n"
        "from ballbot_casadi.cli import commands, main\n"
        "def step(out):\n"
        "    subprocess.run([sys.executable, '-c', 'print(\"from the child\")'], check=True)\n"
        "commands.DEMO_STEPS = (('first', step), ('second', step))\n"
        "sys.exit(main(['demo', '--out', sys.argv[1]]))\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    res = subprocess.run([sys.executable, "-c", driver, str(tmp_path / "d")], capture_output=True,
                         text=True, env=env)  # stdout a pipe: block-buffered
    assert res.returncode == 0, res.stderr
    lines = [line for line in res.stdout.splitlines() if line]
    assert lines[:4] == ["=== first ===", "from the child", "=== second ===", "from the child"]


def test_bench_prints_each_result_sorted_and_where_it_wrote(tmp_path, monkeypatch, capsys):
    from ballbot_casadi.cli import commands

    asked = []

    def fake(path, only):
        asked.append((path, only))
        return {"z_ratio": 2.0, "a_ns": 1234.56789, "m_label": "c99"}

    monkeypatch.setattr(commands, "run_benchmarks", fake)
    out = tmp_path / "bench.json"
    assert main(["bench", "--out", str(out), "--only", "model"]) == 0
    assert asked == [(out, ["model"])]
    lines = capsys.readouterr().out.splitlines()
    assert lines == [f"{'a_ns':28s} 1234.57", f"{'m_label':28s} c99", f"{'z_ratio':28s} 2",
                     f"written to {out}"]
