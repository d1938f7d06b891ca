"""What the benchmark groups compute from their measurements, with hand values and nothing
timed: each group's measuring calls (builds, replays, costs, clocks) replaced by fakes that
return known numbers, then every key written to bench.json read back against the number
it must hold (the arguments each measuring call got, the ratios, maxima, medians and
percentiles, the targets).  test_bench_groups runs the groups for real with tiny sizes."""

from __future__ import annotations

import json
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest
from _clock import Clock

import ballbot_casadi.bench as bench
from ballbot_casadi.bench import control as bench_control_mod
from ballbot_casadi.bench import firmware as bf
from ballbot_casadi.bench import guidance as bg
from ballbot_casadi.bench import montecarlo as bm
from ballbot_casadi.codegen.libraries import model_functions_list
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import BallbotError, BuildError
from ballbot_casadi.sim.embedded import VALID
from ballbot_casadi.sim.ports import PERIOD_CONSTANTS, PERIOD_SEQUENCES


def _fake_toolchain(monkeypatch, missing=()):
    monkeypatch.setattr(bf, "missing_tools", lambda: list(missing))


@pytest.mark.parametrize("group, key", [(bf.bench_firmware, "firmware_available"),
                                        (bf.bench_firmware_mpc, "firmware_mpc_available"),
                                        (bf.bench_firmware_split, "firmware_split_available")])
def test_firmware_groups_without_the_toolchain(monkeypatch, group, key):
    _fake_toolchain(monkeypatch, ["qemu-system-arm"])
    assert group() == {key: 0.0}


def test_firmware_group_by_hand(monkeypatch):
    _fake_toolchain(monkeypatch)
    calls = []
    monkeypatch.setattr(bf, "replay_scenario", lambda n: ("scenario", n))
    monkeypatch.setattr(bf, "record_log", lambda sc: ("rec", sc))
    monkeypatch.setattr(bf, "build_firmware", lambda precision: SimpleNamespace(precision=precision))
    monkeypatch.setattr(bf, "run_qemu", lambda b, rec: calls.append((b.precision, rec)) or b)
    costs = {"double": (110.0, 100.0, 1.5, 30, 20, 5, 400, 300),
             "single": (210.0, 200.0, 2.5, 31, 21, 6, 401, 301)}

    def cost(b, q):
        v = costs[q.precision]
        return SimpleNamespace(step_instructions_max=v[0], step_instructions=v[1], step_us=v[2],
                               ram_bytes=v[3], context_bytes=v[4], stack_bytes=v[5],
                               image_flash_bytes=v[6], library_flash_bytes=v[7])
    monkeypatch.setattr(bf, "firmware_cost", cost)
    out = bf.bench_firmware(n_periods=7)
    assert calls == [("double", ("rec", ("scenario", 7))), ("single", ("rec", ("scenario", 7)))]
    want = {"firmware_available": 1.0, "firmware_clock_hz": bf.CLOCK_HZ,
            "firmware_ipc_assumed": bf.IPC,
            "firmware_step_instructions_target": 200000.0, "firmware_ram_bytes_target": 32768.0,
            "firmware_flash_bytes_target": 262144.0}
    for pre, p in (("firmware", "double"), ("firmware_single", "single")):
        v = costs[p]
        want.update({f"{pre}_step_instructions": v[0], f"{pre}_step_instructions_median": v[1],
                     f"{pre}_step_us_at_400mhz": v[2], f"{pre}_ram_bytes": v[3],
                     f"{pre}_context_bytes": v[4], f"{pre}_stack_bytes": v[5],
                     f"{pre}_flash_bytes": v[6], f"{pre}_library_flash_bytes": v[7]})
    assert out == want
    assert all(type(v) is float for v in out.values())
    assert (bf.CLOCK_HZ, bf.IPC) == (400e6, 1.0)


