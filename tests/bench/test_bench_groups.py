"""Every benchmark group's code path with tiny sizes: the keys it documents are there and
every value is a finite number.  No timing is asserted (timing goals live in
``make bench`` only); this catches a refactor that breaks a group (issue 23: a reshape
error in bench/estimation.py went unnoticed until ``make bench``).

The sizes are made tiny by the groups' own arguments where they have them, otherwise by
patching the group's private size constants/helpers (a rename there fails here loudly,
which is the point)."""

from __future__ import annotations

import functools
import json
import math
import subprocess

import pytest

import ballbot_casadi.bench as bench
from ballbot_casadi.bench import BENCHMARKS
from ballbot_casadi.bench import control as bench_control_mod
from ballbot_casadi.bench import estimation as bench_estimation_mod
from ballbot_casadi.bench import fmu as bench_fmu_mod
from ballbot_casadi.bench import fmu3 as bench_fmu3_mod
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware.toolchain import missing_tools

pytestmark = pytest.mark.needs_cc


def _usage(program: str, line: str) -> None:
    """The C benchmark program the group just built: a call without its arguments is a
    usage line on stderr and exit status 2 (a user error), nothing on stdout."""
    res = subprocess.run([str(build_root() / "bench" / program)], capture_output=True, text=True)
    assert (res.returncode, res.stdout, res.stderr) == (2, "", f"usage: {program} {line}\n")


def _check(data: dict, keys: set[str]) -> None:
    assert keys <= set(data), sorted(keys - set(data))
    for k, v in data.items():
        assert isinstance(v, (int, float)) and not isinstance(v, bool), (k, v)
        assert math.isfinite(v), (k, v)
    json.dumps(data)


def test_every_group_is_covered_here():
    assert set(BENCHMARKS) == {"model", "fmu", "control", "estimation", "montecarlo", "firmware",
                               "firmware_mpc", "firmware_split", "mpc"}


def test_model_group(monkeypatch):
    monkeypatch.setattr(bench, "_python_call_ns", functools.partial(bench._python_call_ns, 200))
    _check(bench.bench_model(n_calls=1000),
           {"ode_ns", "jac_ns", "python_call_ns", "python_over_c_ratio", "ode_target_ns", "jac_target_ns"})
    _usage("bench_model", "N_CALLS x[12] tau[3] p[...]")


def test_control_group(monkeypatch):
    # the Python-loop comparison walks 3 x 400 periods of the mission's inputs: 6.5 s
    orig = bench_control_mod.mission_inputs
    monkeypatch.setattr(bench_control_mod, "mission_inputs", lambda duration=100.0: orig(6.5))
    _check(bench_control_mod.bench_control(n_calls=200, repeats=1),
           {"control_step_us", "control_step_smc_us", "cl_period_us", "mission_100s_s",
            "mission_build_s", "mission_100s_casadi_call_s", "mission_driver_vs_casadi_max_abs_diff",
            "python_loop_period_us", "mission_period_us", "python_loop_ratio",
            "control_step_target_us", "mission_100s_target_s"})
    _usage("bench_control", "N_CALLS INPUT_FILE")


