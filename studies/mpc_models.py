"""``ballbot study mpc_models``: which prediction model serves the path MPC best (issue 18).

The variants are the rows of :data:`MPC_MODEL_VARIANTS`, defined once: a name, one line
of description and a builder ``(inputs, path, config) -> (guidance, predictor, qp_size)``
(``inputs`` the course's :meth:`Scenario.inputs`; ``guidance.step(X) -> v_ref``;
``predictor(X0, v_refs) -> positions`` the variant's own model, for the prediction error;
``qp_size`` a dict).  A further variant (e.g. the balance-feed arrangement) is one more row.

Each variant follows the study's two courses (the figure-eight 4 m x 2 m at 0.5 m/s and
the obstacle course of the ``path`` study, true state) through the Python driver
:func:`~ballbot_casadi.sim.path_following.run_path` (the same driver for every variant:
the shipped MPC's compiled slot equals it to ~1e-7 m).  Per run, :func:`variant_metrics`:

* ``lateral_rms_cm`` (after the first 2 s), ``lateral_max_cm``, ``min_clearance_m``,
  ``completed`` (:mod:`~ballbot_casadi.analysis.path_metrics`); ``peak_tilt_deg``,
  ``peak_tilt_rate_deg_s``, ``peak_torque_nm`` (thesis §7.1 limits);
* ``pred_err_2s_rms_cm``, ``pred_err_2s_max_cm``: the open-loop prediction error of the
  variant's model, from the loop state of each guidance sample, fed the references the
  run actually applied, against the position the robot reached 2 s later (20 samples);
* ``step_ms_median``, ``step_ms_p99`` (wall-clock of one guidance call, this loaded
  machine, Python-side: the CasADi interpreter for the linear MPCs, the interpreter and
  OSQP for the NMPC) and ``qp_variables``, ``qp_rows``, ``failures``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ballbot_casadi.analysis.metrics import limit_metrics
from ballbot_casadi.analysis.path_metrics import path_metrics
from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.guidance.mpc import MpcConfig, PathMPC
from ballbot_casadi.guidance.nmpc import NonlinearPathMPC
from ballbot_casadi.guidance.paths import Path
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.ports import PERIOD_SEQUENCES
from ballbot_casadi.sim.path_following import make_loop_state, run_path, velocity_loop_model
from ballbot_casadi.sim.prediction_models import ClippedLoop, full_loop_model
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["ModelVariant", "MPC_MODEL_VARIANTS", "VARIANT_METRICS", "variant_metrics",
           "prediction_errors", "mpc_models_metrics", "mpc_models_report_lines", "COURSES"]

#: Guidance samples over the 2 s prediction horizon (0.1 s each).
HORIZON_SAMPLES = 20
#: Control periods per guidance sample.
_EVERY = 20
#: The courses (tags of the ``path`` study's scenario files, in the study's run order).
COURSES = ("obstacles", "fig8")


@dataclass(frozen=True)
class ModelVariant:
    """One row of the comparison: ``build(inputs, path, config) -> (guidance, predictor,
    qp_size)`` (module docstring)."""

    name: str
    description: str
    build: Callable[[Mapping[str, Any], Path, MpcConfig], tuple[Any, Callable, dict]]


def _linear(model: Any, path: Path, config: MpcConfig) -> tuple[Any, Callable, dict]:
    mpc = PathMPC(model, path, config)
    L = mpc.layout
    return mpc, lambda X0, v: model.simulate(X0, v)[:, 12:14], {"variables": L.n_u,
                                                                "rows": L.n_rows}


def _shipped(inp: Mapping[str, Any], path: Path, config: MpcConfig) -> tuple[Any, Callable, dict]:
    return _linear(velocity_loop_model(inp["p_ctrl"], inp["k_vel"], config.dt), path, config)


def _full(inp: Mapping[str, Any], path: Path, config: MpcConfig) -> tuple[Any, Callable, dict]:
    return _linear(full_loop_model(inp, config.dt)[0], path, config)


def _nmpc(inp: Mapping[str, Any], path: Path, config: MpcConfig) -> tuple[Any, Callable, dict]:
    model = ClippedLoop(inp, config.dt)
    mpc = NonlinearPathMPC(model, path, config)

    def predict(X0: np.ndarray, v: np.ndarray) -> np.ndarray:
        xs = [np.asarray(X0, float)]
        for vk in v:
            xs.append(model.step(xs[-1], vk))
        return np.array(xs)[:, 12:14]

    return mpc, predict, {"variables": mpc.qp_size["variables"], "rows": mpc.qp_size["rows"]}


#: The variants, in the report's order (the first is the shipped default).
MPC_MODEL_VARIANTS: tuple[ModelVariant, ...] = (
    ModelVariant("shipped", "linear: the velocity loop's design model (balance loop continuous, "
                 "LQR sampled), condensed QP, fixed-iteration ADMM", _shipped),
    ModelVariant("full", "linear: exact linearisation of the sampled closed loop (3D model, "
                 "FLC, velocity LQR, RK4 plant) at upright, same QP and ADMM", _full),
    ModelVariant("nmpc", "nonlinear (Python only): the velocity loop with the velocity "
                 "controller's own limits, RTI along the shifted solution (LTV, condensed), "
                 "HiGHS", _nmpc),
)

#: The metrics of :func:`variant_metrics` (units in the names).
VARIANT_METRICS = ("lateral_rms_cm", "lateral_max_cm", "min_clearance_m", "completed",
                   "peak_tilt_deg", "peak_tilt_rate_deg_s", "peak_torque_nm",
                   "pred_err_2s_rms_cm", "pred_err_2s_max_cm", "step_ms_median", "step_ms_p99",
                   "qp_variables", "qp_rows", "failures")


def loop_states(log: Mapping[str, np.ndarray], every: int = _EVERY) -> np.ndarray:
    """The loop-model state (14) at each guidance sample of a run's log."""
    ls = make_loop_state()
    x, z = np.asarray(log["state"], float)[::every], np.asarray(log["z"], float)[::every]
    return np.array([np.asarray(ls(xi, zi), float).ravel() for xi, zi in zip(x, z)])