def test_firmware_mpc_group_by_hand(monkeypatch):
    _fake_toolchain(monkeypatch)
    solver, block = object(), SimpleNamespace(find_function=lambda n: {"ballbot_mpc": solver}[n])
    monkeypatch.setattr(bf, "firmware_guidance", lambda g: SimpleNamespace(name=g, function=block))
    monkeypatch.setattr(bf, "guidance_every", lambda law: 20 if law.name == "mpc" else 0)
    rec = SimpleNamespace(values=SimpleNamespace(guidance=np.zeros(123)))
    monkeypatch.setattr(bf, "record_guided_log", lambda n: rec if n == 9 else None)
    monkeypatch.setattr(bf, "build_firmware", lambda precision, guidance: (precision, guidance))
    monkeypatch.setattr(bf, "run_qemu", lambda b, r: ("q", b, r))
    monkeypatch.setattr(bf, "arm_workspace_bytes", lambda f: {id(solver): 1000, id(block): 5000}[id(f)])
    seen = {}

    def cost(b, q, every, n_data):
        seen.update(b=b, q=q, every=every, n=n_data)
        return SimpleNamespace(solve_instructions_max=9e5, solve_instructions_median=8e5,
                               first_instructions=4e6, hold_instructions_max=3e4,
                               hold_instructions_median=2e4,
                               solve_ms=lambda clock: 9e5 / clock * 1e3 * (clock == bf.CLOCK_HZ_MAX),
                               ram_bytes=70000, context_bytes=60000, stack_bytes=10000,
                               flash_bytes=300000, guidance_data_bytes=12000)
    monkeypatch.setattr(bf, "guided_cost", cost)
    out = bf.bench_firmware_mpc(n_periods=9)
    assert seen == {"b": ("double", "mpc"), "q": ("q", ("double", "mpc"), rec), "every": 20,
                    "n": 123}
    assert out == {
        "firmware_mpc_available": 1.0, "firmware_mpc_instructions_max": 9e5,
        "firmware_mpc_instructions_median": 8e5, "firmware_mpc_first_instructions": 4e6,
        "firmware_mpc_hold_instructions_max": 3e4, "firmware_mpc_hold_instructions_median": 2e4,
        "firmware_mpc_solve_ms_at_480mhz": pytest.approx(1.875, rel=1e-12),
        "firmware_mpc_ram_bytes": 70000.0, "firmware_mpc_context_bytes": 60000.0,
        "firmware_mpc_stack_bytes": 10000.0, "firmware_mpc_workspace_bytes": 1000.0,
        "firmware_mpc_guidance_workspace_bytes": 5000.0, "firmware_mpc_flash_bytes": 300000.0,
        "firmware_mpc_path_table_bytes": 12000.0, "firmware_mpc_workspace_bytes_target": 65536.0,
        "firmware_mpc_ipc_assumed": 1.0}


@pytest.mark.parametrize("tau_d, v_d, want", [(0.3, -0.5, 0.5), (-0.7, 0.2, 0.7)])
def test_firmware_split_group_by_hand(monkeypatch, tau_d, v_d, want):
    _fake_toolchain(monkeypatch)
    law = SimpleNamespace(latency=4, first_latency=17)
    monkeypatch.setattr(bf, "firmware_guidance", lambda g, latency: law if (g, latency) == ("mpc", 4)
                        else None)
    tau, v = np.full((6, 3), 0.1), np.full((6, 3), 0.3)   # non-zero: a difference, not a sum
    rec = SimpleNamespace(tau_mission=tau, v_ref_mission=v)
    monkeypatch.setattr(bf, "record_guided_log", lambda n, latency: rec if (n, latency) == (11, 4)
                        else None)
    monkeypatch.setattr(bf, "build_firmware", lambda precision, guidance, latency:
                        (precision, guidance, latency))
    q_tau, q_v = tau.copy(), v.copy()
    q_tau[2, 1], q_v[4, 0] = 0.1 + tau_d, 0.3 + v_d
    q_tau[1, 2], q_v[3, 1] = 0.1 + tau_d / 2, 0.3 + v_d / 2
    q = SimpleNamespace(tau=q_tau, v_ref=q_v)
    monkeypatch.setattr(bf, "run_qemu", lambda b, r: q if (b, r) == (("double", "mpc", 4), rec) else None)
    seen, lap = {}, []

    def cost(b, qq, latency, first):
        seen.update(b=b, q=qq, latency=latency, first=first)
        return SimpleNamespace(isr_instructions_max=60000.0, isr_instructions_median=40000.0,
                               sample_instructions_max=1.2e6, sample_instructions_median=1.1e6,
                               first_sample_instructions=5e6, latency=latency, first_latency=first,
                               margin=lambda: 2.25, first_margin=lambda: 3.5, ram_bytes=150000,
                               context_bytes=100000, stack_bytes=30000, bg_stack_bytes=20000,
                               flash_bytes=900000)
    monkeypatch.setattr(bf, "split_cost", cost)
    monkeypatch.setattr(bf, "min_latency", lambda isr, sample, margin: 7 if (isr, sample, margin) == (
        60000.0, 1.2e6, bf.SPLIT_MARGIN) else -1)
    monkeypatch.setattr(bf, "lap_lateral_rms", lambda latency, lap_s: lap.append((latency, lap_s))
                        or 0.01 + latency / 1000)
    out = bf.bench_firmware_split(n_periods=11, latency=4, lap_s=3.0)
    assert seen == {"b": ("double", "mpc", 4), "q": q, "latency": 4, "first": 17}
    assert lap == [(4, 3.0), (0, 3.0)]
    period = 0.005 * 480e6
    assert out == {
        "firmware_split_available": 1.0,
        "firmware_split_isr_instructions_max": 60000.0,
        "firmware_split_isr_instructions_median": 40000.0,
        "firmware_split_isr_instructions_target": 200000.0,
        "firmware_split_period_instructions": pytest.approx(period, rel=1e-12),
        "firmware_split_isr_period_fraction": pytest.approx(60000.0 / period, rel=1e-12),
        "firmware_split_sample_instructions_max": 1.2e6,
        "firmware_split_sample_instructions_median": 1.1e6,
        "firmware_split_first_sample_instructions": 5e6,
        "firmware_split_latency_periods": 4.0, "firmware_split_first_latency_periods": 17.0,
        "firmware_split_margin": 2.25, "firmware_split_first_margin": 3.5,
        "firmware_split_margin_target": bf.SPLIT_MARGIN, "firmware_split_latency_min": 7.0,
        "firmware_split_ram_bytes": 150000.0, "firmware_split_ram_bytes_target": 524288.0,
        "firmware_split_context_bytes": 100000.0, "firmware_split_stack_bytes": 30000.0,
        "firmware_split_bg_stack_bytes": 20000.0, "firmware_split_flash_bytes": 900000.0,
        "firmware_split_flash_bytes_target": 2097152.0,
        "firmware_split_replay_max_abs_diff": pytest.approx(want, rel=1e-15),
        "firmware_split_lateral_rms_settled_m": pytest.approx(0.014, rel=1e-12),
        "firmware_split_lateral_rms_settled_latency0_m": pytest.approx(0.01, rel=1e-12),
        "firmware_split_lateral_rms_settled_m_target": 0.02,
        "firmware_split_ipc_assumed": 1.0}
    assert (bf.LAP_S, bf.SETTLE_S) == (27.0, 2.0)


