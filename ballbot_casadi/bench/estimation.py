"""Benchmark group ``estimation`` (``ballbot bench --only estimation``): the complete system's speed.

Keys
----
``estimator_step_us``
    One period of the estimation: the QUKF, the VUKF, the velocity-aided tilt
    correction and the COM observer (``ballbot_qukf`` + ``ballbot_vukf`` +
    ``ballbot_tilt_correction`` + ``ballbot_com_observer``, exported by
    :func:`~ballbot_casadi.bench.exports.estimation_bench_library`) in generated C, each timed by the C driver
    ``csrc/bench_function.c`` on a realistic operating point.  Target <= 10 us (the
    loop period is 5000 us).  Also the parts ``qukf_step_us``, ``vukf_step_us``,
    ``tilt_correction_step_us``, ``com_observer_step_us`` and ``embedded_step_us``
    (the whole embedded software: filters, observer, controllers, limit); with the
    matched velocity filter of estimator ``ukf_consistent``: ``vukf_matched_step_us``,
    ``estimator_step_matched_us`` and ``embedded_step_matched_us``; with the matched
    filter adapting its acceleration random walk (estimator ``ukf_adaptive``):
    ``vukf_adaptive_step_us``, ``estimator_step_adaptive_us`` and
    ``embedded_step_adaptive_us``; the adaptive filter's cost relative to the others
    timed in the same run, ``estimator_step_adaptive_over_plain`` and
    ``estimator_step_adaptive_over_matched`` (ratios of the ``estimator_step`` keys: the
    load of a shared host scales all three alike).
``estimator_heading_step_us``
    The same with the heading-aided QUKF (``ballbot_qukf_heading``: the z gyro bias a
    state, the heading reading in the update; estimator ``ukf_heading``) in place of the
    QUKF, timed on a period with a heading reading; also ``qukf_heading_step_us``,
    ``embedded_heading_step_us`` and the predecessor's QEKF with heading and gyro biases
    ``qekf_heading_step_us`` (estimator ``ekf_heading``).
``mission_full_100s_s``
    Wall time of 100 s of the complete system (sensor noise, QUKF + VUKF, velocity LQR,
    FLC, plant) run from Python as one call of the compiled mission, inputs prepared
    beforehand (``mission_full_100s_with_inputs_s`` includes drawing the noise and
    building the inputs).  Target <= 0.5 s.
"""

from __future__ import annotations

import json
import time
from importlib import resources
from pathlib import Path

import casadi as ca
import numpy as np

from ballbot_casadi.core.toolchain import CFLAGS, Library, build_root, compiler_command, run_tool
from ballbot_casadi.bench.exports import estimation_bench_library
from ballbot_casadi.bench.verify import check_c_outputs, function_nonzeros, run_program
from ballbot_casadi.errors import BuildError
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.core.layout import ATTITUDE_FILTER_STATE, VELOCITY_FILTER_STATE
from ballbot_casadi.estimation.attitude import ATTITUDE_MEAS
from ballbot_casadi.estimation.tuning import ADAPTIVE_WALK_FORGETTING
from ballbot_casadi.sim.embedded import (
    ADAPTIVE_VELOCITY,
    MATCHED_VELOCITY,
    THESIS_ESTIMATOR,
    VALID,
    embedded_readings,
    software_layout,
)
from ballbot_casadi.sim.ports import REFERENCE_SEQUENCES
from ballbot_casadi.sim.scenario import load_scenario_file

__all__ = ["bench_estimation", "c_function_us"]


def c_function_us(lib: Library, function: ca.Function, inputs: list, n_calls: int) -> float:
    """Microseconds per call of ``function`` (exported by ``lib``) in a C loop."""
    out = build_root() / "bench"
    out.mkdir(parents=True, exist_ok=True)
    src = Path(str(resources.files("ballbot_casadi.bench") / "csrc" / "bench_function.c"))
    exe = out / f"bench_{function.name()}_{lib.digest}"
    run_tool([*compiler_command(), *CFLAGS, f"-DBENCH_FN={function.name()}",
              f'-DBENCH_HEADER="{lib.header.name}"', "-I", str(lib.header.parent), "-o", str(exe),
              str(src), str(lib.static), "-lm"], f"compiling the benchmark of {function.name()}")
    args = [np.asarray(v, float).reshape(function.size_in(i), order="F") if np.size(v) > 1
            else np.asarray(v, float) for i, v in enumerate(inputs)]
    values = [" ".join(repr(float(e)) for e in np.ravel(arr, order="F")) for arr in args]
    data = out / f"bench_{function.name()}_input.txt"
    data.write_text("\n".join(values) + "\n")
    res = json.loads(run_program(f"benchmark of {function.name()}", [exe, n_calls, data]))
    if not res["finite"]:
        raise BuildError(f"benchmark of {function.name()} produced a non-finite output")
    check_c_outputs(f"benchmark of {function.name()}", res["outputs"], function_nonzeros(function, *args))
    return float(res["us_per_call"])