def prediction_errors(X: np.ndarray, v_ref: np.ndarray, predictor: Callable,
                      horizon: int = HORIZON_SAMPLES) -> np.ndarray:
    """Position error (m) ``horizon`` samples ahead of each sample ``i`` with a full
    horizon left: ``|predictor(X[i], v_ref[i:i+h])[h] - X[i+h, position]|``."""
    out = []
    for i in range(0, X.shape[0] - horizon):
        if i + horizon > v_ref.shape[0]:
            break
        p = predictor(X[i], v_ref[i:i + horizon])[horizon]
        out.append(float(np.linalg.norm(p - X[i + horizon, 12:14])))
    return np.array(out)


def variant_metrics(scenario: Mapping[str, Any], log: Mapping[str, np.ndarray], tau_max: float,
                    v_ref: np.ndarray, step_s: np.ndarray, predictor: Callable,
                    qp_size: Mapping[str, int], failures: int) -> dict[str, float]:
    """The row of :data:`VARIANT_METRICS` for one run (``scenario`` the course's scenario
    dict with its ``path``; ``log`` the run's arrays; ``v_ref`` (n, 2) and ``step_s`` (n,)
    per guidance sample)."""
    shim = SimpleNamespace(scenario=scenario, arrays=log, extra={})
    pm, lm = path_metrics(shim), limit_metrics(log, tau_max)
    err = prediction_errors(loop_states(log), np.asarray(v_ref, float), predictor)
    step_ms = 1e3 * np.asarray(step_s, float)
    return {"lateral_rms_cm": 100 * pm["path_lateral_rms_settled_m"],
            "lateral_max_cm": 100 * pm["path_lateral_max_m"],
            "min_clearance_m": pm["path_min_clearance_m"], "completed": pm["path_completed"],
            "peak_tilt_deg": lm["peak_tilt_deg"], "peak_tilt_rate_deg_s": lm["peak_tilt_rate_deg_s"],
            "peak_torque_nm": lm["peak_torque_nm"],
            "pred_err_2s_rms_cm": 100 * float(np.sqrt(np.mean(err**2))) if err.size else math.nan,
            "pred_err_2s_max_cm": 100 * float(np.max(err)) if err.size else math.nan,
            "step_ms_median": float(np.median(step_ms)),
            "step_ms_p99": float(np.percentile(step_ms, 99)),
            "qp_variables": float(qp_size["variables"]), "qp_rows": float(qp_size["rows"]),
            "failures": float(failures)}


def run_variant(variant: ModelVariant, scenario: Scenario, config: MpcConfig = MpcConfig()
                ) -> dict[str, float]:
    """Follow ``scenario``'s course with ``variant`` (true state) and measure its row."""
    path = scenario.route.build()
    inp = scenario.inputs(periods=(0, 1))
    guidance, predictor, qp_size = variant.build(inp, path, config)
    run = run_path(path, guidance, scenario.duration)
    # the first sample re-linearises a few times (cold start): its time is not a sample's
    return variant_metrics(scenario.to_dict(), run.log, scenario.plant_params().tau_max,
                           run.v_ref, run.solve_s[1:], predictor, qp_size,
                           int(getattr(guidance, "failures", 0)))