def test_lap_lateral_rms_by_hand(monkeypatch):
    """The lap's lateral RMS over the sub-sampled true positions from SETTLE_S on, the
    sample at exactly 2.0 s included, with the latency and duration handed through."""
    seen = {}

    class _Sc:
        def replace(self, **kw):
            seen["replace"] = kw
            return "scenario"

    monkeypatch.setattr(bf, "default_guidance_path", lambda: "path")
    monkeypatch.setattr(bf, "path_scenario", lambda path, d: seen.update(ps=(path, d)) or _Sc())
    monkeypatch.setattr(bf, "scenario_law", lambda sc, lat: seen.update(law=(sc, lat)) or "law")
    n = 30 * bf.SAMPLE_EVERY + 1                     # 31 sub-samples, t = 0, 0.1, ..., 3.0 s
    state = np.zeros((n, STATE.size))
    state[:, bf.STATE_XY] = np.arange(n)[:, None] * [1.0, -1.0]
    monkeypatch.setattr(bf, "run_guided", lambda path, law, d, scenario: seen.update(
        run=(path, law, d, scenario)) or {"state": state})

    def errors(path, xy):
        seen["xy"] = xy.copy()
        lat = np.zeros(xy.shape[0])
        lat[20] = 3.0                                # t = 2.0 s exactly: counted
        lat[30] = 4.0
        lat[19] = 100.0                              # t = 1.9 s: before the window
        return None, lat
    monkeypatch.setattr(bf, "path_errors", errors)
    rms = bf.lap_lateral_rms(latency=3, duration=5.5)
    assert rms == pytest.approx(np.sqrt((9.0 + 16.0) / 11), rel=1e-14)
    assert seen["ps"] == ("path", 5.5) and seen["replace"] == {"guidance": "mpc"}
    assert seen["law"] == ("scenario", 3) and seen["run"] == ("path", "law", 5.5, "scenario")
    np.testing.assert_array_equal(seen["xy"], state[::bf.SAMPLE_EVERY, bf.STATE_XY])
    assert seen["xy"].shape == (31, 2)