#: The estimator choice with the matched velocity filter and its constant random walk
#: (timed beside the scenario's).
MATCHED = min(MATCHED_VELOCITY - ADAPTIVE_VELOCITY)
#: The estimator choice with the matched velocity filter adapting its random walk.
ADAPTIVE = min(ADAPTIVE_VELOCITY)


def _full_scenario():
    """The ``full_velocity`` file with the thesis's filters (``estimator = "ukf"``: the
    ``estimator_step_us`` keys; the shipped ``ukf_adaptive`` has its own ``*_adaptive_*``)."""
    path = Path(str(resources.files("ballbot_casadi.studies") / "scenarios" / "full_velocity.toml"))
    return load_scenario_file(path).scenario.replace(estimator=THESIS_ESTIMATOR)


def bench_estimation(n_calls: int = 20000, repeats: int = 3) -> dict[str, float]:
    """Run the ``estimation`` benchmark group (see the module docstring)."""
    sc = _full_scenario()
    sim = ClosedLoop(compiled=True)
    t0 = time.perf_counter()
    inputs = sc.inputs()
    t_inputs = time.perf_counter() - t0
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        log = sim.simulate(sc.controller, **inputs, n_sub=sc.n_sub)
        best = min(best, time.perf_counter() - t0)
    if not np.all(np.isfinite(log["state"])):
        raise BuildError("the complete-system benchmark mission diverged")
    data = {"mission_full_100s_s": best, "mission_full_100s_with_inputs_s": best + t_inputs,
            "mission_full_100s_target_s": 0.5}
    k = log["x_hat"].shape[0] // 2
    parts = _estimator_parts(sc, inputs, log, k, n_calls)
    data.update({f"{k}_step_us": v for k, v in parts.items() if k not in ("attitude", "embedded")})
    data["estimator_step_us"] = sum(parts[k] for k in ("qukf", "vukf", "tilt_correction",
                                                       "com_observer"))
    data["embedded_step_us"] = parts["embedded"]
    # the heading-aided QUKF in the same place, on a period with a heading reading (20 s of
    # the same profile give its operating point), and the predecessor's QEKF with heading
    for est_name, att in (("ukf_heading", "qukf_heading"), ("ekf_heading", "qekf_heading")):
        sh = sc.replace(estimator=est_name, heading_sensor=True, duration=20.0)
        inp_h = sh.inputs()
        log_h = sim.simulate(sh.controller, **inp_h, n_sub=sh.n_sub)
        heading = inp_h["estimation"]["valid"][:, VALID.index("heading")]
        k_h = int(np.flatnonzero(heading > 0)[-1])
        ph = _estimator_parts(sh, inp_h, log_h, k_h, n_calls, with_rest=est_name == "ukf_heading")
        data[f"{att}_step_us"] = ph["attitude"]
        if est_name == "ukf_heading":
            data["estimator_heading_step_us"] = sum(ph[k] for k in ("attitude", "vukf",
                                                                    "tilt_correction",
                                                                    "com_observer"))
            data["embedded_heading_step_us"] = ph["embedded"]
    # the matched velocity filter (estimator "ukf_consistent": the gyro-rate input P_rate
    # and the period's acceleration noise G Q G^T), at the same operating point
    pm = _estimator_parts(sc.replace(estimator=MATCHED), inputs, log, k, n_calls)
    data["vukf_matched_step_us"] = pm["vukf"]
    data["estimator_step_matched_us"] = sum(pm[k] for k in ("qukf", "vukf", "tilt_correction",
                                                           "com_observer"))
    data["embedded_step_matched_us"] = pm["embedded"]
    # the same with the adapted random walk (estimator "ukf_adaptive")
    pa = _estimator_parts(sc.replace(estimator=ADAPTIVE), inputs, log, k, n_calls)
    data["vukf_adaptive_step_us"] = pa["vukf"]
    data["estimator_step_adaptive_us"] = sum(pa[k] for k in ("qukf", "vukf", "tilt_correction",
                                                            "com_observer"))
    data["embedded_step_adaptive_us"] = pa["embedded"]
    data["estimator_step_adaptive_over_plain"] = (data["estimator_step_adaptive_us"]
                                                  / data["estimator_step_us"])
    data["estimator_step_adaptive_over_matched"] = (data["estimator_step_adaptive_us"]
                                                    / data["estimator_step_matched_us"])
    data["estimator_step_target_us"] = 10.0
    return data