def test_estimation_inputs_are_passed_by_name(monkeypatch):
    """Every function the estimation group times gets one argument per input, each of that
    input's size (taken by name), the gated filters' rejection counters at zero, and
    evaluates to finite outputs at that operating point (CasADi, no C build)."""
    import numpy as np

    seen, flags = {}, {}

    def record(lib, f, inputs, n_calls):
        assert len(inputs) == f.n_in(), f.name()
        for i, v in enumerate(inputs):
            assert np.size(v) == f.numel_in(i), (f.name(), f.name_in(i), np.size(v))
            if f.name_in(i) == "n_rej":
                assert not np.any(v), f.name()
        out = f(*[np.reshape(np.asarray(v, float), f.size_in(i), order="F")
                  for i, v in enumerate(inputs)])
        for o in (out if isinstance(out, (list, tuple)) else [out]):
            assert np.all(np.isfinite(np.asarray(o))), f.name()
        seen[f.name()] = f.name_in()
        flags[f.name()] = {n: float(np.asarray(v)) for n, v in zip(f.name_in(), inputs)
                           if n in ("cascade", "feedforward", "com_observer")}
        return 1.0

    orig = bench_estimation_mod._full_scenario
    monkeypatch.setattr(bench_estimation_mod, "_full_scenario", lambda: orig().replace(duration=0.5))
    monkeypatch.setattr(bench_estimation_mod, "c_function_us", record)
    bench_estimation_mod.bench_estimation(n_calls=1, repeats=1)
    assert {"ballbot_qukf", "ballbot_vukf", "ballbot_qukf_heading", "ballbot_qekf_heading",
            "ballbot_tilt_correction", "ballbot_com_observer"} <= set(seen)
    assert "n_rej" in seen["ballbot_qukf"]
    # the embedded software is timed in the scenario's own set-up (its switches as 0 / 1)
    inp = orig().replace(duration=0.5).inputs()
    want = {k: (1.0 if inp.get(k) else 0.0) for k in ("cascade", "feedforward", "com_observer")}
    timed = [v for v in flags.values() if v]
    assert timed and all(v == want for v in timed), (timed, want)
    assert want == {"cascade": 1.0, "feedforward": 0.0, "com_observer": 0.0}  # the full study's set-up


def test_estimation_filters_are_timed_at_one_consistent_operating_point(monkeypatch):
    """The velocity filter is timed with what the attitude filter of the same period hands
    it in the embedded software: the attitude estimate's first states and the attitude
    filter's own ``P_att`` output; the attitude filter gets the velocity filter's ball
    acceleration ``(a_x, a_y, 0)`` (CasADi, no C build)."""
    import numpy as np

    from ballbot_casadi.core.layout import ATTITUDE_FILTER_STATE as XA
    from ballbot_casadi.core.layout import VELOCITY_FILTER_STATE as XV

    calls = []

    def record(lib, f, inputs, n_calls):
        args = [np.reshape(np.asarray(v, float), f.size_in(i), order="F") for i, v in enumerate(inputs)]
        out = f.call(args)
        calls.append((f.name(), dict(zip(f.name_in(), args)), dict(zip(f.name_out(), out))))
        return 1.0

    orig = bench_estimation_mod._full_scenario
    monkeypatch.setattr(bench_estimation_mod, "_full_scenario", lambda: orig().replace(duration=0.5))
    monkeypatch.setattr(bench_estimation_mod, "c_function_us", record)
    bench_estimation_mod.bench_estimation(n_calls=1, repeats=1)
    pairs = [(a, v) for a, v in zip(calls, calls[1:]) if a[0] == "ballbot_qukf" and v[0] == "ballbot_vukf"]
    assert len(pairs) == 3, [c[0] for c in calls]  # the scenario's, matched and adaptive filters
    for (_, att_in, att_out), (_, vel_in, _) in pairs:
        np.testing.assert_array_equal(vel_in["P_att"], np.asarray(att_out["P_att"]))
        np.testing.assert_array_equal(vel_in["att"].ravel(), att_in["xhat"].ravel()[:XA.size])
        a = vel_in["xhat"].ravel()[XV["a"]]
        np.testing.assert_array_equal(att_in["a"].ravel(), np.r_[a, 0.0])
        assert np.all(a != 0.0)  # a real operating point: both axes move


def test_estimation_group(monkeypatch):
    orig = bench_estimation_mod._full_scenario
    monkeypatch.setattr(bench_estimation_mod, "_full_scenario", lambda: orig().replace(duration=0.5))
    real_loop, loops = bench_estimation_mod.ClosedLoop, []
    monkeypatch.setattr(bench_estimation_mod, "ClosedLoop", lambda **kw: loops.append(kw) or real_loop(**kw))
    data = bench_estimation_mod.bench_estimation(n_calls=50, repeats=1)
    assert loops == [{"compiled": True}]  # the compiled mission is what is timed
    _check(data,
           {"mission_full_100s_s", "mission_full_100s_with_inputs_s", "mission_full_100s_target_s",
            "qukf_step_us", "vukf_step_us", "tilt_correction_step_us", "com_observer_step_us",
            "estimator_step_us", "embedded_step_us", "estimator_step_target_us",
            "estimator_step_adaptive_us", "estimator_step_adaptive_over_plain",
            "estimator_step_adaptive_over_matched"})
    # the ratios are of the same run's keys
    for other, key in (("plain", "estimator_step_us"), ("matched", "estimator_step_matched_us")):
        assert data[f"estimator_step_adaptive_over_{other}"] == pytest.approx(
            data["estimator_step_adaptive_us"] / data[key], rel=1e-12)