def test_mpc_group_statistics_by_hand(monkeypatch):
    # 5 solves; pass 1 is the mission's own timing, passes 2 and 3 the replays
    pass1 = np.array([10.0, 50.0, 20.0, 40.0, 30.0])
    pass2 = np.array([12.0, 45.0, 25.0, 35.0, 60.0])
    pass3 = np.array([11.0, 55.0, 15.0, 38.0, 28.0])
    cpu1, cpu2, cpu3 = pass1 / 2, pass2 / 2, pass3 / 2
    clock = Clock([*(pass2 * 1e-6), *(pass3 * 1e-6), 2.0, 0.5], [*(cpu2 * 1e-6), *(cpu3 * 1e-6)])
    monkeypatch.setattr(bg, "time", clock)
    made = []

    class MPC:
        def __init__(self):
            self.function = lambda *a: a
            self.solve_s, self.solve_cpu_s = list(pass1 * 1e-6), list(cpu1 * 1e-6)
            self.failures, self.residuals = 2, [1e-9, 3e-7, 2e-8]
            made.append(self)

    paths = []

    def compiled_mpc(path):
        paths.append(path)
        return MPC(), 4321

    monkeypatch.setattr(bg, "compiled_mpc", compiled_mpc)
    runs = []

    def run_path(path, mpc, duration, sim):
        runs.append(duration)
        paths.append(path)
        if len(runs) == 1:
            for i in range(5):
                mpc.function(np.array([float(i)]))
    monkeypatch.setattr(bg, "run_path", run_path)
    monkeypatch.setattr(bg, "ClosedLoop", lambda: SimpleNamespace(simulate=lambda *a, **k: None))
    monkeypatch.setattr(bg, "path_scenario", lambda p, d: SimpleNamespace(inputs=lambda: {}))
    out = bg.bench_mpc(duration=0.7, mission=1.3, repeats=3)
    assert runs == [0.7, 1.3]
    W = np.vstack([pass1, pass2, pass3])
    C = W / 2
    best = W.min(axis=0)  # 10, 45, 15, 35, 28
    np.testing.assert_array_equal(best, [10.0, 45.0, 15.0, 35.0, 28.0])
    approx = lambda v: pytest.approx(v, rel=1e-9)  # noqa: E731
    assert out["mpc_solve_us_median"] == approx(30.0)  # the 8th of the 15 sorted
    assert out["mpc_solve_us_max"] == approx(60.0)
    assert out["mpc_solve_us_p99"] == approx(np.percentile(W, 99))
    assert out["mpc_solve_us_p99"] == approx(55.0 + 0.99 * 14 % 1 * 5.0)  # between 55 and 60
    assert out["mpc_solve_us_median_min"] == approx(28.0)
    assert out["mpc_solve_us_p99_min"] == approx(35.0 + (0.99 * 4 % 1) * 10.0)
    assert out["mpc_solve_cpu_us_median"] == approx(15.0)
    assert out["mpc_solve_cpu_us_max"] == approx(30.0)
    assert out["mpc_solve_cpu_us_p99"] == approx(np.percentile(C, 99))
    assert out["mpc_solve_cpu_us_median_min"] == approx(14.0)
    assert out["mpc_solve_cpu_us_p99_min"] == approx((35.0 + (0.99 * 4 % 1) * 10.0) / 2)
    assert out["mpc_solve_repeats"] == 3.0 and out["mpc_failures"] == 2.0
    assert out["mpc_residual_max"] == 3e-7
    assert out["mpc_workspace_bytes"] == 4321.0
    assert (out["mpc_solve_us_p99_target"], out["mpc_workspace_bytes_target"]) == (1000.0, 65536.0)
    assert out["mpc_mission_s"] == approx(2.0) and out["mpc_mission_ratio"] == approx(4.0)
    assert len(made) == 2  # the mission runs a fresh compiled MPC
    # the documented figure-eight: closed, 4 m x 2 m about the origin, 0.5 m/s, every time
    assert all(p is paths[0] for p in paths) and len(paths) == 4
    xy = paths[0].point(np.linspace(0.0, paths[0].length, 4001))
    assert paths[0].closed and paths[0].speed == 0.5
    np.testing.assert_allclose([np.ptp(xy[:, 0]), np.ptp(xy[:, 1])], [4.0, 2.0], rtol=1e-3)
    np.testing.assert_allclose(xy.mean(axis=0), [0.0, 0.0], atol=1e-3)
    assert all(type(v) is float for v in out.values())


def test_mpc_group_single_pass(monkeypatch):
    clock = Clock([1.0, 0.25], [])
    monkeypatch.setattr(bg, "time", clock)

    class MPC:
        def __init__(self):
            self.function = lambda *a: a
            self.solve_s, self.solve_cpu_s = [3e-6, 1e-6, 2e-6], [1e-6, 1e-6, 1e-6]
            self.failures, self.residuals = 0, [0.0]

    monkeypatch.setattr(bg, "compiled_mpc", lambda path: (MPC(), 1))
    monkeypatch.setattr(bg, "run_path", lambda path, mpc, duration, sim: None)
    monkeypatch.setattr(bg, "ClosedLoop", lambda: SimpleNamespace(simulate=lambda *a, **k: None))
    monkeypatch.setattr(bg, "path_scenario", lambda p, d: SimpleNamespace(inputs=lambda: {}))
    out = bg.bench_mpc(repeats=1)
    assert out["mpc_solve_us_median"] == pytest.approx(2.0) == out["mpc_solve_us_median_min"]
    assert out["mpc_solve_us_max"] == pytest.approx(3.0)
    assert out["mpc_mission_ratio"] == pytest.approx(4.0)


class _Ctx:
    def __init__(self, *a, **kw):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_montecarlo_group_runs_the_shipped_com_scenario_for_the_asked_duration():
    """The group's source is the shipped ``com`` scenario (its dispersions drawn), only its
    duration changed."""
    from ballbot_casadi.sim.scenario import load_scenario_file
    from ballbot_casadi.studies.registry import shipped_scenarios

    src = bm._source(0.75)
    shipped = load_scenario_file(shipped_scenarios()["com"])
    assert src.scenario.duration == 0.75 and src.table["duration_s"] == 0.75
    assert src.scenario.replace(duration=shipped.scenario.duration) == shipped.scenario
    assert src.montecarlo == shipped.montecarlo and src.montecarlo["dispersion"]
    assert src.specs == shipped.specs
    assert {k: v for k, v in src.table.items() if k != "duration_s"} == \
        {k: v for k, v in shipped.table.items() if k != "duration_s"}


