"""Named layouts of the package's vectors: every index is defined here once and used by name.

A :class:`Layout` is an ordered list of named fields with sizes (a field may itself be a
layout: ``L["c.xa"]``); ``L["q"]`` (or ``L.slice("q")``) is the slice of field ``q``,
``L.offset("q")`` its first index, ``L.index("dx")`` the index of a scalar field, ``L.names`` the element
names (``q0..q3`` for a 4-vector ``q``).  Slices work on numpy arrays and CasADi
SX/MX/DM alike.

Layouts
-------
:data:`STATE`
    Plant state ``x = [x, y, q, dx, dy, dq]`` (thesis C.1: ball position in {I}, body
    attitude quaternion of {B} in {K}, and their time derivatives), 12 entries.
:data:`REDUCED_STATE`
    Minimal 10-state model on the quaternion constraint's tangent space (``v`` the
    attitude increment, see :mod:`ballbot_casadi.model.linearization`).
:data:`GENERALISED`
    Generalised coordinates ``chi = [x, y, q]`` (thesis C.1), 6 entries.
:data:`DISTURBANCE`
    Per-period disturbance ``w = [push, tau_dist]``: attitude jump rotation vector in
    {K} (thesis §8.4.3) and a wheel-torque disturbance added after the plant's
    saturation.
:data:`ATTITUDE_FILTER_STATE`, :data:`VELOCITY_FILTER_STATE`
    The filters' states ``xa = [q, omega]`` (thesis 4.1) and ``xv = [v, a, b_acc]``
    (thesis 5.1).
:data:`VELOCITY_CONTROLLER_STATE`
    Velocity controller state ``z = [theta_r, dtheta_r, p_e, psi_r, r_r]`` (thesis §7.3):
    tilt reference and its rate, position error (integral of the velocity error),
    heading reference and heading-rate reference.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any, Iterable, Mapping

import numpy as np

__all__ = [
    "Layout",
    "STATE",
    "REDUCED_STATE",
    "DISTURBANCE",
    "VELOCITY_CONTROLLER_STATE",
]


class Layout:
    """An ordered, immutable set of named fields of a flat vector.

    Parameters
    ----------
    name
        What the vector is (used in error messages).
    fields
        ``(field name, size)`` pairs in vector order.
    element_names
        Optional names of the individual entries (default: the field name for a scalar
        field, ``<field>0..`` otherwise).
    """

    __slots__ = ("name", "_slices", "_parts", "size", "names")

    def __init__(self, name: str, fields: Iterable[tuple[str, "int | Layout"]],
                 element_names: Iterable[str] | None = None) -> None:
        slices: dict[str, slice] = {}
        parts: dict[str, Layout] = {}
        names: list[str] = []
        start = 0
        for field, size in fields:
            n = size.size if isinstance(size, Layout) else int(size)
            if field in slices or n < 1 or "." in field:
                raise ValueError(f"layout {name}: field {field!r} repeated, dotted or of size {n}")
            slices[field] = slice(start, start + n)
            if isinstance(size, Layout):
                parts[field] = size
                names += [f"{field}.{e}" for e in size.names]
            else:
                names += [field] if n == 1 else [f"{field}{i}" for i in range(n)]
            start += n
        self.name = name
        self._slices: Mapping[str, slice] = MappingProxyType(slices)
        self._parts: Mapping[str, Layout] = MappingProxyType(parts)
        self.size = start
        self.names = tuple(element_names) if element_names is not None else tuple(names)
        if len(self.names) != self.size:
            raise ValueError(f"layout {name}: {len(self.names)} element names for {start} entries")

    @property
    def fields(self) -> tuple[str, ...]:
        """Field names in order."""
        return tuple(self._slices)

    def __getitem__(self, field: str) -> slice:
        """Slice of ``field``; ``"c.xa"`` is field ``xa`` of the nested layout ``c``."""
        head, _, rest = field.partition(".")
        try:
            s = self._slices[head]
        except KeyError:
            raise KeyError(f"{self.name} has no field {head!r}; fields: {', '.join(self._slices)}") from None
        if not rest:
            return s
        inner = self.part(head)[rest]
        return slice(s.start + inner.start, s.start + inner.stop)

    def slice(self, field: str) -> slice:
        """Slice of ``field`` (same as ``layout[field]``; dotted paths reach nested layouts)."""
        return self[field]

    def offset(self, field: str) -> int:
        """Index of the first entry of ``field``."""
        return self[field].start

    def size_of(self, field: str) -> int:
        """Number of entries of ``field``."""
        s = self[field]
        return s.stop - s.start

    def part(self, field: str) -> "Layout":
        """The nested layout of ``field`` (a field given as a :class:`Layout`)."""
        try:
            return self._parts[field]
        except KeyError:
            raise KeyError(f"{self.name} field {field!r} is not a nested layout; nested: "
                           f"{', '.join(self._parts) or 'none'}") from None

    def has(self, field: str) -> bool:
        """Whether ``field`` (dotted paths allowed) exists."""
        try:
            self[field]
        except KeyError:
            return False
        return True

    def index(self, field: str) -> int:
        """Index of a scalar field."""
        s = self[field]
        if s.stop - s.start != 1:
            raise KeyError(f"{self.name} field {field!r} has {s.stop - s.start} entries, not one")
        return s.start

    def pack(self, parts: Mapping[str, Any]) -> np.ndarray:
        """The vector from its fields by name (dotted paths reach nested fields); every
        entry must be given exactly once."""
        out = np.full(self.size, np.nan)
        given = np.zeros(self.size, dtype=int)
        for field, value in parts.items():
            v = np.asarray(value, float).ravel()
            if v.size != self.size_of(field):
                raise ValueError(f"{self.name}: field {field!r} has {v.size} entries, "
                                 f"expected {self.size_of(field)}")
            out[self[field]] = v
            given[self[field]] += 1
        if np.any(given != 1):
            bad = [f for f, o, n in self.flat() if np.any(given[o:o + n] != 1)]
            raise ValueError(f"{self.name}: fields {', '.join(bad)} not given exactly once")
        return out

    def flat(self) -> tuple[tuple[str, int, int], ...]:
        """``(dotted field name, offset, size)`` of every field, nested layouts expanded
        after their own entry."""
        out: list[tuple[str, int, int]] = []
        for f, s in self._slices.items():
            out.append((f, s.start, s.stop - s.start))
            if f in self._parts:
                out += [(f"{f}.{g}", s.start + o, n) for g, o, n in self._parts[f].flat()]
        return tuple(out)

    def __len__(self) -> int:
        return self.size

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Layout) and self.flat() == other.flat()

    def __hash__(self) -> int:
        return hash(self.flat())

    def __repr__(self) -> str:
        return f"Layout({self.name!r}, {[(f, s.stop - s.start) for f, s in self._slices.items()]})"


STATE = Layout(
    "plant state",
    [("x", 1), ("y", 1), ("q", 4), ("dx", 1), ("dy", 1), ("dq", 4)],
)
#: Ball position ``[x, y]`` and velocity ``[dx, dy]`` as slices of :data:`STATE`.
STATE_XY = slice(STATE["x"].start, STATE["y"].stop)
STATE_DXY = slice(STATE["dx"].start, STATE["dy"].stop)

REDUCED_STATE = Layout(
    "reduced state",
    [("x", 1), ("y", 1), ("v", 3), ("dx", 1), ("dy", 1), ("dv", 3)],
    ("x", "y", "v1", "v2", "v3", "dx", "dy", "dv1", "dv2", "dv3"),
)
#: The two tilt components of the reduced attitude (about {K} x and y).
REDUCED_TILT = slice(REDUCED_STATE["v"].start, REDUCED_STATE["v"].start + 2)

#: Generalised coordinates ``chi = [x, y, q]`` of the Euler-Lagrange model (thesis C.1);
#: the state is ``[chi, dchi]``.
GENERALISED = Layout("generalised coordinates chi", [("x", 1), ("y", 1), ("q", 4)])

DISTURBANCE = Layout("disturbance w", [("push", 3), ("tau_dist", 3)])

VELOCITY_CONTROLLER_STATE = Layout(
    "velocity controller state z",
    [("theta_r", 2), ("dtheta_r", 2), ("p_e", 2), ("psi_r", 1), ("r_r", 1)],
    ("theta_rx", "theta_ry", "dtheta_rx", "dtheta_ry", "p_ex", "p_ey", "psi_r", "r_r"),
)

#: Attitude filter state ``xa = [q, omega]`` (thesis 4.1; QUKF and QEKF).
ATTITUDE_FILTER_STATE = Layout("attitude filter state xa", [("q", 4), ("omega", 3)])

#: Velocity filter state ``xv = [v, a, b_acc]`` (thesis 5.1; VUKF and VEKF): ball velocity,
#: ball acceleration and the accelerometer bias.
VELOCITY_FILTER_STATE = Layout("velocity filter state xv", [("v", 2), ("a", 2), ("b_acc", 3)])

__all__ += ["ATTITUDE_FILTER_STATE", "VELOCITY_FILTER_STATE"]
__all__ += ["STATE_XY", "STATE_DXY", "REDUCED_TILT", "GENERALISED"]

#: Planar state of the outer-loop designs at the upright equilibrium (thesis §7.3): ball
#: velocity, tilt angles about {K} x and y and their rates, ``s = [dx, dy, th, dth]`` with
#: ``q_{1,2} = th_{x,y} / 2`` and ``dq_{1,2} = dth_{x,y} / 2`` to first order.
PLANAR_STATE = Layout("planar state s", [("dxy", 2), ("th", 2), ("dth", 2)],
                      ("dx", "dy", "th_x", "th_y", "dth_x", "dth_y"))


def planar_maps() -> tuple[np.ndarray, np.ndarray]:
    """``(T, S)`` between :data:`PLANAR_STATE` ``s`` and :data:`STATE` ``x`` at upright.

    ``x = x_up + T s`` (12 x 6: the velocity rows, half the tilt into ``q_{1,2}``, half the
    tilt rate into ``dq_{1,2}``) and ``s' = S x'`` (6 x 12, ``S T = I``): the linearised
    plant ``x' = A x + B tau`` reads ``s' = S A T s + S B tau`` on the planar state.
    """
    T = np.zeros((STATE.size, PLANAR_STATE.size))
    S = np.zeros((PLANAR_STATE.size, STATE.size))
    q12 = slice(STATE["q"].start + 1, STATE["q"].start + 3)
    dq12 = slice(STATE["dq"].start + 1, STATE["dq"].start + 3)
    for sl, xs, k in ((PLANAR_STATE["dxy"], STATE_DXY, 1.0), (PLANAR_STATE["th"], q12, 0.5),
                      (PLANAR_STATE["dth"], dq12, 0.5)):
        T[xs, sl] = k * np.eye(2)
        S[sl, xs] = np.eye(2) / k
    return T, S


__all__ += ["PLANAR_STATE", "planar_maps"]