@pytest.mark.slow  # two Dask clusters: ~13 s even in-process
def test_montecarlo_group(monkeypatch):
    import distributed

    real = distributed.LocalCluster
    # in-process workers: the group's code path without spawning processes
    monkeypatch.setattr(distributed, "LocalCluster", lambda **kw: real(**{**kw, "processes": False}))
    data = BENCHMARKS["montecarlo"](n_runs=2, duration=0.1)
    _check(data, {"montecarlo_runs_per_s_1w", "montecarlo_runs_per_s_2w", "montecarlo_parallel_efficiency",
                  "montecarlo_serial_runs_per_s", "montecarlo_dask_equals_serial", "montecarlo_runs",
                  "montecarlo_run_duration_s"})
    assert data["montecarlo_dask_equals_serial"] == 1.0


def test_mpc_group():
    data = BENCHMARKS["mpc"](duration=0.5, mission=0.5, repeats=3)
    _check(data, {"mpc_solve_us_median", "mpc_solve_us_p99", "mpc_solve_us_max", "mpc_failures",
                  "mpc_solve_us_median_min", "mpc_solve_us_p99_min", "mpc_solve_repeats",
                  "mpc_solve_cpu_us_median", "mpc_solve_cpu_us_p99", "mpc_solve_cpu_us_max",
                  "mpc_solve_cpu_us_median_min", "mpc_solve_cpu_us_p99_min",
                  "mpc_workspace_bytes", "mpc_mission_s", "mpc_mission_ratio",
                  "mpc_solve_us_p99_target", "mpc_workspace_bytes_target"})
    assert data["mpc_solve_repeats"] == 3.0
    # each solve's minimum over the passes is below every pass's time, so its quantiles
    # are below those of all passes pooled (whatever the machine's load)
    assert data["mpc_solve_us_median_min"] <= data["mpc_solve_us_median"]
    assert data["mpc_solve_us_p99_min"] <= data["mpc_solve_us_p99"] <= data["mpc_solve_us_max"]
    assert data["mpc_solve_cpu_us_p99_min"] <= data["mpc_solve_cpu_us_p99"]
    assert 0 < data["mpc_workspace_bytes"] <= data["mpc_workspace_bytes_target"]


def test_mpc_group_refuses_bad_repeats():
    with pytest.raises(ScenarioError, match="repeats"):
        BENCHMARKS["mpc"](duration=0.5, mission=0.5, repeats=0)


class _ShortScenario:
    """A scenario whose ``replace(duration=...)`` keeps a tiny duration (the SIL bench asks
    for 100 s)."""

    def __init__(self, sc, duration: float):
        self._sc, self._d = sc, duration

    def replace(self, **kw):
        return self._sc.replace(**{**kw, "duration": min(kw.get("duration", self._d), self._d)})