def test_montecarlo_group_by_hand(monkeypatch):
    import distributed

    class CM:
        def __init__(self, *a, **kw):
            self.kw = kw
            clusters.append(kw)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False
    clusters: list = []
    monkeypatch.setattr(distributed, "LocalCluster", CM)
    monkeypatch.setattr(distributed, "Client", _Ctx)
    monkeypatch.setattr(bm, "_source", lambda duration: ("src", duration))
    monkeypatch.setattr(bm, "draw_runs", lambda source, n, seed: list(range(n)))
    monkeypatch.setattr(bm, "ClosedLoop", lambda: "sim")
    calls: list = []
    monkeypatch.setattr(bm, "run_serial", lambda source, runs, sim: calls.append(("serial", list(runs)))
                        or [r * 2 for r in runs])
    dask_results = iter([[0, 2], list(range(0, 16, 2)), [0, 2, 4, 6], list(range(0, 16, 2))])
    monkeypatch.setattr(bm, "run_dask", lambda source, runs, client: calls.append(("dask", list(runs)))
                        or next(dask_results))
    clock = Clock([4.0, 2.0, 1.25], [])
    monkeypatch.setattr(bm, "time", clock)
    out = bm.bench_montecarlo(n_runs=8, duration=0.5)
    # untimed warm-ups: two serial runs, then two runs per worker on each cluster
    every = list(range(8))
    assert calls == [("serial", [0, 1]), ("serial", every), ("dask", [0, 1]), ("dask", every),
                     ("dask", [0, 1, 2, 3]), ("dask", every)]
    assert clusters == [dict(n_workers=k, threads_per_worker=1, processes=True, dashboard_address=None)
                        for k in (1, 2)]  # worker processes, one thread each, no dashboard
    assert out == {"montecarlo_serial_runs_per_s": 2.0, "montecarlo_runs_per_s_1w": 4.0,
                   "montecarlo_runs_per_s_2w": 6.4, "montecarlo_dask_equals_serial": 1.0,
                   "montecarlo_parallel_efficiency": pytest.approx(0.8, rel=1e-12),
                   "montecarlo_parallel_efficiency_target": 0.8, "montecarlo_runs": 8.0,
                   "montecarlo_run_duration_s": 0.5}


def test_montecarlo_group_reports_a_dask_difference(monkeypatch):
    import distributed

    class CM:
        def __init__(self, **kw):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False
    monkeypatch.setattr(distributed, "LocalCluster", CM)
    monkeypatch.setattr(distributed, "Client", _Ctx)
    monkeypatch.setattr(bm, "_source", lambda duration: None)
    monkeypatch.setattr(bm, "draw_runs", lambda source, n, seed: list(range(n)))
    monkeypatch.setattr(bm, "ClosedLoop", lambda: None)
    monkeypatch.setattr(bm, "run_serial", lambda source, runs, sim: list(runs))
    dask_results = iter([None, [0, 1, 2, 9], None, [0, 1, 2, 3]])  # 1 worker differs
    monkeypatch.setattr(bm, "run_dask", lambda source, runs, client: next(dask_results))
    monkeypatch.setattr(bm, "time", Clock([1.0, 1.0, 1.0], []))
    assert bm.bench_montecarlo(n_runs=4, duration=0.1)["montecarlo_dask_equals_serial"] == 0.0