#: Velocity-reference steps (m/s, along x) of the step-prediction check: small (every limit
#: of the velocity controller inactive) and large (its tilt-acceleration clip active).
STEP_SPEEDS = (0.1, 0.4)


def step_prediction_error(inp: Mapping[str, Any], predictor: Callable, speed: float,
                          sim: ClosedLoop | None = None) -> float:
    """Largest position error (m) over 2 s of ``predictor`` from rest against the closed
    loop (the compiled mission, COM observer off) after a held step ``v_ref = (speed, 0)``."""
    sim = ClosedLoop() if sim is None else sim
    seq = {k: np.asarray(v) for k, v in inp.items() if k not in ("com_observer", "k_obs",
                                                                  "estimator")}
    n = HORIZON_SAMPLES * _EVERY
    for key in PERIOD_SEQUENCES:
        seq[key] = np.zeros((n, np.asarray(inp[key]).shape[1]))
    seq["q_ref"][:, 0] = 1.0
    seq["v_ref"][:, 0] = speed
    out = sim.simulate("flc", **seq)
    X = loop_states(out)
    p = predictor(X[0], np.tile([speed, 0.0], (HORIZON_SAMPLES, 1)))
    return float(np.max(np.linalg.norm(p - X[:, 12:14], axis=1)))


def mpc_models_metrics(logs: Sequence[SimulationLog],
                       variants: Sequence[ModelVariant] = MPC_MODEL_VARIANTS) -> dict[str, Any]:
    """Every variant on every course of ``logs`` (the study's runs: their scenarios),
    as ``<course>_<variant>_<metric>``."""
    out: dict[str, Any] = {}
    sc0 = Scenario.from_dict(logs[-1].scenario)
    inp = sc0.inputs(periods=(0, HORIZON_SAMPLES * _EVERY))
    sim = ClosedLoop()
    for v in variants:
        _, predictor, _ = v.build(inp, sc0.route.build(), MpcConfig())
        for speed in STEP_SPEEDS:
            out[f"step{speed:g}_{v.name}_pred_err_max_cm"] = 100 * step_prediction_error(
                inp, predictor, speed, sim)
    for log in logs:
        sc = Scenario.from_dict(log.scenario)
        course = str(sc.name).removeprefix("path_").removesuffix("_mpc")
        for v in variants:
            out.update({f"{course}_{v.name}_{k}": val for k, val in run_variant(v, sc).items()})
    return out


#: A variant replaces the shipped default only if it beats it by this factor on the
#: lateral RMS of every course, completing it no worse, inside the §7.1 limits.
DECISION_MARGIN = 0.9


def decide(m: Mapping[str, Any], variants: Sequence[ModelVariant] = MPC_MODEL_VARIANTS,
           limits: Mapping[str, float] | None = None) -> tuple[str, str]:
    """``(name, reason)``: the variant the numbers ``m`` choose (the shipped default unless
    another one is better by :data:`DECISION_MARGIN` on every course, see above)."""
    lim = {"peak_tilt_deg": math.degrees(THESIS_LIMITS["tilt_max"]),
           "peak_tilt_rate_deg_s": math.degrees(THESIS_LIMITS["tilt_rate_max"])}
    lim.update(limits or {})
    base = variants[0].name

    def ok(v: str, c: str) -> bool:
        return (all(m.get(f"{c}_{v}_{k}", math.inf) <= b for k, b in lim.items())
                and m.get(f"{c}_{v}_completed", 0.0) >= m.get(f"{c}_{base}_completed", 0.0)
                and m.get(f"{c}_{v}_min_clearance_m", math.inf) > 0.0)

    better = [v.name for v in variants[1:]
              if all(ok(v.name, c) and m.get(f"{c}_{v.name}_lateral_rms_cm", math.inf)
                     <= DECISION_MARGIN * m.get(f"{c}_{base}_lateral_rms_cm", math.nan)
                     for c in COURSES)]
    if not better:
        return base, (f"no variant beats `{base}` by {100 * (1 - DECISION_MARGIN):.0f} % on the "
                      "lateral RMS of every course inside the §7.1 limits without losing "
                      "completion or clearance: the shipped model stays the default")
    best = min(better, key=lambda v: m[f"fig8_{v}_lateral_rms_cm"])
    return best, f"`{best}` beats `{base}` on every course: switch"


