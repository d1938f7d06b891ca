"""Named layouts of the package's vectors: every index is defined here once and used by name.

A :class:`Layout` is an ordered list of named fields with sizes; ``L["q"]`` is the slice
of field ``q``, ``L.index("dx")`` the index of a scalar field, ``L.names`` the element
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
:data:`VELOCITY_CONTROLLER_STATE`
    Velocity controller state ``z = [theta_r, dtheta_r, p_e, psi_r, r_r]`` (thesis §7.3):
    tilt reference and its rate, position error (integral of the velocity error),
    heading reference and heading-rate reference.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Iterable, Mapping

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

    __slots__ = ("name", "_slices", "size", "names")

    def __init__(self, name: str, fields: Iterable[tuple[str, int]],
                 element_names: Iterable[str] | None = None) -> None:
        slices: dict[str, slice] = {}
        names: list[str] = []
        start = 0
        for field, n in fields:
            if field in slices or n < 1:
                raise ValueError(f"layout {name}: field {field!r} repeated or of size {n}")
            slices[field] = slice(start, start + n)
            names += [field] if n == 1 else [f"{field}{i}" for i in range(n)]
            start += n
        self.name = name
        self._slices: Mapping[str, slice] = MappingProxyType(slices)
        self.size = start
        self.names = tuple(element_names) if element_names is not None else tuple(names)
        if len(self.names) != self.size:
            raise ValueError(f"layout {name}: {len(self.names)} element names for {start} entries")

    @property
    def fields(self) -> tuple[str, ...]:
        """Field names in order."""
        return tuple(self._slices)

    def __getitem__(self, field: str) -> slice:
        try:
            return self._slices[field]
        except KeyError:
            raise KeyError(f"{self.name} has no field {field!r}; fields: {', '.join(self._slices)}") from None

    def index(self, field: str) -> int:
        """Index of a scalar field."""
        s = self[field]
        if s.stop - s.start != 1:
            raise KeyError(f"{self.name} field {field!r} has {s.stop - s.start} entries, not one")
        return s.start

    def __len__(self) -> int:
        return self.size

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

__all__ += ["STATE_XY", "STATE_DXY", "REDUCED_TILT", "GENERALISED"]
