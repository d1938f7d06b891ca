"""Paths for path following: C2 curves parametrised by arc length, circular obstacles.

A :class:`Path` is a planar curve ``P(s) = (x(s), y(s))`` with ``s`` the arc length
(m), stored as a cubic spline in ``s`` (C2; periodic for closed paths), a reference
progress speed and the circular obstacles around it.  Constructors:

* :func:`waypoint_path` - waypoints smoothed to a C2 cubic spline (chord-length fit,
  then re-parametrised by arc length);
* :func:`line_path`, :func:`arc_path` - a straight segment and a circular arc;
* :func:`figure_eight` - a lemniscate of Gerono, ``length`` x ``width`` (default 4 m x 2 m).

For the solver the path is handed over as a *window*: at the guessed progress values
``s_k`` of the horizon the points ``P(s_k)`` and unit tangents ``T(s_k)``
(:meth:`Path.window`); the MPC linearises ``P(s) ~ P(s_k) + T(s_k) (s - s_k)`` (one
Gauss-Newton step per sample, :mod:`ballbot_casadi.guidance.mpc`).

Obstacles are circles the ball centre must stay out of (their radius includes the
robot's footprint); clearance is the distance of the ball centre to the circle.

Validation (:class:`~ballbot_casadi.errors.ScenarioError`, one line naming the key):
fewer than two waypoints, NaN/Inf, repeated consecutive waypoints, a reference speed
outside ``(0, v_max]`` (thesis §7.1, :data:`~ballbot_casadi.core.constants.THESIS_LIMITS`),
a non-positive obstacle radius, and a waypoint (a point the path must pass through:
start, end, the given waypoints) inside an obstacle.  The smooth curve between
waypoints may cross an obstacle: avoiding it is the guidance's job.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
from scipy.interpolate import CubicSpline

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.errors import ScenarioError

__all__ = [
    "Obstacle",
    "Path",
    "waypoint_path",
    "line_path",
    "arc_path",
    "figure_eight",
    "path_from_spec",
    "PATH_TYPES",
    "DEFAULT_SPEED",
]

#: Default reference progress speed (m/s): 0.5 m/s, the thesis §7.1 limit.
DEFAULT_SPEED = THESIS_LIMITS["v_max"]
#: Samples per metre of the dense polyline used for arc length and projection.
_DENSITY = 400


@dataclass(frozen=True)
class Obstacle:
    """A circle ``|p - center| >= radius`` the ball centre must stay out of."""

    center: tuple[float, float]
    radius: float


@dataclass(frozen=True, eq=False)
class Path:
    """A C2 planar path parametrised by arc length (build with the module's constructors).

    Attributes
    ----------
    spline
        Cubic spline ``s -> (x, y)`` with ``|dP/ds| = 1`` (to the resampling accuracy).
    length
        Arc length (m).
    closed
        Closed (periodic) path: ``s`` is taken modulo ``length``.
    speed
        Reference progress speed (m/s), ``0 < speed <= v_max``.
    obstacles
        Circular obstacles.
    waypoints
        The points the path must pass through (checked against the obstacles).
    """

    spline: CubicSpline
    length: float
    closed: bool
    speed: float
    obstacles: tuple[Obstacle, ...] = ()
    waypoints: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def _wrap(self, s: np.ndarray) -> np.ndarray:
        return np.mod(s, self.length) if self.closed else np.clip(s, 0.0, self.length)

    def point(self, s: Any) -> np.ndarray:
        """``P(s)`` (shape ``(..., 2)``); an open path continues straight past its ends."""
        s = np.asarray(s, float)
        sw = self._wrap(s)
        p = self.spline(sw)
        if not self.closed:
            p = p + (s - sw)[..., None] * self.tangent(sw)
        return p

    def tangent(self, s: Any) -> np.ndarray:
        """Unit tangent ``dP/ds`` (shape ``(..., 2)``)."""
        d = self.spline(self._wrap(np.asarray(s, float)), 1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def curvature(self, s: Any) -> np.ndarray:
        """Signed curvature ``x' y'' - y' x''`` (1/m, positive turning left)."""
        sw = self._wrap(np.asarray(s, float))
        d1, d2 = self.spline(sw, 1), self.spline(sw, 2)
        n = np.linalg.norm(d1, axis=-1)
        return (d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]) / n**3

    def dense(self, step: float = 1.0 / _DENSITY) -> tuple[np.ndarray, np.ndarray]:
        """Arc-length samples ``s`` and points ``P(s)`` every ``step`` metres."""
        s = np.linspace(0.0, self.length, max(int(math.ceil(self.length / step)), 2) + 1)
        return s, self.spline(s)

    def project(self, p: Any, s_guess: float | None = None, reach: float = 0.5) -> float:
        """Arc length of the point of the path closest to ``p``.

        With ``s_guess`` only ``[s_guess - reach, s_guess + reach]`` is searched (so a
        figure-eight's crossing does not make the projection jump branches) and the
        result is unwrapped next to ``s_guess``; otherwise the whole path.  A dense
        search is refined by Newton steps on ``T(s) . (P(s) - p) = 0``.
        """
        p = np.asarray(p, float).reshape(2)
        if s_guess is None:
            s, pts = self.dense()
        else:
            s = np.linspace(s_guess - reach, s_guess + reach, int(2 * reach * _DENSITY) + 1)
            if not self.closed:
                s = np.clip(s, 0.0, self.length)
            pts = self.point(s)
        best = float(s[np.argmin(np.sum((pts - p) ** 2, axis=1))])
        for _ in range(3):
            sw = float(self._wrap(np.asarray(best)))
            d1, d2 = self.spline(sw, 1), self.spline(sw, 2)
            r = self.spline(sw) - p
            den = float(d1 @ d1 + r @ d2)
            if den <= 1e-9:
                break
            best -= float(d1 @ r) / den
            if not self.closed:
                best = min(max(best, 0.0), self.length)
        return best

    def reference_speed(self, s: Any, a_stop: float = 0.5 * THESIS_LIMITS["a_max"]) -> np.ndarray:
        """Progress-speed reference: ``speed``, ramped down to stop at the end of an open path."""
        s = np.asarray(s, float)
        if self.closed:
            return np.full(s.shape, self.speed)
        return np.minimum(self.speed, np.sqrt(2.0 * a_stop * np.clip(self.length - s, 0.0, None)))

    def window(self, s: Any) -> tuple[np.ndarray, np.ndarray]:
        """Solver parameters at the guessed progress ``s`` (N+1): points and unit tangents."""
        s = np.asarray(s, float).ravel()
        return self.point(s), self.tangent(s)

    def clearance(self, p: Any) -> np.ndarray:
        """Distance of each point ``p`` (M, 2) to the nearest obstacle circle (inf if none)."""
        p = np.atleast_2d(np.asarray(p, float))
        if not self.obstacles:
            return np.full(p.shape[0], np.inf)
        c = np.array([o.center for o in self.obstacles])
        r = np.array([o.radius for o in self.obstacles])
        return np.min(np.linalg.norm(p[:, None, :] - c[None], axis=2) - r[None], axis=1)


def _finite_points(points: Any, key: str) -> np.ndarray:
    try:
        pts = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise ScenarioError(f"{key} must be a list of [x, y] points in metres") from None
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ScenarioError(f"{key} must be a list of [x, y] points, got shape {pts.shape}")
    if pts.shape[0] < 2:
        raise ScenarioError(f"{key} needs at least two points, got {pts.shape[0]}")
    if not np.all(np.isfinite(pts)):
        raise ScenarioError(f"{key} contains NaN or Inf; points must be finite")
    return pts


def _obstacles(obstacles: Sequence[Any]) -> tuple[Obstacle, ...]:
    out = []
    for j, ob in enumerate(obstacles):
        if isinstance(ob, Obstacle):
            c, r = ob.center, ob.radius
        elif isinstance(ob, dict):
            c, r = ob.get("center"), ob.get("radius")
        else:
            c, r = (ob[:2], ob[2]) if len(ob) == 3 else (None, None)
        try:
            c = tuple(float(v) for v in c)  # type: ignore[union-attr]
            r = float(r)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise ScenarioError(f"obstacles[{j}] must be {{center: [x, y], radius: r}} or "
                                "[x, y, r]") from None
        if len(c) != 2 or not all(math.isfinite(v) for v in (*c, r)):
            raise ScenarioError(f"obstacles[{j}] must have a finite 2-D center and radius")
        if r <= 0.0:
            raise ScenarioError(f"obstacles[{j}].radius must be > 0 m, got {r!r}")
        out.append(Obstacle((c[0], c[1]), r))
    return tuple(out)


def _check_speed(speed: Any) -> float:
    v_max = THESIS_LIMITS["v_max"]
    try:
        v = float(speed)
    except (TypeError, ValueError):
        raise ScenarioError(f"speed must be a number in (0, {v_max}] m/s, got {speed!r}") from None
    if not (math.isfinite(v) and 0.0 < v <= v_max):
        raise ScenarioError(f"speed must be in (0, {v_max}] m/s (thesis §7.1 v_max), got {speed!r}")
    return v


def _build(xy: np.ndarray, t: np.ndarray, closed: bool, speed: Any, obstacles: Sequence[Any],
           waypoints: np.ndarray) -> Path:
    """Spline through samples ``xy(t)``, re-parametrised by arc length, validated."""
    v = _check_speed(speed)
    obs = _obstacles(obstacles)
    bc = "periodic" if closed else "not-a-knot"
    first = CubicSpline(t, xy, bc_type=bc)
    tt = np.linspace(t[0], t[-1], max(int((t[-1] - t[0]) * _DENSITY), 200) * 4 + 1)
    d = np.linalg.norm(first(tt, 1), axis=1)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (d[1:] + d[:-1]) * np.diff(tt))])
    n = max(int(math.ceil(s[-1] * 20)), 8)  # knots every 5 cm of arc length
    sk = np.linspace(0.0, s[-1], n + 1)
    pk = first(np.interp(sk, s, tt))
    if closed:
        pk[-1] = pk[0]
    path = Path(CubicSpline(sk, pk, bc_type=bc), float(s[-1]), closed, v, obs, waypoints)
    for j, ob in enumerate(obs):
        inside = np.linalg.norm(waypoints - np.array(ob.center), axis=1) < ob.radius
        if np.any(inside):
            k = int(np.argmax(inside))
            raise ScenarioError(f"obstacles[{j}] (radius {ob.radius} m at {list(ob.center)}) "
                                f"covers waypoint {k} {waypoints[k].tolist()}: the path cannot "
                                "pass through it")
    return path


def waypoint_path(points: Any, speed: float = DEFAULT_SPEED, closed: bool = False,
                  obstacles: Sequence[Any] = ()) -> Path:
    """Waypoints smoothed to a C2 cubic spline (chord-length knots), by arc length."""
    pts = _finite_points(points, "waypoints")
    if closed and np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
        if pts.shape[0] < 2:
            raise ScenarioError("waypoints needs at least two distinct points for a closed path")
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.any(chords < 1e-6):
        k = int(np.argmax(chords < 1e-6))
        raise ScenarioError(f"waypoints {k} and {k + 1} coincide; consecutive points must differ")
    xy = np.vstack([pts, pts[:1]]) if closed else pts
    t = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    if xy.shape[0] == 2:  # a straight line: add the midpoint so the spline is well posed
        xy = np.vstack([xy[0], 0.5 * (xy[0] + xy[1]), xy[1]])
        t = np.array([0.0, 0.5 * t[1], t[1]])
    return _build(xy, t, closed, speed, obstacles, pts)


def line_path(start: Any, end: Any, speed: float = DEFAULT_SPEED,
              obstacles: Sequence[Any] = ()) -> Path:
    """The straight segment from ``start`` to ``end``."""
    return waypoint_path([start, end], speed, False, obstacles)


def arc_path(center: Any, radius: float, start_angle: float, sweep: float,
             speed: float = DEFAULT_SPEED, obstacles: Sequence[Any] = ()) -> Path:
    """A circular arc (angles in rad, ``sweep`` > 0 counter-clockwise); ``|sweep| = 2 pi`` closes it."""
    c = _finite_points([center, center], "center")[0]
    if not (math.isfinite(radius) and radius > 0.0):
        raise ScenarioError(f"radius must be > 0 m, got {radius!r}")
    if not (math.isfinite(sweep) and math.isfinite(start_angle) and sweep != 0.0):
        raise ScenarioError(f"sweep must be a finite nonzero angle (rad), got {sweep!r}")
    closed = abs(abs(sweep) - 2 * math.pi) < 1e-12
    n = max(int(abs(sweep) * radius * 40), 16)
    th = start_angle + np.linspace(0.0, sweep, n + 1)
    xy = c + radius * np.column_stack([np.cos(th), np.sin(th)])
    if closed:  # the periodic spline needs the end to be the start bit for bit
        xy[-1] = xy[0]
    t = np.abs(th - start_angle) * radius
    ends = xy[:1] if closed else xy[[0, -1]]
    return _build(xy, t, closed, speed, obstacles, ends)


def figure_eight(length: float = 4.0, width: float = 2.0, center: Any = (0.0, 0.0),
                 speed: float = DEFAULT_SPEED, obstacles: Sequence[Any] = ()) -> Path:
    """Lemniscate of Gerono ``x = L/2 sin t``, ``y = W/2 sin 2t`` (closed), starting at ``center``."""
    for key, val in (("length", length), ("width", width)):
        if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0.0):
            raise ScenarioError(f"{key} must be > 0 m, got {val!r}")
    c = _finite_points([center, center], "center")[0]
    t = np.linspace(0.0, 2 * math.pi, 1601)
    xy = c + np.column_stack([0.5 * length * np.sin(t), 0.5 * width * np.sin(2 * t)])
    xy[-1] = xy[0]
    return _build(xy, t, True, speed, obstacles, xy[:1])


#: Path types of a scenario file's ``[path]`` table and their keys (besides ``type`` and
#: ``speed``): required, then optional.
PATH_TYPES = {
    "waypoints": (("waypoints",), ("closed",)),
    "line": (("start", "end"), ()),
    "arc": (("center", "radius", "sweep_deg"), ("start_angle_deg",)),
    "figure_eight": ((), ("length", "width", "center")),
}


_KEY_OF = {"sweep": "sweep_deg", "start_angle": "start_angle_deg"}


def _keyed(build: Any, *args: Any, **kwargs: Any) -> Path:
    """``build(...)`` with its :class:`ScenarioError` keyed ``path.<key>`` or
    ``obstacle[j]`` (the key a message starts with)."""
    try:
        return build(*args, **kwargs)
    except ScenarioError as exc:
        if exc.key is not None:
            raise
        head = str(exc).split(" ", 1)[0]
        key = (head.replace("obstacles[", "obstacle[").split(".")[0] if head.startswith("obstacles[")
               else f"path.{_KEY_OF.get(head, head)}")
        raise ScenarioError(str(exc), key=key) from None


def path_from_spec(spec: Any, obstacles: Sequence[Any] = ()) -> Path:
    """The :class:`Path` of a scenario file's ``[path]`` table (``type`` one of
    :data:`PATH_TYPES`, ``speed`` in m/s, angles in degrees) and ``[[obstacle]]`` rows
    ``(x, y, r)``; a bad table is refused with one line naming the key (``path.<key>``,
    ``obstacle[j]``)."""
    if not isinstance(spec, dict):
        raise ScenarioError(f"path must be a table, got {type(spec).__name__}", key="path")
    kind = spec.get("type")
    if kind not in PATH_TYPES:
        raise ScenarioError(f"path.type must be one of {', '.join(PATH_TYPES)}, got {kind!r}",
                            key="path.type")
    required, optional = PATH_TYPES[kind]
    for k in spec:
        if k not in ("type", "speed", *required, *optional):
            raise ScenarioError(f"path.{k}: unknown key for a {kind} path; allowed: "
                                f"{', '.join(('type', 'speed', *required, *optional))}",
                                key=f"path.{k}")
    for k in required:
        if k not in spec:
            raise ScenarioError(f"path.{k}: missing (required for a {kind} path)", key=f"path.{k}")
    speed = spec.get("speed", DEFAULT_SPEED)
    obs = [tuple(o) for o in obstacles]
    for k in ("radius", "sweep_deg", "start_angle_deg", "length", "width"):
        if k in spec and (isinstance(spec[k], bool) or not isinstance(spec[k], (int, float))
                          or not math.isfinite(spec[k])):
            raise ScenarioError(f"path.{k} must be a finite number, got {spec[k]!r}",
                                key=f"path.{k}")
    if kind == "waypoints":
        return _keyed(waypoint_path, spec["waypoints"], speed, bool(spec.get("closed", False)), obs)
    if kind == "line":
        for k in ("start", "end"):
            _keyed(_finite_points, [spec[k], spec[k]], k)
        return _keyed(line_path, spec["start"], spec["end"], speed, obs)
    if kind == "arc":
        _keyed(_finite_points, [spec["center"], spec["center"]], "center")
        return _keyed(arc_path, spec["center"], spec["radius"],
                      math.radians(spec.get("start_angle_deg", 0.0)),
                      math.radians(spec["sweep_deg"]), speed, obs)
    # the keys left out take figure_eight's own defaults
    return _keyed(figure_eight, speed=speed, obstacles=obs,
                  **{k: spec[k] for k in ("length", "width", "center") if k in spec})