#: What the numbers mean (measured once, this study's run of 2 Dec 2026 on the shared
#: machine; the table above is the current run).
EVIDENCE_NOTE = [
    "### Reading the comparison (measured once)", "",
    "* On both courses the three models predict equally well: 0.03-0.06 cm RMS, 0.1 cm at "
    "most, of position error 2 s ahead with the references the run applied.  The MPC's soft "
    "rows keep the loop inside its linear range (the LQR's tilt-acceleration demand below "
    "its clip, tilts near 3 deg), where the design model, the exact linearisation and the "
    "nonlinear loop agree; the exact linearisation differs from the design model by at most "
    "0.5 % of a step response (tests/sim/test_prediction_models.py), invisible in tracking "
    "(0.18 cm lateral RMS on the figure-eight for both).",
    "* Where the models differ - a 0.4 m/s reference step, whose LQR demand the velocity "
    "controller clips - the nonlinear model predicts 40 times better (0.07 against 2.6 cm "
    "over 2 s), but the MPC does not command such steps.",
    "* The NMPC tracks worse (5.1 cm against 0.18 cm lateral RMS on the figure-eight, up to "
    "21 cm off at the lobes; 80 against 31 cm maximum on the obstacle course, 6 samples "
    "whose QP HiGHS did not solve) with the same prediction error: the difference is in "
    "the QP it solves (exact active set along the LTV linearisation instead of 60 ADMM "
    "iterations; 10.5 m of progress in 27 s against the shipped run's 11.0 m), not in its "
    "model; not investigated further.",
    "* Cost: one NMPC sample took 53-156 ms median, 87-272 ms p99 wall-clock from Python "
    "in two runs on this loaded machine (linearisation 20-60 ms, HiGHS the rest; 300 "
    "variables, 530 rows), the linear MPCs 1.2-31 ms median in the CasADi interpreter and "
    "0.6 ms p99 as generated C (`make bench`); the `full` model costs nothing at run time (a "
    "different constant matrix in the same generated solver) but 2 s to build.",
    "* Decision: the shipped design model stays the default.  `full` is kept as an option "
    "(`sim.prediction_models.full_loop_model`, a drop-in `LoopModel`); `nmpc` stays a "
    "Python-only option (`guidance.nmpc.NonlinearPathMPC`): generating it to C is not "
    "justified by these numbers.",
]


def _cell(v: Any, fmt: str) -> str:
    return "—" if v is None or not np.isfinite(v) else f"{v:{fmt}}"


_FORMATS = {"lateral_rms_cm": ".2f", "lateral_max_cm": ".1f", "min_clearance_m": ".3f",
            "completed": ".0f", "peak_tilt_deg": ".2f", "peak_tilt_rate_deg_s": ".1f",
            "peak_torque_nm": ".2f", "pred_err_2s_rms_cm": ".2f", "pred_err_2s_max_cm": ".1f",
            "step_ms_median": ".1f", "step_ms_p99": ".1f", "qp_variables": ".0f",
            "qp_rows": ".0f", "failures": ".0f"}


def mpc_models_report_lines(m: Mapping[str, Any],
                            variants: Sequence[ModelVariant] = MPC_MODEL_VARIANTS) -> list[str]:
    """The comparison table (one row per course and variant) and the variants' list."""
    head = "| course | model | " + " | ".join(VARIANT_METRICS) + " |"
    rows = [f"| {c} | {v.name} | " + " | ".join(_cell(m.get(f"{c}_{v.name}_{k}"), _FORMATS[k])
                                              for k in VARIANT_METRICS) + " |"
            for c in COURSES for v in variants]
    name, reason = decide(m, variants)
    return ["## Prediction models of the path MPC (issue 18)", "",
            f"**Decision (from the numbers below): `{name}`** - {reason}.", "",
            *(f"* `{v.name}`: {v.description}" for v in variants), "",
            head, "| " + " | ".join(["---"] * (len(VARIANT_METRICS) + 2)) + " |", *rows, "",
            "Units in the column names; true state; the Python driver for every variant; "
            "`step_ms_*`: wall-clock of one guidance call on this (shared, loaded) machine, "
            "not the generated C (see `make bench`).  Limits (thesis §7.1): tilt 5 deg, tilt "
            "rate 20 deg/s.", "",
            "Prediction error over 2 s after a velocity-reference step from rest (largest "
            "position error against the closed loop, cm):", "",
            "| model | " + " | ".join(f"step {v:g} m/s" for v in STEP_SPEEDS) + " |",
            "| --- | " + " | ".join("---" for _ in STEP_SPEEDS) + " |",
            *(f"| {v.name} | " + " | ".join(_cell(m.get(f"step{s:g}_{v.name}_pred_err_max_cm"),
                                                  ".3f") for s in STEP_SPEEDS) + " |"
              for v in variants), "", *EVIDENCE_NOTE]
