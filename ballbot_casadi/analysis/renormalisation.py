"""Renormalising the attitude filter's quaternion: does it matter? (thesis ch. 4, ch. 10).

The thesis's conclusions: its first UKF forced the quaternion back to unit norm and its
estimate "was deeply deviated"; the QUKF keeps the norm by quaternion algebra instead,
while the QEKF (additive, renormalised) was fine.  Two tools answer it on our filters:

* :func:`norm_probe_dev` - one update from a prior whose quaternion is off the unit
  sphere by ``eps``: a filter whose operations keep the norm (the QUKF's ``q o exp(r/2)``
  retraction and Karcher mean) returns it still off by ``~eps``; a filter that
  renormalises returns it at 0.  Unlike the logged norm (``quat_norm_max_dev``, 1e-16
  for both kinds) it tells the two apart.
* :func:`replay_attitude` / :func:`renormalisation_metrics` - the attitude filter
  variants (:data:`ATTITUDE_VARIANTS`) run on the same logged sensor readings of a run,
  their tilt and heading errors against the true attitude.  The replay has neither the
  embedded software's velocity-aided tilt correction nor the acceleration compensation:
  it compares the filters alone, as the thesis's ch. 6 does.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.analysis.estimates import tilt_heading_error_deg
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.estimation.attitude import (
    make_additive_ukf,
    make_qekf,
    make_qukf,
    qekf_initial_covariance,
)
from ballbot_casadi.estimation.tuning import QUKF_P0
from ballbot_casadi.sim.embedded import ESTIMATOR_FILTERS, MEAS
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["ATTITUDE_VARIANTS", "PROBE_EPS", "attitude_variant", "norm_probe_dev", "replay_attitude",
           "renormalisation_metrics", "norm_probe_metrics"]

#: The attitude filters compared: name -> (builder, covariance on the additive 7-chart?).
ATTITUDE_VARIANTS: Mapping[str, tuple[Callable[[], ca.Function], bool]] = {
    "qukf": (make_qukf, False),
    "qukf_renorm": (lambda: make_qukf(renormalise=True), False),
    "qukf_additive": (make_additive_ukf, True),
    "qekf": (make_qekf, True),
}
#: How far off the unit sphere the probe's prior quaternion is.
PROBE_EPS = 1e-6


def attitude_variant(name: str, q0: np.ndarray, omega0: np.ndarray) -> tuple[ca.Function, np.ndarray, np.ndarray]:
    """``(filter, x0, P0)`` of variant ``name`` started at attitude ``q0``, rate ``omega0``
    with the thesis's initial covariance (4.4; on the additive chart as the QEKF's)."""
    if name not in ATTITUDE_VARIANTS:
        raise ValueError(f"unknown attitude filter variant {name!r}; allowed: {', '.join(ATTITUDE_VARIANTS)}")
    build, additive = ATTITUDE_VARIANTS[name]
    q0 = np.asarray(q0, float) / np.linalg.norm(q0)
    P0 = qekf_initial_covariance(q0) if additive else np.array(QUKF_P0, float)
    return build(), np.concatenate([q0, np.asarray(omega0, float)]), P0


def norm_probe_dev(f: ca.Function, P0: np.ndarray, Qn: np.ndarray, R: np.ndarray, p: np.ndarray,
                   dt: float, eps: float = PROBE_EPS) -> float:
    """``| |q_next| - 1 |`` after one update of ``f`` from the upright prior scaled to norm
    ``1 + eps``, at rest (accelerometer reads g, gyroscope 0): ~``eps`` when the filter
    keeps the norm by its operations, 0 when it renormalises."""
    x = np.array([1.0 + eps, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    g = float(np.asarray(p, float).ravel()[PARAM_NAMES.index("g")])
    z = np.array([0.0, 0.0, g, 0.0, 0.0, 0.0])
    out = f(x, P0, z, Qn, R, dt, p)
    return float(abs(np.linalg.norm(np.asarray(out[0]).ravel()[:4]) - 1.0))


def replay_attitude(f: ca.Function, meas: np.ndarray, x0: np.ndarray, P0: np.ndarray, Qn: np.ndarray,
                    R: np.ndarray, dt: float, p: np.ndarray) -> np.ndarray:
    """The filter's estimates ``xhat`` (N, 7) after each of the readings ``meas`` (N, 9,
    :data:`~ballbot_casadi.sim.embedded.MEAS`; accelerometer and gyroscope are used)."""
    z_all = np.hstack([meas[:, MEAS["acc"]], meas[:, MEAS["gyro"]]])
    x, P = np.asarray(x0, float), np.asarray(P0, float)
    out = np.empty((z_all.shape[0], 7))
    for k, z in enumerate(z_all):
        res = f(x, P, z, Qn, R, dt, p)
        x, P = np.asarray(res[0]).ravel(), np.asarray(res[1])
        out[k] = x
    return out


def renormalisation_metrics(log: Any, variants: tuple[str, ...] = tuple(ATTITUDE_VARIANTS)) -> dict[str, Any]:
    """Each variant replayed on ``log``'s readings (a run with an estimator): ``<v>_tilt_rms_deg``,
    ``<v>_tilt_max_deg``, ``<v>_heading_max_deg`` against the true attitude, the norm
    before any renormalisation ``<v>_norm_probe_dev`` (:func:`norm_probe_dev`), and
    ``<v>_vs_qukf_tilt_rms_ratio`` (1 = no deviation from the QUKF)."""
    sc = Scenario.from_dict(log.scenario)
    est = sc.estimation_inputs()
    a = log.arrays
    meas = np.asarray(a["meas"], float)
    n = meas.shape[0]
    q0 = np.asarray(a["state"][0, STATE["q"]], float)
    omega0 = 2 * Q.vee(Q.mul(Q.conj(q0), np.asarray(a["state"][0, STATE["dq"]], float)))
    out: dict[str, Any] = {}
    for v in variants:
        f, x0, P0 = attitude_variant(v, q0, omega0)
        xh = replay_attitude(f, meas, x0, P0, est["Qa"], est["Ra"], sc.Ts, est["p_est"])
        tilt, heading = tilt_heading_error_deg(a["state"][:n, STATE["q"]], xh[:, :4])
        out[f"{v}_tilt_rms_deg"] = float(np.sqrt(np.mean(tilt**2)))
        out[f"{v}_tilt_max_deg"] = float(np.max(tilt))
        out[f"{v}_heading_max_deg"] = float(np.max(np.abs(heading)))
        out[f"{v}_norm_probe_dev"] = norm_probe_dev(f, P0, est["Qa"], est["Ra"], est["p_est"], sc.Ts)
    if "qukf" in variants:
        for v in variants:
            out[f"{v}_vs_qukf_tilt_rms_ratio"] = out[f"{v}_tilt_rms_deg"] / out["qukf_tilt_rms_deg"]
    return out


def norm_probe_metrics(log: Any) -> dict[str, float]:
    """``attitude_norm_probe_dev``: :func:`norm_probe_dev` of the attitude filter of
    ``log``'s estimator (``ukf``: the QUKF, ``ekf``: the QEKF) with the run's tuning."""
    sc = Scenario.from_dict(log.scenario)
    est = sc.estimation_inputs(periods=(0, 1))
    f, _, P0 = attitude_variant(ESTIMATOR_FILTERS[sc.estimator][0], np.array([1.0, 0, 0, 0]),
                                np.zeros(3))
    return {"attitude_norm_probe_dev": norm_probe_dev(f, P0, est["Qa"], est["Ra"], est["p_est"], sc.Ts)}
