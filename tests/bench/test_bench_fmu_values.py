"""The FMU benchmark group's arithmetic with hand values and nothing timed or built: the
builds, hosts, fmpy runs, libcosim and clocks replaced by fakes, every key written to
bench.json read back (ratios, best-of, state differences, start values, the targets)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from types import ModuleType, SimpleNamespace

import numpy as np
import pytest
from _clock import Clock

from ballbot_casadi.bench import fmu as bfm
from ballbot_casadi.bench import fmu3 as bf3
from ballbot_casadi.fmi.plant.plant import X0_PREFIX
from ballbot_casadi.model.dynamics import STATE_NAMES
from ballbot_casadi.model.numeric import make_state


def test_fmu_group_by_hand(monkeypatch, fake_run):
    plant = SimpleNamespace(binary=Path("/b/plant.so"), guid="{g}", fmu=Path("/b/plant.fmu"))
    monkeypatch.setattr(bfm, "build_fmu", lambda: plant)
    monkeypatch.setattr(bfm, "build_tool", lambda b, name: f"/t/{name}")
    calls = []
    monkeypatch.setattr(bfm.subprocess, "run", fake_run(lambda cmd: json.dumps({"step_us": 3.5}), calls))
    monkeypatch.setattr(bfm, "build_pythonfmu", lambda out: Path("/p/py.fmu"))
    xn = np.arange(24.0).reshape(2, 12)
    xp = xn.copy()
    xp[1, 5] -= 0.25
    xp[0, 2] += 0.125
    timed = {}

    def fmpy_time(fmu, start, reps=3):
        timed[fmu] = (start, reps)
        return (0.5, xn) if fmu == plant.fmu else (12.0, xp)
    monkeypatch.setattr(bfm, "_fmpy_time", fmpy_time)
    monkeypatch.setattr(bfm, "bench_controller_fmu", lambda: {"fmu_controller_step_us": 7.0})
    monkeypatch.setattr(bfm, "bench_sil", lambda: {"sil_100s_s": 2.0})
    monkeypatch.setattr(bfm, "bench_fmu3_vs_casadi", lambda: {"fmu3_vs_casadi_export_ratio": 0.9})
    out = bfm.bench_fmu()
    assert [c for c, _ in calls] == [["/t/host", "/b/plant.so", "{g}", "2000", "0.005", "0.02",
                                      "-0.01", "0.005", "0.002", "5"]]
    assert calls[0][1]["check"] is True
    taus = {"tau0": 0.02, "tau1": -0.01, "tau2": 0.005}
    x0 = dict(zip((X0_PREFIX + n for n in STATE_NAMES), make_state(roll=0.002).tolist()))
    assert timed[plant.fmu] == ({**taus, **x0}, 3)
    assert timed[Path("/p/py.fmu")] == (taus, 2)
    assert out == {"fmu_plant_step_us": 3.5, "fmu_native_cosim_s": 0.5, "fmu_pythonfmu_cosim_s": 12.0,
                   "fmu_vs_pythonfmu_ratio": 24.0, "fmu_vs_pythonfmu_ratio_target": 20.0,
                   "fmu_vs_pythonfmu_state_diff": 0.25, "fmu_controller_step_us": 7.0,
                   "sil_100s_s": 2.0, "fmu3_vs_casadi_export_ratio": 0.9}


def test_fmpy_time_columns_are_the_states_in_order(monkeypatch):
    seen = {}

    def best(fmu, reps, **kw):
        seen.update(fmu=fmu, reps=reps, **kw)
        return 0.75, {n: np.array([i, 10.0 + i]) for i, n in enumerate(STATE_NAMES)}
    monkeypatch.setattr(bfm, "fmpy_best_time", best)
    t, x = bfm._fmpy_time(Path("a.fmu"), {"tau0": 1.0}, reps=4)
    assert t == 0.75
    np.testing.assert_array_equal(x, [np.arange(12.0), 10.0 + np.arange(12.0)])
    assert seen == {"fmu": Path("a.fmu"), "reps": 4, "fmi_type": "CoSimulation", "stop_time": 2.0,
                    "output_interval": 0.005, "start_values": {"tau0": 1.0},
                    "output": list(STATE_NAMES)}


def test_controller_fmu_group_by_hand(monkeypatch, fake_run):
    monkeypatch.setattr(bfm, "controller_spec", lambda: "spec")
    monkeypatch.setattr(bfm, "build_fmu_from_spec", lambda spec: SimpleNamespace(
        binary=Path(f"/c/{spec}.so"), guid="{c}"))
    monkeypatch.setattr(bfm, "build_tool", lambda b, name: f"/t/{name}")
    calls = []
    monkeypatch.setattr(bfm.subprocess, "run", fake_run(lambda cmd: '{"step_us": 4.25}', calls))
    assert bfm.bench_controller_fmu() == {"fmu_controller_step_us": 4.25,
                                          "fmu_controller_step_target_us": 15.0}
    assert [c for c, _ in calls] == [["/t/controller_host", "/c/spec.so", "{c}", "2000", "5"]]
    assert calls[0][1]["check"] is True


def _fake_libcosim(monkeypatch, ok=True):
    simulated = []

    class Execution:
        @staticmethod
        def from_ssp_file(path):
            simulated.append(("load", path))
            return SimpleNamespace(simulate_until=lambda ns: simulated.append(("until", ns)) or ok)
    ex = ModuleType("libcosimpy.CosimExecution")
    ex.CosimExecution = Execution
    logging = ModuleType("libcosimpy.CosimLogging")
    logging.CosimLogLevel = SimpleNamespace(ERROR="error")
    logging.log_output_level = lambda level: simulated.append(("log", level))
    monkeypatch.setitem(sys.modules, "libcosimpy", ModuleType("libcosimpy"))
    monkeypatch.setitem(sys.modules, "libcosimpy.CosimExecution", ex)
    monkeypatch.setitem(sys.modules, "libcosimpy.CosimLogging", logging)
    return simulated


class _Sc:
    def __init__(self, duration=10.0):
        self.duration = duration

    def replace(self, duration):
        return _Sc(duration)


def test_sil_group_by_hand(monkeypatch, tmp_path):
    simulated = _fake_libcosim(monkeypatch)
    loaded = []
    monkeypatch.setattr(bfm, "load_scenario_file", lambda p: loaded.append(p) or SimpleNamespace(
        scenario=_Sc()))
    monkeypatch.setattr(bfm, "build_root", lambda: tmp_path)
    monkeypatch.setattr(bfm, "write_sil_ssp", lambda sc, path: (sc.duration, path))
    monkeypatch.setattr(bfm, "ClosedLoop", lambda: "sim")
    missions = []
    monkeypatch.setattr(bfm, "run_scenario", lambda sc, sim: missions.append((sc.duration, sim)))
    monkeypatch.setattr(bfm, "time", Clock([3.0, 2.5, 0.5, 0.4]))
    out = bfm.bench_sil(reps=2)
    assert Path(loaded[0]).name == "full_velocity.toml"
    ssp = (100.0, tmp_path / "bench" / "sil" / "BallbotSIL_100s.ssp")
    assert simulated == [("log", "error"), ("load", str(ssp)), ("until", 100_000_000_000),
                         ("load", str(ssp)), ("until", 100_000_000_000)]
    assert missions == [(1.0, "sim"), (100.0, "sim"), (100.0, "sim")]
    assert out == pytest.approx({"sil_100s_s": 2.5, "sil_mission_100s_s": 0.4,
                                 "sil_vs_mission_ratio": 6.25}, rel=1e-12)


def test_sil_group_refuses_a_stopped_run(monkeypatch, tmp_path):
    _fake_libcosim(monkeypatch, ok=False)
    monkeypatch.setattr(bfm, "load_scenario_file", lambda p: SimpleNamespace(scenario=_Sc()))
    monkeypatch.setattr(bfm, "build_root", lambda: tmp_path)
    monkeypatch.setattr(bfm, "write_sil_ssp", lambda sc, path: path)
    with pytest.raises(RuntimeError, match="libcosim stopped before the end of the 100 s SIL run"):
        bfm.bench_sil()


def test_fmu3_time_keeps_the_value_after_each_event(monkeypatch):
    seen = {}

    def best(fmu, reps, **kw):
        seen.update(fmu=fmu, reps=reps, **kw)
        t = np.array([0.0, 0.5, 0.5, 1.0])  # a time event at 0.5 repeats its time
        return 1.5, {"time": t, **{n: np.array([i, 100.0 + i, 200.0 + i, 300.0 + i])
                                   for i, n in enumerate(STATE_NAMES)}}
    monkeypatch.setattr(bf3, "fmpy_best_time", best)
    t, x = bf3._time(Path("m.fmu"), {"tau0": 0.1}, reps=2)
    assert t == 1.5
    np.testing.assert_array_equal(x, [np.arange(12.0), 200.0 + np.arange(12.0),
                                      300.0 + np.arange(12.0)])
    assert seen == {"fmu": Path("m.fmu"), "reps": 2, "fmi_type": "ModelExchange", "solver": "CVode",
                    "relative_tolerance": 1e-10, "stop_time": 1.0, "output_interval": 0.005,
                    "start_values": {"tau0": 0.1}, "output": list(STATE_NAMES)}


def test_fmu3_group_by_hand(monkeypatch):
    monkeypatch.setattr(bf3, "build_fmu", lambda fmi_version: SimpleNamespace(
        fmu=Path(f"/f/plant{fmi_version}.fmu")))
    monkeypatch.setattr(bf3, "casadi_export_fmu", lambda: Path("/f/casadi.fmu"))
    starts = []
    x_ours = np.zeros((3, 12))
    x_theirs = x_ours.copy()
    x_theirs[2, 7] = -0.375

    def timed(fmu, start, reps=3):
        starts.append((fmu, start))
        return {1: (2.0, x_ours), 2: (3.0, x_ours), 3: (4.0, x_theirs)}[len(starts)]
    monkeypatch.setattr(bf3, "_time", timed)
    out = bf3.bench_fmu3_vs_casadi()
    taus = {"tau0": 0.1, "tau1": -0.05, "tau2": 0.02}
    x0 = {X0_PREFIX + n: float(v) for n, v in zip(STATE_NAMES, make_state(roll=0.05))}
    assert starts == [(Path("/f/plant3.fmu"), {**taus, **x0, "Ts_sensor": 100.0}),
                      (Path("/f/plant3.fmu"), {**taus, **x0}), (Path("/f/casadi.fmu"), taus)]
    assert out == {"fmu3_cvode_1s_s": 2.0, "fmu3_cvode_1s_sampled_s": 3.0,
                   "casadi_export_cvode_1s_s": 4.0, "fmu3_vs_casadi_export_ratio": 0.5,
                   "fmu3_vs_casadi_export_ratio_sampled": 0.75,
                   "fmu3_vs_casadi_export_state_diff": 0.375}
    assert bf3.CASADI_EXPORT_NAME == "BallbotCasadiExport"
