"""A path and its obstacles as one parameter vector, and the path evaluated on CasADi symbols.

The guidance blocks that run inside the control period (:mod:`ballbot_casadi.guidance.blocks`)
read the path as a *parameter* (the constant port ``k_guid`` of the period), so one
generated mission or controller FMU follows any path: a table of :data:`PATH_SAMPLES`
points and unit tangents at equal arc-length steps, the length, closed/open, the
reference speed and up to ``n_obstacles`` circles (:func:`path_table_layout`,
:func:`pack_path`).  :func:`path_eval` evaluates ``P(s)``, ``T(s)``, the reference
progress speed and the progress bound on symbols, by linear interpolation in the table
(a CasADi parametric ``linear`` interpolant, O(1) lookup on the uniform grid), with the
same conventions as :class:`~ballbot_casadi.guidance.paths.Path`: ``s`` modulo the length
on a closed path, a straight continuation past the ends of an open one, the speed ramped
down to stop at the end of an open path.

With 2048 samples a path of up to ~20 m is tabulated every <= 1 cm; the linear
interpolation of a curve of radius ``R`` then deviates by at most ``h^2 / (8 R)``
(2.5e-5 m at ``R = 0.5 m``).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import Path

__all__ = ["PATH_SAMPLES", "A_STOP", "path_table_layout", "pack_path", "path_eval",
           "PathSymbols"]

#: Table samples of a path (arc-length grid, both ends included).
PATH_SAMPLES = 2048
#: Deceleration of the speed ramp at the end of an open path (m/s^2), as
#: :meth:`Path.reference_speed <ballbot_casadi.guidance.paths.Path.reference_speed>`.
A_STOP = 0.5 * THESIS_LIMITS["a_max"]


def path_table_layout(n_obstacles: int, n_samples: int = PATH_SAMPLES) -> Layout:
    """Layout of the path parameter vector: ``length``, ``closed`` (0/1), ``speed``,
    ``points`` and ``tangents`` (``n_samples`` x 2, interleaved ``x0, y0, x1, ...``) and
    ``obstacles`` (``n_obstacles`` x 3: ``cx, cy, r``; ``r = 0`` marks an empty slot)."""
    return Layout("path table", [("length", 1), ("closed", 1), ("speed", 1),
                                 ("points", 2 * n_samples), ("tangents", 2 * n_samples),
                                 ("obstacles", 3 * max(n_obstacles, 1))])


def pack_path(path: Path, n_obstacles: int, n_samples: int = PATH_SAMPLES,
              obstacles: bool = True) -> np.ndarray:
    """The parameter vector of ``path`` (:func:`path_table_layout`); ``obstacles = False``
    leaves the obstacle slots empty (a guidance law that does not read them).

    Raises
    ------
    ScenarioError
        More obstacles than the block has slots for.
    """
    kept = path.obstacles if obstacles else ()
    if len(kept) > n_obstacles:
        raise ScenarioError(f"obstacles: at most {n_obstacles} allowed by this guidance block, "
                            f"got {len(path.obstacles)}")
    L = path_table_layout(n_obstacles, n_samples)
    s = np.linspace(0.0, path.length, n_samples)
    obs = np.zeros((max(n_obstacles, 1), 3))
    for j, ob in enumerate(kept):
        obs[j] = (*ob.center, ob.radius)
    return L.pack({"length": path.length, "closed": 1.0 if path.closed else 0.0,
                   "speed": path.speed, "points": path.spline(s).ravel(),
                   "tangents": path.tangent(s).ravel(), "obstacles": obs.ravel()})


class PathSymbols:
    """The path parameter vector ``k`` (a symbol) split by :func:`path_table_layout`."""

    def __init__(self, k: Any, n_obstacles: int, n_samples: int = PATH_SAMPLES) -> None:
        L = path_table_layout(n_obstacles, n_samples)
        self.n_samples, self.n_obstacles = n_samples, n_obstacles
        self.length, self.closed, self.speed = k[L["length"]], k[L["closed"]], k[L["speed"]]
        self.points, self.tangents = k[L["points"]], k[L["tangents"]]
        self.obstacles = ca.reshape(k[L["obstacles"]], 3, max(n_obstacles, 1))


def _interp(values: Any, u: Any, n: int) -> Any:
    """Linear interpolation of the table ``values`` (n x 2 interleaved) at grid
    coordinates ``u`` (a row, in samples): a 2 x len(u) matrix."""
    f = ca.interpolant("ballbot_path_table", "linear", [np.arange(n, dtype=float)], 2,
                       {"lookup_mode": ["exact"]})
    # one call per point, each reading the one table (a map would copy it per point into
    # its work vector: 2 x 21 x 4096 doubles for the MPC's horizon)
    return ca.horzcat(*(f(u[i], values) for i in range(u.numel())))


def path_eval(P: PathSymbols, s: Any) -> dict[str, Any]:
    """``point`` (2 x n), unit ``tangent`` (2 x n) and reference progress ``speed``
    (1 x n) at the arc lengths ``s`` (n), and the progress bound ``s_max`` (the length of
    an open path, 1e9 on a closed one)."""
    s = ca.reshape(s, 1, s.numel())
    L, closed = P.length, P.closed > 0.5
    sw = ca.if_else(closed, s - L * ca.floor(s / L), ca.fmin(ca.fmax(s, 0.0), L))
    u = sw * ((P.n_samples - 1) / L)
    pt = _interp(P.points, u, P.n_samples)
    tg = _interp(P.tangents, u, P.n_samples)
    tg = tg / ca.repmat(ca.sqrt(ca.sum1(tg ** 2)), 2, 1)
    # an open path continues straight past its ends
    pt = pt + ca.if_else(closed, 0.0, 1.0) * ca.repmat(s - sw, 2, 1) * tg
    speed = ca.if_else(closed, P.speed * ca.DM.ones(1, s.numel()),
                       ca.fmin(P.speed, ca.sqrt(2.0 * A_STOP * ca.fmax(L - s, 0.0))))
    return {"point": pt, "tangent": tg, "speed": speed,
            "s_max": ca.if_else(closed, 1e9, L)}
