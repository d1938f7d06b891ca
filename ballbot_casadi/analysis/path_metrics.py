"""Metrics of a path-following run: lateral and longitudinal error, clearance, completion.

The true ball position (the plant state, not the estimate) against the path of the run's
scenario (its ``[path]`` and ``[[obstacle]]``, :mod:`ballbot_casadi.sim.scenario.path_section`):

* the projection ``s_k`` of every guidance sample's position onto the path (searched
  next to the previous one, so a figure-eight's crossing keeps its branch), the lateral
  error ``|p - P(s_k)|`` (RMS and maximum, ``path_lateral_rms_m``,
  ``path_lateral_max_m``; the RMS also after the first 2 s, ``path_lateral_rms_settled_m``,
  the start from rest excluded);
* the longitudinal error: the progress behind the reference progress
  ``speed * t`` (``path_longitudinal_lag_max_m``; negative = ahead);
* the smallest distance of the ball centre to an obstacle circle (``path_min_clearance_m``;
  inf without obstacles) and ``path_collision`` (1 if it is ever <= 0);
* ``path_completed``: 1 if an open path was followed to within 0.1 m of its end (a
  closed one: within 0.1 m of the progress the run's time asks for, ``speed * t`` at its
  last sample, at most a lap), ``path_progress_fraction`` how much of it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ballbot_casadi.core.layout import STATE_XY
from ballbot_casadi.guidance.paths import Path, path_from_spec

__all__ = ["path_metrics", "path_errors", "PATH_METRIC_NAMES", "SAMPLE_EVERY"]

#: Periods between the samples the errors are computed on (10 Hz at 200 Hz).
SAMPLE_EVERY = 20
#: The metrics of :func:`path_metrics`.
PATH_METRIC_NAMES = ("path_lateral_rms_m", "path_lateral_rms_settled_m", "path_lateral_max_m",
                     "path_longitudinal_lag_max_m", "path_min_clearance_m", "path_collision",
                     "path_completed", "path_progress_fraction")
_SETTLE_S = 2.0


def path_errors(path: Path, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Progress ``s`` (unwrapped) and lateral error of each position of ``xy`` (M, 2)."""
    s_prev = path.project(xy[0])
    s_out, lat = [], []
    for p in xy:
        s_prev = path.project(p, s_prev)
        s_out.append(s_prev)
        lat.append(float(np.linalg.norm(path.point(s_prev) - p)))
    return np.array(s_out), np.array(lat)


def path_metrics(log: Any) -> dict[str, Any]:
    """The metrics of the module docstring for a run whose scenario has a path."""
    sc = log.scenario
    path = path_from_spec(dict(sc["path"]), [tuple(o) for o in sc.get("obstacles", ())])
    x = np.asarray(log.arrays["state"], float)
    t = np.asarray(log.arrays["time"], float)
    every = max(1, int(round(SAMPLE_EVERY / int(getattr(log, "extra", {}).get("log_every", 1)))))
    xy = x[::every, STATE_XY]
    ts = t[::every]
    if not np.all(np.isfinite(xy)):
        return {k: math.nan for k in PATH_METRIC_NAMES}
    s, lat = path_errors(path, xy)
    settled = lat[ts >= _SETTLE_S]
    clear = path.clearance(x[:, STATE_XY])
    progress = s[-1] - s[0]
    target = path.length if not path.closed else min(path.length, path.speed * ts[-1])
    end = np.inf if path.closed else path.length
    return {
        "path_lateral_rms_m": float(np.sqrt(np.mean(lat ** 2))),
        "path_lateral_rms_settled_m": float(np.sqrt(np.mean(settled ** 2))) if settled.size else math.nan,
        "path_lateral_max_m": float(np.max(lat)),
        "path_longitudinal_lag_max_m": float(np.max(np.minimum(path.speed * ts, end) - (s - s[0]))),
        "path_min_clearance_m": float(np.min(clear)),
        "path_collision": float(np.min(clear) <= 0.0),
        # an open path: its end reached (within 0.1 m) wherever the run started on it; a
        # closed one: the progress of the run's time (or a lap) made
        "path_completed": float((s[-1] if not path.closed else progress) >= target - 0.1),
        "path_progress_fraction": float(min(progress / path.length, 1.0 if not path.closed else math.inf)),
    }
