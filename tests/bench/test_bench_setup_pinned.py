"""The benchmarks' set-up, pinned: every number a benchmark module defines or takes by
default (operating points, call counts, repeats, durations, tolerances, clock and margins).
A ``bench.json`` figure is compared across commits (issue 2's "unchanged within noise"):
it is only comparable when it was measured the same way, so changing how is a deliberate
act, made here as well.  Read back generically, so a new constant must be pinned too."""

from __future__ import annotations

import importlib
import inspect
import numbers

PINNED = {
    "bench.BENCH_STATE": (0.1, -0.2, 0.99904822, 0.0348995, 0.0261769, 0.0, 0.1, 0.05, 0.0, 0.01, -0.02, 0.03),
    "bench.BENCH_TAU": (0.2, -0.1, 0.3),
    "bench._python_call_ns()": {'n': 20000},
    "bench.bench_model()": {'n_calls': 200000},
    "control.mission_inputs()": {'duration': 100.0},
    "control.BENCH_V_REF": (0.1, -0.05, 0.1),
    "control.BENCH_RPY_DEG": (3.0, -2.0, 10.0),
    "control.bench_control()": {'n_calls': 100000, 'repeats': 3},
    "estimation.ADAPTIVE_WALK_FORGETTING": 0.0025,
    "estimation.bench_estimation()": {'n_calls': 20000, 'repeats': 3},
    "exports.N_SUB": 5,
    "firmware.SAMPLE_EVERY": 20,
    "firmware.TS_CONTROL": 0.005,
    "firmware.CLOCK_HZ": 400000000.0,
    "firmware.CLOCK_HZ_MAX": 480000000.0,
    "firmware.IPC": 1.0,
    "firmware.SPLIT_MARGIN": 1.5,
    "firmware.SPLIT_LATENCY": 5,
    "firmware.LAP_S": 27.0,
    "firmware.SETTLE_S": 2.0,
    "firmware.bench_firmware()": {'n_periods': 200},
    "firmware.bench_firmware_mpc()": {'n_periods': 200},
    "firmware.lap_lateral_rms()": {'latency': 0, 'duration': 27.0},
    "firmware.bench_firmware_split()": {'n_periods': 200, 'latency': 5, 'lap_s': 27.0},
    "fmu.FMU_RATIO_TARGET": 20.0,
    "fmu.CONTROLLER_STEP_TARGET_US": 15.0,
    "fmu._TAU": (0.02, -0.01, 0.005),
    "fmu._ROLL0": 0.002,
    "fmu._STOP": 2.0,
    "fmu._DT": 0.005,
    "fmu._fmpy_time()": {'reps': 3},
    "fmu.bench_sil()": {'reps': 2},
    "fmu3._ROLL0": 0.05,
    "fmu3._TAU": (0.1, -0.05, 0.02),
    "fmu3._STOP": 1.0,
    "fmu3._DT": 0.005,
    "fmu3._RTOL": 1e-10,
    "fmu3.casadi_export_fmu()": {'roll0': 0.05},
    "fmu3._time()": {'reps': 3},
    "guidance.compiled_mpc()": {'dt': 0.1},
    "guidance.bench_mpc()": {'duration': 30.0, 'mission': 100.0, 'repeats': 5},
    "montecarlo.bench_montecarlo()": {'n_runs': 32, 'duration': 20.0},
    "verify.C_RTOL": 1e-09,
}

MODULES = ["ballbot_casadi.bench", *(f"ballbot_casadi.bench.{m}" for m in (
    "control", "estimation", "exports", "firmware", "fmpy_timing", "fmu", "fmu3", "guidance",
    "montecarlo", "verify"))]


def _number(v) -> bool:
    if isinstance(v, bool):
        return False
    if isinstance(v, numbers.Number):
        return True
    return isinstance(v, (tuple, list)) and bool(v) and all(_number(x) for x in v)


def _setup() -> dict:
    out = {}
    for name in MODULES:
        mod = importlib.import_module(name)
        short = name.removeprefix("ballbot_casadi.bench").lstrip(".") or "bench"
        for k, v in vars(mod).items():
            if k.startswith("__"):
                continue
            if inspect.isfunction(v) and v.__module__ == name:
                d = {n: p.default for n, p in inspect.signature(v).parameters.items() if _number(p.default)}
                if d:
                    out[f"{short}.{k}()"] = d
            elif _number(v):
                out[f"{short}.{k}"] = v
    return out


def test_the_benchmark_set_up_is_the_pinned_one():
    got = _setup()
    assert sorted(got) == sorted(PINNED)
    for key, want in PINNED.items():
        assert got[key] == want, key
        assert type(got[key]) is type(want), key

