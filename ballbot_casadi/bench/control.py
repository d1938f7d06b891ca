"""Benchmark group ``control`` (``ballbot bench --only control``): closed-loop speed.

Keys
----
``control_step_us``
    One control period of the cascade in generated C: ``ballbot_velocity`` then
    ``ballbot_flc`` (C micro-benchmark ``csrc/bench_control.c`` linked against the static
    closed-loop library).  Target <= 5 us.  Also ``control_step_smc_us`` (velocity +
    SMC) and ``cl_period_us`` (a whole closed-loop period: controllers, saturation and
    the RK4 sub-steps of the plant).  The program prints the outputs of one call of each
    (velocity command :data:`BENCH_V_REF`), checked against the Functions
    (:mod:`~ballbot_casadi.bench.verify`): a time is only reported for what it claims.
``mission_100s_s``
    Wall time of a 100 s cascade mission (20000 control periods at 200 Hz, 1 ms RK4,
    true-state feedback) run from Python as one call of the compiled closed loop (the
    zero-copy C entry point of :mod:`~ballbot_casadi.sim.driver`).  Target <= 0.5 s.
    ``mission_100s_casadi_call_s`` is the same mission through the CasADi mission
    Function (same generated code plus numpy <-> DM conversion of every element).
``python_loop_ratio``
    The same loop written as a Python loop of CasADi calls (velocity controller,
    balance controller, torque limits, RK4 step Function: the period of
    :func:`~ballbot_casadi.sim.period.control_period` on numpy values; best of 3 blocks of
    400 periods) divided by the per-period time of the single compiled call.  A
    measurement, not a target: the baseline is CasADi's own virtual machine, so the
    ratio measures gcc against that interpreter.
"""

from __future__ import annotations

import json
import time
from importlib import resources
from pathlib import Path

import casadi as ca
import numpy as np

from ballbot_casadi.control import (
    default_balance_gains,
    make_balance_controller,
    make_velocity_controller,
)
from ballbot_casadi.core.toolchain import CFLAGS, Library, build_root, compiler_command, run_tool
from ballbot_casadi.errors import BuildError
from ballbot_casadi.model.dynamics import make_affine, make_ode
from ballbot_casadi.bench.exports import control_bench_library
from ballbot_casadi.bench.verify import check_c_outputs, function_nonzeros, run_program
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.period import control_period, rk4_plant
from ballbot_casadi.sim.ports import PERIOD_CONSTANTS, PERIOD_SEQUENCES, PeriodBlocks
from ballbot_casadi.sim.scenario import Scenario, initial_state

__all__ = ["bench_control", "mission_inputs"]


def mission_inputs(duration: float = 100.0) -> tuple[object, dict]:
    """The benchmark mission: FLC cascade following the Fig. 9.3-like profile, then standing."""

    sc = Scenario("bench", "flc", duration, initial_state(2.0, -1.0, 0.0), cascade=True,
                  velocity_keyframes=R.FIG93_KEYFRAMES if duration > 20 else ())
    return sc, sc.inputs()


#: The velocity command the C benchmark's controllers and closed loop run with.
BENCH_V_REF = (0.1, -0.05, 0.1)
#: Roll, pitch, yaw (deg) of the robot the C benchmark's controllers see: off the attitude
#: their states were started for (the mission's), so the gains act on a tracking error.
BENCH_RPY_DEG = (3.0, -2.0, 10.0)


def _expected(fns: dict[str, ca.Function], inputs: dict, kf: np.ndarray, ks: np.ndarray
              ) -> dict[str, np.ndarray]:
    """What ``csrc/bench_control.c`` prints for its check calls, by the Functions."""
    x, z, p, kv, Ts = inputs["x0"], inputs["z0"], inputs["p_ctrl"], inputs["k_vel"], inputs["Ts"]
    vel, step, chunk = fns["ballbot_velocity"], fns["ballbot_cl_step_flc"], fns["ballbot_cl_chunk_flc"]
    v_ref = np.array(BENCH_V_REF)
    refs = function_nonzeros(vel, x, v_ref, z[:vel.size_in(2)[0]], p, kv, Ts)[:3]
    xz = np.zeros(step.size_in(0)[0])   # plant and velocity-controller states, the rest
    xz[:x.size + z.size] = np.concatenate([x, z])  # (the COM observer's, unused) zero as in C
    n = chunk.size_in(1)[1]
    q_ref = np.tile([[1.0], [0.0], [0.0], [0.0]], (1, n))
    return {
        "check_tau_flc": function_nonzeros(fns["ballbot_flc"], x, *refs, p, kf)[0],
        "check_tau_smc": function_nonzeros(fns["ballbot_smc"], x, *refs, p, ks)[0],
        "check_cl_step": function_nonzeros(step, xz, np.zeros(4), np.zeros(4), np.zeros(4), v_ref,
                                           np.zeros(6), p, p, kf, kv, Ts, 1.0, 1.0)[0],
        "check_chunk": function_nonzeros(chunk, xz, q_ref, np.zeros((4, n)), np.zeros((4, n)),
                                         np.tile(v_ref[:, None], (1, n)), np.zeros((6, n)), p, p,
                                         kf, kv, Ts, 1.0, 1.0)[0],
    }