def test_model_group_by_hand(monkeypatch, tmp_path, fake_run):
    lib = SimpleNamespace(header=tmp_path / "inc" / "m.h", static=tmp_path / "libm.a")
    monkeypatch.setattr(bench, "model_library", lambda: lib)
    monkeypatch.setattr(bench, "build_root", lambda: tmp_path)
    monkeypatch.setattr(bench, "run_tool", lambda cmd, what: open(cmd[cmd.index("-o") + 1], "w").close())
    calls = []

    p = bench.load_params().to_vector()
    fns = {f.name(): f for f in model_functions_list()}
    x = np.array([0.1, -0.2, 0.99904822, 0.0348995, 0.0261769, 0.0, 0.1, 0.05, 0.0, 0.01, -0.02, 0.03])
    tau = np.array([0.2, -0.1, 0.3])
    A, B = (np.asarray(o.nonzeros()) for o in fns["ballbot_jac"](x, tau, p))
    good = {"ode_ns": 250.0, "jac_ns": 1200.0, "sink": 3.0,
            "check_ode": [np.asarray(fns["ballbot_ode"](x, tau, p)).ravel().tolist()],
            "check_jac": [A.tolist(), B.tolist()]}
    printed = [good]

    monkeypatch.setattr(subprocess, "run", fake_run(lambda cmd: json.dumps(printed[0]), calls))
    monkeypatch.setattr(bench, "_python_call_ns", lambda: 10000.0)
    out = bench.bench_model(n_calls=77)
    cmd, kw = calls[0]
    assert cmd[0] == str(tmp_path / "bench" / "bench_model") and cmd[1] == "77" and kw["text"]
    # the operating point, then the parameters, all as the C program reads them
    assert [float(v) for v in cmd[2:]] == [*x, *tau, *p]
    assert out == {"ode_ns": 250.0, "jac_ns": 1200.0, "python_call_ns": 10000.0,
                   "python_over_c_ratio": 40.0, "ode_target_ns": 500.0, "jac_target_ns": 3000.0}
    # outputs that are not the Functions' at that point: the benchmark timed something else
    for key, bad in (("check_ode", [good["check_ode"][0][:-1] + [good["check_ode"][0][-1] + 1e-3]]),
                     ("check_jac", [A.tolist(), (B * 1.001).tolist()]),
                     ("check_jac", [A.tolist()])):
        printed[0] = {**good, key: bad}
        with pytest.raises(BuildError, match="model benchmark"):
            bench.bench_model(n_calls=77)
    # the program refusing its buffers (exit 3): its message, not a traceback
    monkeypatch.setattr(subprocess, "run", fake_run(lambda cmd: "", [], returncode=3))
    with pytest.raises(BuildError, match=r"the model benchmark failed \(exit 3\)"):
        bench.bench_model(n_calls=77)


def test_run_benchmarks_merges_and_refuses_unknown_groups(monkeypatch, tmp_path):
    monkeypatch.setattr(bench, "BENCHMARKS", {"a": lambda: {"x": 1.0, "y": 2.0},
                                              "b": lambda: {"y": 5.0, "z": 3.0}})
    path = tmp_path / "new" / "out" / "bench.json"  # its folder and the parents are made
    assert bench.run_benchmarks(path, only=["b"]) == {"y": 5.0, "z": 3.0}
    path.write_text(json.dumps({"old": 9.0, "y": 0.0}))
    assert bench.run_benchmarks(path) == {"old": 9.0, "x": 1.0, "y": 5.0, "z": 3.0}
    assert json.loads(path.read_text()) == {"old": 9.0, "x": 1.0, "y": 5.0, "z": 3.0}
    # keys sorted (not in the order run), two spaces of indent, one line per key, a final newline
    assert path.read_text() == '{\n  "old": 9.0,\n  "x": 1.0,\n  "y": 5.0,\n  "z": 3.0\n}\n'
    path.write_text("{damaged")
    assert bench.run_benchmarks(path, only=["a"]) == {"x": 1.0, "y": 2.0}
    with pytest.raises(bench.BenchmarkError, match=r"unknown benchmark group\(s\) 'c'; valid "
                       r"groups: a, b") as e:
        bench.run_benchmarks(path, only=["a", "c"])
    assert isinstance(e.value, BallbotError) and isinstance(e.value, ValueError)
    assert json.loads(path.read_text()) == {"x": 1.0, "y": 2.0}  # nothing run


def test_fmpy_best_time_is_the_fastest_run(monkeypatch):
    from ballbot_casadi.bench import fmpy_timing as ft

    monkeypatch.setattr(ft, "extract", lambda path: f"unzipped:{path}")
    monkeypatch.setattr(ft, "read_model_description", lambda unzip: ("md", unzip))
    runs = []
    monkeypatch.setattr(ft, "simulate_fmu", lambda unzip, model_description, **kw:
                        runs.append((unzip, model_description, kw)) or len(runs))
    monkeypatch.setattr(ft, "time", Clock([0.5, 0.2, 0.3], []))
    best, res = ft.fmpy_best_time("a.fmu", 3, stop_time=2.0)
    assert best == pytest.approx(0.2, rel=1e-12) and res == 3  # the last run's result
    assert runs == [("unzipped:a.fmu", ("md", "unzipped:a.fmu"), {"stop_time": 2.0})] * 3