def _by_name(f: ca.Function, values: dict) -> list:
    """``f``'s inputs in its order, taken by name (``name_in``) from ``values``; a gated
    filter's consecutive-rejection counters ``n_rej`` start at zero (none so far)."""
    return [np.zeros(f.size1_in(i)) if n == "n_rej" and n not in values else values[n]
            for i, n in enumerate(f.name_in())]


def _estimator_parts(sc, inputs: dict, log, k: int, n_calls: int, with_rest: bool = True
                     ) -> dict[str, float]:
    """Microseconds per call of the parts of ``sc``'s estimation (its attitude filter under
    ``attitude`` and under its own name, ``vukf``/``vekf``, ``tilt_correction``,
    ``com_observer``) and ``embedded``, at the operating point of period ``k`` of ``log``
    (the filters' state at the end of the run, the readings of period ``k``); only the
    attitude filter unless ``with_rest``."""
    lib, names = estimation_bench_library(sc.controller, sc.estimator)
    est = inputs["estimation"]
    c = log["c_final"]
    embedded = names[f"ballbot_embedded_{sc.controller}_{sc.estimator}"]
    att_f = next(f for n, f in names.items() if n.startswith("ballbot_q"))
    vel_f = next(f for n, f in names.items() if n.startswith("ballbot_v"))
    tilt, observer = names["ballbot_tilt_correction"], names["ballbot_com_observer"]
    C = software_layout(embedded, sc.estimator)
    if C.has("walk") and c.size + C.size_of("walk") == C.size:  # a run without the walk state:
        # the adaptation's operating point after its growing memory (n = 1 / lambda)
        walk = np.r_[np.diag(np.asarray(est["Qv"]))[2:4], 1.0 / ADAPTIVE_WALK_FORGETTING]
        c = np.insert(np.asarray(c, float), C.offset("walk"), walk)
    xa, Pa, xv, Pv, obs = (c[C[f]] for f in ("xa", "Pa", "xv", "Pv", "obs"))
    meas = log["meas"][k]
    M = embedded_readings(embedded)
    p = est["p_est"]
    acc, gyro, enc = (meas[M[f]] for f in ("acc", "gyro", "enc"))
    z_att = np.r_[acc, gyro, meas[M["heading"]] if M.has("heading") else []]
    XA, XV = ATTITUDE_FILTER_STATE, VELOCITY_FILTER_STATE
    att_values = {"xhat": xa, "P": Pa, "z": z_att, "Q": est["Qa"], "R": est["Ra"],
                  "dt": inputs["Ts"], "p": p, "a": np.r_[xv[XV["a"]], 0.0]}  # as the software feeds it
    att_args = _by_name(att_f, att_values)
    out = {"attitude": c_function_us(lib, att_f, att_args, n_calls)}
    out[att_f.name().removeprefix("ballbot_")] = out["attitude"]
    if not with_rest:
        return out
    g = ATTITUDE_MEAS["gyro"]
    # the attitude covariance the velocity filter reads: the attitude filter's own output here
    att_out = att_f.call([ca.reshape(ca.DM(v), *att_f.size_in(i)) for i, v in enumerate(att_args)])
    vel_values = {"xhat": xv, "P": Pv, "z": np.r_[enc * inputs["Ts"], acc], "att": xa[:XA.size],
                  "P_att": np.asarray(att_out[att_f.index_out("P_att")]), "Q": est["Qv"], "R": est["Rv"], "dt": inputs["Ts"],
                  "p": p, "P_rate": np.asarray(est["Ra"])[g, g],  # (Ra's gyro block)
                  **({"walk": c[C["walk"]]} if C.has("walk") else {})}
    tilt_values = {"q": xa[XA["q"]], "a": xv[XV["a"]], "b_acc": xv[XV["b_acc"]], "p": p}
    obs_values = {"x": log["x_hat"][k], "v_ref": np.zeros(3), "o": obs, "p": inputs["p_ctrl"],
                  "k": inputs["k_obs"], "Ts": inputs["Ts"]}
    out[vel_f.name().removeprefix("ballbot_")] = c_function_us(
        lib, vel_f, _by_name(vel_f, vel_values), n_calls)
    out["tilt_correction"] = c_function_us(lib, tilt, _by_name(tilt, tilt_values), n_calls)
    out["com_observer"] = c_function_us(lib, observer, _by_name(observer, obs_values), n_calls)
    # the reference rows of period k after the whole-run inputs (which hold the sequences)
    values = {**inputs, **est, "c": c, "meas": meas, **{r: inputs[r][k] for r in REFERENCE_SEQUENCES},
              "cascade": 1.0 if inputs["cascade"] else 0.0,
              "feedforward": 1.0 if inputs["feedforward"] else 0.0,
              "com_observer": 1.0 if inputs.get("com_observer") else 0.0}
    out["embedded"] = c_function_us(lib, embedded, _by_name(embedded, values), n_calls)
    return out