def _c_bench(library: tuple[Library, dict[str, ca.Function]], inputs: dict, n_calls: int
             ) -> dict[str, float]:
    """Time the C program on ``library``
    (:func:`~ballbot_casadi.bench.exports.control_bench_library`); its printed outputs are
    checked against the library's Functions."""
    lib, functions = library
    out = build_root() / "bench"
    out.mkdir(parents=True, exist_ok=True)
    src = Path(str(resources.files("ballbot_casadi.bench") / "csrc" / "bench_control.c"))
    exe = out / "bench_control"
    run_tool([*compiler_command(), *CFLAGS, "-I", str(lib.header.parent), "-o", str(exe), str(src),
              str(lib.static), "-lm"], "compiling the control benchmark")
    x = np.asarray(initial_state(*BENCH_RPY_DEG), float)
    inputs = {**inputs, "x0": x}
    kf, ks = default_balance_gains("flc"), default_balance_gains("smc")
    vals = [inputs["p_ctrl"], kf, ks, inputs["k_vel"], x, inputs["z0"], [inputs["Ts"]], BENCH_V_REF]
    header = [len(inputs["p_ctrl"]), kf.size, ks.size, inputs["k_vel"].size, inputs["z0"].size]
    text = " ".join(str(int(v)) for v in header) + "\n" + "\n".join(
        " ".join(repr(float(v)) for v in np.ravel(arr)) for arr in vals) + "\n"
    data_file = out / "bench_control_input.txt"
    data_file.write_text(text)
    data = json.loads(run_program("the control benchmark", [exe, n_calls, data_file]))
    data.pop("sink", None)
    want = _expected(functions, inputs, kf, ks)
    check_c_outputs("control benchmark", [data.pop(k) for k in want], list(want.values()))
    return data


def _python_loop_period_s(sim: ClosedLoop, inputs: dict, n: int) -> float:
    """Seconds per period of the closed loop as a Python loop of symbolic CasADi calls.

    Each period is :func:`~ballbot_casadi.sim.period.control_period` evaluated on numpy
    values (the same definition as the compiled step) with the RK4 plant Function.
    """
    blocks = PeriodBlocks(make_balance_controller("flc", make_affine()), make_velocity_controller())
    const = {k: inputs[k] for k in PERIOD_CONSTANTS}
    plant = rk4_plant(make_ode(), sim.n_sub, const["p_plant"], const["Ts"])
    x, z = inputs["x0"].copy(), inputs["z0"].copy()
    best = float("inf")
    for rep in range(3):  # best of 3 blocks: the machine may be shared
        t0 = time.perf_counter()
        for k in range(rep * n, (rep + 1) * n):
            out = control_period(blocks, x, z, {key: inputs[key][k] for key in PERIOD_SEQUENCES},
                                 const, plant)
            x, z = out["x_next"], out["z_next"]
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def bench_control(n_calls: int = 100000, repeats: int = 3) -> dict[str, float]:
    """Run the ``control`` benchmark group (see the module docstring)."""

    sim = ClosedLoop(compiled=True)
    sc, inputs = mission_inputs(100.0)
    data = _c_bench(control_bench_library(), inputs, n_calls)
    n = sc.n_periods
    t0 = time.perf_counter()
    sim.mission("flc", n)
    data["mission_build_s"] = time.perf_counter() - t0
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        log = sim.simulate(sc.controller, **inputs)
        best = min(best, time.perf_counter() - t0)
    if not np.all(np.isfinite(log["state"])):
        raise BuildError("benchmark mission diverged")
    data["mission_100s_s"] = best
    # the same mission through the CasADi mission Function (numpy <-> DM conversions)
    via_casadi = ClosedLoop(compiled=True, use_driver=False)
    via_casadi.mission("flc", n)
    t0 = time.perf_counter()
    ref = via_casadi.simulate(sc.controller, **inputs)
    data["mission_100s_casadi_call_s"] = time.perf_counter() - t0
    data["mission_driver_vs_casadi_max_abs_diff"] = float(np.max(np.abs(ref["state"] - log["state"])))
    n_py = 400
    py = _python_loop_period_s(sim, inputs, n_py)
    data["python_loop_period_us"] = py * 1e6
    data["mission_period_us"] = best / n * 1e6
    data["python_loop_ratio"] = py / (best / n)
    data["control_step_target_us"] = 5.0
    data["mission_100s_target_s"] = 0.5
    return data