def test_estimation_group_keys_are_the_parts_of_each_estimator(monkeypatch):
    from ballbot_casadi.bench import estimation as be
    from ballbot_casadi.bench.exports import estimation_bench_functions

    monkeypatch.setattr(be, "estimation_bench_library", lambda ctrl, est: (
        ("lib", est), estimation_bench_functions(ctrl, est)))
    table: dict = {}

    def timed(lib, f, inputs, n_calls):
        key = (lib[1], f.name().removeprefix("ballbot_"))
        assert n_calls == 5 and key not in table  # each part timed once
        table[key] = 2.0 ** len(table)
        return table[key]
    monkeypatch.setattr(be, "c_function_us", timed)
    orig = be._full_scenario
    monkeypatch.setattr(be, "_full_scenario", lambda: orig().replace(duration=0.5))
    monkeypatch.setattr(be, "time", Clock([0.25, 3.0, 2.0], []))
    periods = {}
    parts = be._estimator_parts

    def recorded(sc, inputs, log, k, n_calls, **kw):
        periods[sc.estimator] = (k, np.asarray(inputs["estimation"]["valid"]))
        return parts(sc, inputs, log, k, n_calls, **kw)
    monkeypatch.setattr(be, "_estimator_parts", recorded)
    data = be.bench_estimation(n_calls=5, repeats=2)
    # the heading filters are timed on the last period with a heading reading
    for est in ("ukf_heading", "ekf_heading"):
        k, valid = periods[est]
        heading = valid[:, VALID.index("heading")]
        assert 0 < heading.sum() < len(heading) and k == np.flatnonzero(heading)[-1], est
    T = lambda est, name: table[est, name]  # noqa: E731

    def rest(est, att="qukf", vel="vukf"):
        return T(est, att) + T(est, vel) + T(est, "tilt_correction") + T(est, "com_observer")
    assert ("ekf_heading", "vekf") not in table  # the QEKF alone
    assert data["mission_full_100s_s"] == 2.0 and data["mission_full_100s_with_inputs_s"] == 2.25
    assert data["mission_full_100s_target_s"] == 0.5 and data["estimator_step_target_us"] == 10.0
    want = {"qukf_step_us": T("ukf", "qukf"), "vukf_step_us": T("ukf", "vukf"),
            "tilt_correction_step_us": T("ukf", "tilt_correction"),
            "com_observer_step_us": T("ukf", "com_observer"),
            "estimator_step_us": rest("ukf"), "embedded_step_us": T("ukf", "embedded_flc_ukf"),
            "qukf_heading_step_us": T("ukf_heading", "qukf_heading"),
            "qekf_heading_step_us": T("ekf_heading", "qekf_heading"),
            "estimator_heading_step_us": rest("ukf_heading", "qukf_heading"),
            "embedded_heading_step_us": T("ukf_heading", "embedded_flc_ukf_heading"),
            "vukf_matched_step_us": T(be.MATCHED, "vukf"),
            "estimator_step_matched_us": rest(be.MATCHED),
            "embedded_step_matched_us": T(be.MATCHED, f"embedded_flc_{be.MATCHED}"),
            "vukf_adaptive_step_us": T(be.ADAPTIVE, "vukf"),
            "estimator_step_adaptive_us": rest(be.ADAPTIVE),
            "embedded_step_adaptive_us": T(be.ADAPTIVE, f"embedded_flc_{be.ADAPTIVE}"),
            "estimator_step_adaptive_over_plain": rest(be.ADAPTIVE) / rest("ukf"),
            "estimator_step_adaptive_over_matched": rest(be.ADAPTIVE) / rest(be.MATCHED)}
    for k, v in want.items():
        assert data[k] == pytest.approx(v, rel=1e-12), k
    assert set(data) == {*want, "mission_full_100s_s", "mission_full_100s_with_inputs_s",
                         "mission_full_100s_target_s", "estimator_step_target_us"}
    assert (be.MATCHED, be.ADAPTIVE) == ("ukf_consistent", "ukf_adaptive")


def test_control_group_times_the_compiled_closed_loop(monkeypatch):
    seen = []

    class Stop(Exception):
        pass

    def closed_loop(**kw):
        seen.append(kw)
        raise Stop

    monkeypatch.setattr(bench_control_mod, "ClosedLoop", closed_loop)
    with pytest.raises(Stop):
        bench_control_mod.bench_control(n_calls=1, repeats=1)
    assert seen == [{"compiled": True}]


def test_control_group_figures_by_hand_on_a_stand_in_clock(monkeypatch):
    """The mission timings are the best of the repeats (not the last), each an elapsed time
    (end - start) on the clock; the per-period figures and the ratio follow from them."""
    from types import SimpleNamespace

    monkeypatch.setattr(bench_control_mod, "time", Clock([1.0, 3.0, 5.0, 7.0]))  # elapsed per read pair
    calls = []

    class Loop:
        def __init__(self, compiled, use_driver=True):
            self.driver = use_driver
            calls.append(("loop", compiled, use_driver))

        def mission(self, ctrl, n):
            calls.append(("mission", self.driver, ctrl, n))

        def simulate(self, ctrl, **inputs):
            calls.append(("simulate", self.driver, ctrl))
            return {"state": np.full((3, 12), 1.0 if self.driver else 1.25)}

    sc = SimpleNamespace(n_periods=20000, controller="flc")
    monkeypatch.setattr(bench_control_mod, "ClosedLoop", Loop)
    monkeypatch.setattr(bench_control_mod, "mission_inputs", lambda d: (sc, {"u": d}))
    monkeypatch.setattr(bench_control_mod, "control_bench_library", lambda: "lib")
    monkeypatch.setattr(bench_control_mod, "_c_bench", lambda lib, inp, n: {"c_ns": 1.5, "n": n, "inp": inp})
    monkeypatch.setattr(bench_control_mod, "_python_loop_period_s", lambda sim, inp, n: 6e-5 * n / 400)
    out = bench_control_mod.bench_control(n_calls=7, repeats=2)
    assert out["c_ns"] == 1.5 and out["n"] == 7 and out["inp"] == {"u": 100.0}
    assert out["mission_build_s"] == 1.0
    assert out["mission_100s_s"] == 3.0                     # best of 3 and 5
    assert out["mission_100s_casadi_call_s"] == 7.0
    assert out["mission_driver_vs_casadi_max_abs_diff"] == 0.25
    assert out["python_loop_period_us"] == pytest.approx(60.0, rel=1e-12)
    assert out["mission_period_us"] == pytest.approx(3.0 / 20000 * 1e6, rel=1e-12)
    assert out["python_loop_ratio"] == pytest.approx(6e-5 / (3.0 / 20000), rel=1e-12)
    assert (out["control_step_target_us"], out["mission_100s_target_s"]) == (5.0, 0.5)
    assert calls == [("loop", True, True), ("mission", True, "flc", 20000), ("simulate", True, "flc"),
                     ("simulate", True, "flc"), ("loop", True, False), ("mission", False, "flc", 20000),
                     ("simulate", False, "flc")]  # both compiled: the driver against the Function call