@pytest.mark.slow  # PythonFMU build, libcosim and CasADi's FMU export: ~15 s with cached builds
@pytest.mark.fmi_extra
def test_fmu_group(monkeypatch):
    pytest.importorskip("libcosimpy")
    pytest.importorskip("pythonfmu")
    load = bench_fmu_mod.load_scenario_file

    def short(path):
        sf = load(path)
        return type("SF", (), {"scenario": _ShortScenario(sf.scenario, 0.1)})()
    monkeypatch.setattr(bench_fmu_mod, "load_scenario_file", short)
    monkeypatch.setattr(bench_fmu_mod, "_STOP", 0.05)
    monkeypatch.setattr(bench_fmu3_mod, "_STOP", 0.02)
    data = BENCHMARKS["fmu"]()
    _check(data, {"fmu_plant_step_us", "fmu_native_cosim_s", "fmu_pythonfmu_cosim_s", "fmu_vs_pythonfmu_ratio",
                  "fmu_vs_pythonfmu_ratio_target", "fmu_vs_pythonfmu_state_diff", "fmu_controller_step_us",
                  "fmu_controller_step_target_us", "sil_100s_s", "sil_mission_100s_s", "sil_vs_mission_ratio",
                  "fmu3_vs_casadi_export_ratio", "fmu3_vs_casadi_export_ratio_sampled",
                  "fmu3_vs_casadi_export_state_diff"})
    # the two plant FMUs integrate the same model: the states agree
    assert data["fmu_vs_pythonfmu_state_diff"] < 1e-9


@pytest.mark.firmware
def test_firmware_group():
    if missing_tools():
        assert BENCHMARKS["firmware"](n_periods=4) == {"firmware_available": 0.0}
        pytest.skip(f"firmware toolchain missing: {missing_tools()}")
    _check(BENCHMARKS["firmware"](n_periods=4),
           {"firmware_available", "firmware_step_instructions", "firmware_single_step_instructions",
            "firmware_ram_bytes", "firmware_flash_bytes", "firmware_step_instructions_target"})


@pytest.mark.firmware
@pytest.mark.slow
def test_firmware_mpc_group():
    # builds the guided mission and the firmware with the MPC (minutes the first time)
    if missing_tools():
        assert BENCHMARKS["firmware_mpc"](n_periods=21) == {"firmware_mpc_available": 0.0}
        pytest.skip(f"firmware toolchain missing: {missing_tools()}")
    data = BENCHMARKS["firmware_mpc"](n_periods=21)
    _check(data, {"firmware_mpc_available", "firmware_mpc_instructions_max",
                  "firmware_mpc_instructions_median", "firmware_mpc_first_instructions",
                  "firmware_mpc_hold_instructions_max", "firmware_mpc_solve_ms_at_480mhz",
                  "firmware_mpc_ram_bytes", "firmware_mpc_workspace_bytes",
                  "firmware_mpc_flash_bytes", "firmware_mpc_workspace_bytes_target"})
    # a sample costs more than holding the reference; the cold first sample (5 QPs) most
    assert data["firmware_mpc_hold_instructions_max"] < data["firmware_mpc_instructions_max"]
    assert data["firmware_mpc_instructions_max"] < data["firmware_mpc_first_instructions"]
    assert data["firmware_mpc_workspace_bytes"] < data["firmware_mpc_guidance_workspace_bytes"]


@pytest.mark.firmware
@pytest.mark.slow
def test_firmware_split_group():
    # the split build and the guided missions with latency (minutes the first time; the
    # lap shortened to 3 s)
    if missing_tools():
        assert BENCHMARKS["firmware_split"](n_periods=41) == {"firmware_split_available": 0.0}
        pytest.skip(f"firmware toolchain missing: {missing_tools()}")
    data = BENCHMARKS["firmware_split"](n_periods=41, lap_s=3.0)
    _check(data, {"firmware_split_available", "firmware_split_isr_instructions_max",
                  "firmware_split_isr_instructions_median", "firmware_split_isr_instructions_target",
                  "firmware_split_sample_instructions_max", "firmware_split_first_sample_instructions",
                  "firmware_split_latency_periods", "firmware_split_margin",
                  "firmware_split_margin_target", "firmware_split_latency_min",
                  "firmware_split_ram_bytes", "firmware_split_ram_bytes_target",
                  "firmware_split_flash_bytes", "firmware_split_replay_max_abs_diff",
                  "firmware_split_lateral_rms_settled_m",
                  "firmware_split_lateral_rms_settled_latency0_m"})
    # the interrupt step never runs the QP: a small fraction of a background sample
    assert data["firmware_split_isr_instructions_max"] < 0.1 * data["firmware_split_sample_instructions_max"]
    assert data["firmware_split_replay_max_abs_diff"] < 1e-9
