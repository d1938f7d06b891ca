"""Every option of ``study``, ``montecarlo``, ``simulate``, ``animate``, ``analyze``,
``firmware`` and ``fmu`` reaches the function it configures with its value, and each error
branch exits with its code and one line naming the option (issue 23, test strength: a
swapped argument, a wrong default, a bound off by one or an exit code from the wrong branch
changes nothing any run would show).  The computations are replaced by recorders."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.cli import animate as cli_animate
from ballbot_casadi.cli import analyze as cli_analyze
from ballbot_casadi.cli import firmware as cli_firmware
from ballbot_casadi.cli import fmu as cli_fmu
from ballbot_casadi.cli import main
from ballbot_casadi.cli import montecarlo as cli_mc
from ballbot_casadi.cli import simulate as cli_simulate
from ballbot_casadi.cli import study as cli_study


def _err(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err  # one line
    return err


# ------------------------------------------------------------------------------- study
@pytest.fixture()
def study_calls(monkeypatch, tmp_path):
    calls = []

    def run_study(name, controller, out, plot, overrides, params):
        calls.append(dict(name=name, controller=controller, out=out, plot=plot, overrides=overrides,
                          params=params))
        return {"passed": calls[0].get("pass", True)}

    monkeypatch.setattr(cli_study, "run_study", run_study)
    monkeypatch.setattr(cli_study, "format_summary", lambda r: "SUMMARY")
    monkeypatch.chdir(tmp_path)
    return calls


def test_study_options_reach_run_study(study_calls, capsys, tmp_path):
    rc = main(["study", "sine", "--controller", "smc", "--set", "duration_s=2", "--set", "seed=4",
               "--estimator", "ukf", "--seed", "3", "--feedforward", "none", "--torque-limit", "per-wheel",
               "--no-plot", "--out", str(tmp_path / "o")])
    assert rc == 0 and capsys.readouterr().out == "SUMMARY\n"
    c = study_calls[0]
    assert (c["name"], c["controller"], c["out"], c["plot"], c["params"]) == (
        "sine", "smc", tmp_path / "o", False, None)
    assert c["overrides"] == [("duration_s", 2), ("seed", 4), ("estimator", "ukf"), ("seed", 3),
                              ("feedforward", "none"), ("torque_limit", "per-wheel")]


def test_study_defaults_and_a_missed_spec(study_calls, capsys, monkeypatch):
    assert main(["study", "zero", "--quiet"]) == 0 and capsys.readouterr().out == ""
    c = study_calls[0]
    assert (c["controller"], c["out"], c["plot"], c["overrides"], c["params"]) == ("flc", None, True, [], None)
    monkeypatch.setattr(cli_study, "run_study", lambda *a, **k: {"passed": False})
    assert main(["study", "zero", "--quiet"]) == 1


def test_study_params_file_is_loaded(study_calls, tmp_path):
    p = tmp_path / "p.toml"
    p.write_text("Mb = 15.0\n")
    assert main(["study", "zero", "--quiet", "--params", str(p)]) == 0
    assert study_calls[0]["params"].Mb == 15.0


@pytest.mark.parametrize("argv, needle", [
    (["study"], "give a study name (or --list); studies: zero, sine"),
    (["study", "sine", "--axis", "pitch"], "--axis and --amplitude apply to the chirp study only"),
    (["study", "sine", "--amplitude", "2"], "--axis and --amplitude apply to the chirp study only"),
    (["study", "chirp", "--amplitude", "0"], "--amplitude must be in (0, 45] deg, got 0"),
    (["study", "chirp", "--amplitude", "45.01"], "--amplitude must be in (0, 45] deg, got 45.01"),
    (["study", "chirp", "--amplitude", "-3"], "--amplitude must be in (0, 45] deg, got -3"),
    (["study", "thesis", "--seed", "1"], "do not apply to 'thesis'"),
    (["study", "thesis", "--controller", "smc"], "do not apply to 'thesis'"),
    (["study", "all", "--estimator", "ukf"], "apply to one study, not to 'all'"),
    (["study", "all", "--set", "seed=1"], "apply to one study, not to 'all'"),
    (["study", "sine", "--set", "=3"], "--set '=3'"),
    (["study", "sine", "--params", "missing.toml"], "--params"),
])
def test_study_refusals_are_one_line_exit_2(study_calls, capsys, argv, needle):
    assert main(argv) == 2
    assert needle in _err(capsys)
    assert study_calls == []


def test_study_chirp_amplitude_at_its_bound_and_axis(study_calls, monkeypatch):
    got = []
    monkeypatch.setattr(cli_study.chirp_study, "axis_overrides",
                        lambda table, axis, amp: got.append((axis, amp)) or [("k", 1)])
    assert main(["study", "chirp", "--amplitude", "45", "--quiet"]) == 0
    assert main(["study", "chirp", "--axis", "pitch", "--quiet"]) == 0
    assert got == [(None, 45.0), ("pitch", None)]
    assert study_calls[0]["overrides"] == [("k", 1)]


def test_study_thesis_and_all(study_calls, monkeypatch, capsys):
    seen = []
    monkeypatch.setattr(cli_study, "run_thesis", lambda out, rerun, plot: seen.append((out, rerun, plot)) or {
        "passed": False, "counts": {"pass": 3, "differs": 1}, "missing": ["speed", "push"]})
    assert main(["study", "thesis", "--rerun", "--no-plot"]) == 1
    assert seen == [(None, True, False)]
    assert capsys.readouterr().out == "thesis table: 3 pass, 1 differs; metrics missing for: speed, push\n"
    monkeypatch.setattr(cli_study, "run_thesis", lambda out, rerun, plot: {"passed": True, "counts": {"pass": 2},
                                                                          "missing": []})
    assert main(["study", "thesis"]) == 0 and capsys.readouterr().out == "thesis table: 2 pass\n"
    table = {"a": {"flc": {"passed": True}, "smc": {"passed": False}}, "b": {"flc": {"passed": True}}}
    monkeypatch.setattr(cli_study, "run_all", lambda out, plot: table)
    assert main(["study", "all"]) == 1 and capsys.readouterr().out == "SUMMARY\n" * 3
    table["a"]["smc"]["passed"] = True
    assert main(["study", "all", "--quiet"]) == 0 and capsys.readouterr().out == ""


def test_study_extra_refuses_scenario_options_and_runs(study_calls, monkeypatch, capsys, tmp_path):
    name = next(iter(cli_study.EXTRA_STUDIES))
    assert main(["study", name, "--seed", "2", "--set", "a=1"]) == 2
    assert f"--set, --seed do not apply to the {name} study" in _err(capsys)
    ran = []
    monkeypatch.setattr(cli_study, "run_extra_study", lambda n, out, plot: ran.append((n, out, plot))
                        or {"passed": False})
    assert main(["study", name, "--no-plot"]) == 1
    assert ran == [(name, cli_study.DEFAULT_OUT / name, False)]
    assert capsys.readouterr().out == f"{name}: FAIL  ({cli_study.DEFAULT_OUT / name / 'report.md'})\n"


# ------------------------------------------------------------------------------- montecarlo
@pytest.fixture()
def mc(monkeypatch, tmp_path):
    calls = []
    doc = {"name": "sine", "n": 4, "success_rate": 0.75, "worst": [{"index": 2, "seed": 9, "file": "worst/w.toml"}],
           "specs": [{"metric": "m", "op": "<=", "threshold": 1.0, "pass_rate": 0.5}]}

    def run(path, n, out, scheduler, workers, quiet, seed, overrides, resume):
        calls.append(dict(path=path, n=n, out=out, scheduler=scheduler, workers=workers, quiet=quiet,
                          seed=seed, overrides=overrides, resume=resume))
        return doc

    monkeypatch.setattr(cli_mc, "run_montecarlo", run)
    monkeypatch.chdir(tmp_path)
    return calls, doc


def test_montecarlo_options_reach_the_run(mc, capsys, tmp_path):
    calls, doc = mc
    rc = main(["montecarlo", "sine", "--n", "4", "--workers", "0", "--seed", "11", "--set", "duration_s=1",
               "--out", str(tmp_path / "o"), "--min-success", "0.75", "--resume"])
    assert rc == 0
    c = calls[0]
    assert (c["path"].name, c["n"], c["out"], c["scheduler"], c["workers"], c["quiet"], c["seed"],
            c["overrides"], c["resume"]) == ("sine.toml", 4, tmp_path / "o", None, 0, False, 11,
                                             [("duration_s", 1)], True)
    out = capsys.readouterr().out
    assert "montecarlo sine: 4 runs, success rate 75.0 %" in out
    assert "  m <= 1.0: 50.0 % pass" in out
    assert f"  worst: run 2 (noise seed 9): ballbot simulate {tmp_path / 'o' / 'worst/w.toml'}" in out


def test_montecarlo_defaults_and_the_success_bound(mc, capsys):
    calls, doc = mc
    assert main(["montecarlo", "sine", "--n", "1", "--quiet"]) == 1   # 75 % < the default 100 %
    c = calls[0]
    assert (c["out"], c["workers"], c["seed"], c["overrides"], c["resume"], c["quiet"]) == (
        Path("build") / "montecarlo" / "sine", 2, None, [], False, True)
    assert capsys.readouterr().out == ""
    assert main(["montecarlo", "sine", "--n", "1", "--min-success", "0.76"]) == 1
    assert "FAIL: success rate 75.0 % below --min-success 76 %" in capsys.readouterr().out
    doc["success_rate"] = 1.0
    assert main(["montecarlo", "sine", "--n", "1", "--quiet"]) == 0
    assert main(["montecarlo", "sine", "--n", "1", "--quiet", "--min-success", "1"]) == 0


@pytest.mark.parametrize("argv, needle", [
    (["--n", "0"], "--n must be >= 1, got 0"),
    (["--n", "1", "--min-success", "-0.01"], "--min-success must be within [0, 1], got -0.01"),
    (["--n", "1", "--min-success", "1.01"], "--min-success must be within [0, 1], got 1.01"),
    (["--n", "1", "--workers", "-1"], "--workers must be >= 0 (0 = serial in this process), got -1"),
])
def test_montecarlo_bounds_exit_2(mc, capsys, argv, needle):
    assert main(["montecarlo", "sine", *argv]) == 2
    assert needle in _err(capsys) and mc[0] == []


def test_montecarlo_bounds_just_inside(mc):
    assert main(["montecarlo", "sine", "--n", "1", "--min-success", "0", "--workers", "0", "--quiet"]) == 0
    assert mc[0][0]["n"] == 1 and mc[0][0]["workers"] == 0


# ------------------------------------------------------------------------------- simulate
@pytest.fixture()
def sim_calls(monkeypatch, tmp_path):
    calls = []
    monkeypatch.setattr(cli_simulate, "run_file", lambda src, out, plot, params, log_every: calls.append(
        dict(src=src, out=out, plot=plot, params=params, log_every=log_every)) or {"passed": calls[0].get("ok", True)})
    monkeypatch.setattr(cli_simulate, "format_summary", lambda r: "SUMMARY")
    monkeypatch.chdir(tmp_path)
    return calls


def test_simulate_options_reach_run_file(sim_calls, capsys, tmp_path, monkeypatch):
    widened = []
    monkeypatch.setattr(cli_simulate, "with_duration", lambda src, d, m: widened.append((d, m)) or src)
    assert main(["simulate", "sine", "--no-plot", "--log-every", "3", "--duration", "7.5",
                 "--out", str(tmp_path / "o")]) == 0
    c = sim_calls[0]
    assert (c["src"].scenario.name, c["out"], c["plot"], c["params"], c["log_every"]) == (
        "sine", tmp_path / "o", False, None, 3)
    assert widened == [(7.5, 3)]
    assert capsys.readouterr().out == (
        f"SUMMARY\nwritten to {tmp_path / 'o'} (metrics.json, run.npz, plot.png, report.md)\n")
    assert main(["simulate", "sine", "--quiet"]) == 0 and capsys.readouterr().out == ""
    assert (sim_calls[1]["out"], sim_calls[1]["plot"], sim_calls[1]["log_every"]) == (
        Path("build") / "simulate" / "sine", True, 1)
    assert len(widened) == 1   # no --duration: the file's


def test_simulate_refusals_and_a_missed_spec(sim_calls, capsys, monkeypatch):
    assert main(["simulate", "sine", "--log-every", "0"]) == 2
    assert "--log-every must be >= 1, got 0" in _err(capsys)
    assert main(["simulate", "no_such_scenario"]) == 2
    assert "no_such_scenario: no such scenario file" in _err(capsys)
    assert sim_calls == []
    monkeypatch.setattr(cli_simulate, "run_file", lambda *a, **k: {"passed": False})
    assert main(["simulate", "sine", "--quiet"]) == 1


# ------------------------------------------------------------------------------- animate, analyze
def test_animate_options(monkeypatch, tmp_path, capsys):
    run = tmp_path / "run.npz"
    run.write_bytes(b"x")
    got = []
    monkeypatch.setattr(cli_animate, "animate", lambda r, o, fps, max_frames: got.append((r, o, fps, max_frames))
                        or Path(o))
    monkeypatch.chdir(tmp_path)
    assert main(["animate", str(run), "-o", "a.mp4", "--fps", "7.5", "--max-frames", "9"]) == 0
    assert main(["animate", str(run), "--quiet"]) == 0
    assert got == [(str(run), "a.mp4", 7.5, 9), (str(run), "run.gif", 15.0, 200)]
    assert capsys.readouterr().out == "written a.mp4\n"
    assert main(["animate", str(tmp_path / "none.npz")]) == 2 and "RUN" in _err(capsys)


def test_analyze_options(monkeypatch, tmp_path, capsys):
    got = []
    monkeypatch.setattr(cli_analyze, "run_analysis", lambda out, params, at, plots, compiled: got.append(
        (out, params, at, plots, compiled)) or {"files": ["a.json", "b.md"]})
    monkeypatch.setattr(cli_analyze, "summary_text", lambda r: "S")
    monkeypatch.chdir(tmp_path)
    assert main(["analyze", "--at", "yaw=30", "--no-plots", "--compiled", "--out", "o"]) == 0
    assert main(["analyze"]) == 0
    assert got == [("o", None, "yaw=30", False, True), ("build/analysis", None, None, True, False)]
    assert capsys.readouterr().out == "S\nwritten: a.json, b.md\n" * 2
    assert main(["analyze", "--params", "nope.toml"]) == 2 and "--params" in _err(capsys)


# ------------------------------------------------------------------------------- firmware
def test_firmware_options_reach_the_build(monkeypatch, capsys, tmp_path):
    got = []
    fw = SimpleNamespace(library=tmp_path / "lib.a", status="cached", include=tmp_path / "inc",
                         example_elf=tmp_path / "e.elf")
    monkeypatch.setattr(cli_firmware, "build_firmware", lambda c, e, p, guidance, latency: got.append(
        (c, e, p, guidance, latency)) or fw)
    assert main(["firmware", "--controller", "smc", "--estimator", "ukf", "--precision", "single"]) == 0
    assert main(["firmware"]) == 0
    assert got == [("smc", "ukf", "single", None, 0), ("flc", cli_firmware.DEFAULT_ESTIMATOR, "double", None, 0)]
    assert capsys.readouterr().out.startswith(f"{fw.library}  (cached)\n  headers {fw.include}\n")
    assert main(["firmware", "--latency", "2"]) == 2
    assert "--latency 2 needs --guidance mpc" in _err(capsys)


def test_firmware_missing_toolchain_is_exit_3(monkeypatch, capsys):
    def missing(*a, **k):
        raise cli_firmware.ToolchainMissing("arm-none-eabi-gcc not found")

    monkeypatch.setattr(cli_firmware, "build_firmware", missing)
    assert main(["firmware"]) == 3
    assert _err(capsys) == "ballbot firmware: error: arm-none-eabi-gcc not found\n"


# ------------------------------------------------------------------------------- fmu
def test_fmu_cosim_options_and_exit_code(monkeypatch, capsys, tmp_path):
    ssp = tmp_path / "s.ssp"
    ssp.write_bytes(b"x")
    got = []
    result = {"passed": True, "sil": {"steps": 10, "master": "gauss-seidel", "wall_s": 1.23456,
                                      "vs_mission": {"reference": "mission", "state_max": 1e-9, "tau_max": 2e-9}}}
    monkeypatch.setattr(cli_fmu, "run_sil", lambda s, out, d, master, plot, compare, allow_long: got.append(
        (s, out, d, master, plot, compare, allow_long)) or result)
    out = str(tmp_path / "o")
    assert main(["fmu", "cosim", str(ssp), "--out", out, "--duration", "2.5", "--master", "gauss-seidel",
                 "--no-plot", "--no-compare", "--allow-long"]) == 0
    assert main(["fmu", "cosim", str(ssp), "--out", out]) == 0
    assert got[0] == (ssp, out, 2.5, "gauss-seidel", False, False, True)
    assert got[1] == (ssp, out, None, "libcosim", True, True, False)
    assert capsys.readouterr().out.splitlines()[0] == (
        f"{out}: 10 steps (gauss-seidel) in 1.23 s; specs passed; vs the mission: states 1e-09, torques 2e-09")
    result["passed"] = False
    assert main(["fmu", "cosim", str(ssp), "--out", out]) == 1
    assert "specs MISSED" in capsys.readouterr().out
    assert main(["fmu", "cosim", str(tmp_path / "none.ssp"), "--out", out]) == 2 and "SSP" in _err(capsys)


def test_fmu_build_and_build_controller_options(monkeypatch, capsys, tmp_path):
    b = SimpleNamespace(fmu="F.fmu", fmi_version=3, guid="G", digest="D", status="built")
    got = []
    monkeypatch.setattr(cli_fmu, "build_fmu", lambda out, fmi_version: got.append(("plant", out, fmi_version)) or b)
    monkeypatch.setattr(cli_fmu, "controller_spec", lambda *a, **k: ("spec", a, tuple(sorted(k))))
    monkeypatch.setattr(cli_fmu, "build_fmu_from_spec", lambda spec, out, fmi_version: got.append(
        (spec, out, fmi_version)) or b)
    assert main(["fmu", "build", "--fmi-version", "3"]) == 0
    assert main(["fmu", "build-controller", "--controller", "smc", "--estimator", "ekf",
                 "--out", str(tmp_path / "c")]) == 0
    assert main(["fmu", "build-controller"]) == 0
    assert got == [("plant", None, 3), (("spec", ("smc", "ekf"), ()), str(tmp_path / "c"), 2),
                   (("spec", ("flc", cli_fmu.DEFAULT_ESTIMATOR), ()), None, 2)]
    assert capsys.readouterr().out.splitlines()[0] == "F.fmu  (FMI 3.0, GUID G, cache D, built)"
    with pytest.raises(SystemExit) as e:
        main(["fmu", "build", "--fmi-version", "4"])
    assert e.value.code == 2 and "invalid choice: 4" in _err(capsys)


def test_fmu_info_without_a_build_names_the_command(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(cli_fmu, "build_root", lambda: tmp_path)
    for cmd in ("info", "validate"):
        assert main(["fmu", cmd]) == 2
        assert f"{tmp_path / 'fmu' / 'BallbotPlant.fmu'} does not exist; run 'ballbot fmu build' first" in _err(capsys)
    assert main(["fmu", "container"]) == 2
    assert "BallbotSIL.ssp does not exist; run 'make sil'" in _err(capsys)


def test_fmu_container_defaults_to_the_sil_ssp_and_the_build_folder(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(cli_fmu, "build_root", lambda: tmp_path)
    ssp = tmp_path / "fmu" / "BallbotSIL.ssp"
    ssp.parent.mkdir()
    ssp.write_bytes(b"x")
    built = []
    monkeypatch.setattr(cli_fmu, "build_container", lambda s, out: built.append((s, out)) or out)
    assert main(["fmu", "container"]) == 0
    assert built == [(ssp, tmp_path / "fmu" / f"{cli_fmu.CONTAINER_NAME}.fmu")]
    assert capsys.readouterr().out.strip() == str(built[0][1])
    mine = tmp_path / "mine.ssp"
    mine.write_bytes(b"x")
    assert main(["fmu", "container", str(mine), "--out", str(tmp_path / "c.fmu")]) == 0
    assert built[1] == (mine, tmp_path / "c.fmu")


def test_fmu_info_and_validate_accept_an_fmu_without_binaries(monkeypatch, capsys, tmp_path):
    fmu = tmp_path / "m.fmu"
    fmu.write_bytes(b"x")
    checked = []
    monkeypatch.setattr(cli_fmu, "validate_fmu_archive", lambda p, require_binary: checked.append((p, require_binary)))
    monkeypatch.setattr(cli_fmu, "dump", lambda p: print(f"DUMP {p}"))
    monkeypatch.setattr(cli_fmu, "validate_fmu", lambda p: [])
    assert main(["fmu", "info", str(fmu)]) == 0
    assert main(["fmu", "validate", str(fmu)]) == 0
    assert checked == [(fmu, False), (fmu, False)]
    assert capsys.readouterr().out == f"DUMP {fmu}\n{fmu}: valid\n"
    monkeypatch.setattr(cli_fmu, "validate_fmu", lambda p: ["a", "b"])
    assert main(["fmu", "validate", str(fmu)]) == 1
    assert capsys.readouterr().out == f"problem: a\nproblem: b\n{fmu}: 2 problem(s)\n"


def test_study_out_folder_checked_up_front_for_one_study_not_for_all(study_calls, monkeypatch, capsys,
                                                                     tmp_path):
    """One study replaces its --out folder as a whole, so a folder holding a file it did
    not write is refused before anything runs; 'all' writes one subfolder per study into
    --out, so a folder holding earlier studies' subfolders and the user's own files is
    accepted."""
    out = tmp_path / "mine"
    (out / "sine").mkdir(parents=True)
    (out / "notes.txt").write_text("mine\n")
    assert main(["study", "sine", "--out", str(out)]) == 2
    assert "already holds files that ballbot did not write ('notes.txt'" in _err(capsys)
    assert study_calls == []
    ran = []
    monkeypatch.setattr(cli_study, "run_all", lambda o, plot: ran.append(o) or {})
    assert main(["study", "all", "--quiet", "--out", str(out)]) == 0
    assert ran == [out] and (out / "notes.txt").read_text() == "mine\n"
    (out / "notes.txt").unlink()
    (out / "sine").rmdir()
    (out / "report.md").write_text("an earlier run's\n")
    assert main(["study", "sine", "--quiet", "--out", str(out)]) == 0 and study_calls[0]["out"] == out


def _verify_stand_ins(monkeypatch, qemu_tau, base=0.25):
    """``ballbot firmware --verify`` around recording stand-ins: which recorder, which builds,
    which replays; the torques of QEMU against the double host replay decide the exit code."""
    calls = []
    fw = SimpleNamespace(library=Path("/l/lib.a"), status="built", include=Path("/l/inc"),
                         example_elf=Path("/l/e.elf"), precision="p")

    def build(c, e, p, guidance, latency):
        calls.append(("build", c, e, p, guidance, latency))
        return SimpleNamespace(**{**vars(fw), "precision": p})

    rec = SimpleNamespace(n=5, tau_mission=np.array([[0.5, 0.0, 0.0]]), v_ref_mission=np.zeros((1, 3)),
                          values=SimpleNamespace(guidance=np.zeros(7)))
    monkeypatch.setattr(cli_firmware, "build_firmware", build)
    monkeypatch.setattr(cli_firmware, "replay_scenario", lambda n, estimator: calls.append(
        ("scenario", n, estimator)) or "log")
    monkeypatch.setattr(cli_firmware, "record_log", lambda log: calls.append(("record", log)) or rec)
    monkeypatch.setattr(cli_firmware, "record_guided_log", lambda n, guidance, latency, estimator: calls.append(
        ("guided", n, guidance, latency, estimator)) or rec)
    monkeypatch.setattr(cli_firmware, "run_host", lambda b, r: calls.append(("host", b.precision, r is rec))
                        or SimpleNamespace(tau=np.array([[base, 0.0, 0.0]]), v_ref=np.zeros((1, 3))))
    monkeypatch.setattr(cli_firmware, "run_qemu", lambda b, r: calls.append(("qemu", b.precision, r is rec))
                        or SimpleNamespace(tau=np.array([[base + qemu_tau, 0.0, 0.0]]), v_ref=np.zeros((1, 3))))
    cost = SimpleNamespace(step_instructions_max=1e5, step_us=250.0, period_fraction=0.05, ram_bytes=100,
                           context_bytes=60, stack_bytes=40, image_flash_bytes=9000, library_flash_bytes=8000)
    monkeypatch.setattr(cli_firmware, "firmware_cost", lambda b, q: cost)
    g = SimpleNamespace(solve_instructions_max=2e6, solve_instructions_median=1e6, first_instructions=3e6,
                        solve_ms=lambda hz: 4.0, hold_instructions_max=1e5, ram_bytes=5, static_ram_bytes=3,
                        stack_bytes=2, flash_bytes=7)
    monkeypatch.setattr(cli_firmware, "guided_cost", lambda b, q, every, size: calls.append(
        ("guided_cost", every, size)) or g)
    return calls


@pytest.mark.parametrize("precision, off, code", [("double", 5e-13, 0), ("double", 2e-12, 1),
                                                  ("single", 1.5e-3, 0), ("single", 3e-3, 1)])
def test_firmware_verify_replays_the_recorded_mission_against_the_double_host(monkeypatch, capsys, precision,
                                                                               off, code):
    calls = _verify_stand_ins(monkeypatch, off)
    assert main(["firmware", "--precision", precision, "--estimator", "ukf", "--verify", "5"]) == code
    assert calls == [("build", "flc", "ukf", precision, None, 0), ("scenario", 5, "ukf"), ("record", "log"),
                     ("build", "flc", "ukf", "double", None, 0), ("host", "double", True),
                     ("qemu", precision, True)]
    out = capsys.readouterr().out.splitlines()
    assert out[-2].startswith(f"QEMU replay of 5 periods: max |tau_qemu - tau_host(double)| = {off:.3g} N m "
                              f"(tolerance {cli_firmware.REPLAY_ATOL[precision]:g}); host replay vs "
                              "compiled mission 0.25 N m")
    assert out[-1] == ("cost: 100000 instructions per period (worst), 250 us at 400 MHz and 1 IPC "
                       "(5.0 % of 5 ms); RAM 100 B (context 60, stack 40); flash 9000 B (library 8000)")


def test_firmware_verify_with_guidance_records_the_guided_mission(monkeypatch, capsys):
    calls = _verify_stand_ins(monkeypatch, 5e-11)
    assert main(["firmware", "--guidance", "pursuit", "--verify", "4"]) == 0   # 5e-11 <= 1e-10 guided
    est = cli_firmware.DEFAULT_ESTIMATOR
    assert calls[:3] == [("build", "flc", est, "double", "pursuit", 0), ("guided", 4, "pursuit", 0, est),
                         ("build", "flc", est, "double", "pursuit", 0)]
    assert calls[-1] == ("guided_cost", cli_firmware.guidance_every(cli_firmware.firmware_guidance("pursuit")), 7)
    out = capsys.readouterr().out
    assert "guidance pursuit: max |v_ref_qemu - v_ref_host(double)| = 0 m/s" in out
    assert "(tolerance 1e-10)" in out


@pytest.mark.parametrize("precision", ["double", "single"])
def test_firmware_verify_passes_at_exactly_the_tolerance(monkeypatch, precision):
    _verify_stand_ins(monkeypatch, cli_firmware.REPLAY_ATOL[precision], base=0.0)
    assert main(["firmware", "--precision", precision, "--verify", "5"]) == 0