def test_python_call_time_is_the_best_block_per_call(monkeypatch):
    """ns per call: the fastest of 3 blocks of n calls, (end - start) / n on the clock."""
    reads = iter([7000, 7000 + 900, 9000, 9000 + 600, 20000, 20000 + 750])  # blocks of 900, 600, 750 ns
    monkeypatch.setattr(bench, "time", SimpleNamespace(perf_counter_ns=lambda: next(reads)))
    calls = []
    monkeypatch.setattr(bench, "make_ode", lambda: lambda x, tau, p: calls.append((x.copy(), tau.copy(), p)))
    assert bench._python_call_ns(3) == 200.0
    assert len(calls) == 9
    np.testing.assert_array_equal(calls[0][0], bench.BENCH_STATE)
    np.testing.assert_array_equal(calls[0][1], bench.BENCH_TAU)
    np.testing.assert_array_equal(calls[0][2], load_params().to_vector())


def test_python_loop_period_is_the_best_block_per_period(monkeypatch):
    """Seconds per period: the fastest of 3 blocks of n periods, each block continuing the
    state where the last ended, with the period's sequences read at its own index."""
    monkeypatch.setattr(bench_control_mod, "time", Clock([0.3, 0.12, 0.2]))
    seen = []

    def period(blocks, x, z, seq, const, plant):
        seen.append((float(x[0]), float(z[0]), {k: float(np.ravel(v)[0]) for k, v in seq.items()}))
        return {"x_next": x + 1.0, "z_next": z + 2.0}

    monkeypatch.setattr(bench_control_mod, "control_period", period)
    monkeypatch.setattr(bench_control_mod, "rk4_plant", lambda ode, n_sub, p, Ts: ("plant", n_sub, Ts))
    n = 2
    inputs = {k: 0.005 if k == "Ts" else np.zeros(3) for k in PERIOD_CONSTANTS}
    inputs.update({k: np.arange(3 * n, dtype=float)[:, None] * np.ones((1, 2)) for k in PERIOD_SEQUENCES})
    inputs["x0"], inputs["z0"] = np.zeros(12), np.ones(4)
    got = bench_control_mod._python_loop_period_s(SimpleNamespace(n_sub=5), inputs, n)
    assert got == pytest.approx(0.12 / n, rel=1e-12)
    assert [s[0] for s in seen] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]     # the state carried over blocks
    assert [s[1] for s in seen] == [1.0, 3.0, 5.0, 7.0, 9.0, 11.0]
    for k, (_, _, seq) in enumerate(seen):
        assert set(seq) == set(PERIOD_SEQUENCES) and all(v == float(k) for v in seq.values())


def test_the_benchmark_mission_is_the_cascade_following_fig_9_3():
    """The timed mission (``mission_100s_s``): FLC in cascade with the velocity LQR from
    roll 2 deg, pitch -1 deg, following the Fig. 9.3-like velocity profile, which a run of
    20 s or less leaves out."""
    from ballbot_casadi.sim import references as R
    from ballbot_casadi.sim.scenario import initial_state

    sc, inp = bench_control_mod.mission_inputs(100.0)
    assert (sc.controller, sc.cascade, sc.duration) == ("flc", True, 100.0)
    assert tuple(sc.velocity_keyframes) == tuple(R.FIG93_KEYFRAMES)
    np.testing.assert_array_equal(sc.x0, initial_state(2.0, -1.0, 0.0))
    assert np.abs(inp["v_ref"]).max() > 0.0
    short, _ = bench_control_mod.mission_inputs(20.0)
    assert short.cascade and tuple(short.velocity_keyframes) == ()
