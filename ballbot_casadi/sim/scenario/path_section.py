"""The path-following part of a scenario: file ``[path]``, ``[[obstacle]]`` and ``guidance``.

``[path]`` is a table with ``type`` (``waypoints``, ``line``, ``arc``, ``figure_eight``,
:data:`~ballbot_casadi.guidance.paths.PATH_TYPES`), its geometry keys and ``speed``
(m/s); each ``[[obstacle]]`` row has ``x``, ``y`` and ``r`` (m); ``guidance`` chooses the
law in the period's guidance slot (``mpc``: the MPC feeding the velocity LQR, ``pursuit``,
or ``mpc_balance``: the MPC feeding the balance controller directly,
:mod:`ballbot_casadi.sim.guided`, :mod:`ballbot_casadi.sim.balance_feed`).
``guidance_latency`` (periods, an integer ``0 <= L <`` :data:`LATENCY_LIMIT`, default 0;
the velocity-feed MPC only) applies each guidance sample's reference ``L`` control
periods after the sample, the split firmware's arrangement
(:func:`~ballbot_casadi.sim.guided.mpc_law` ``latency``).
The section is validated by building the path
(:func:`~ballbot_casadi.guidance.paths.path_from_spec`): fewer than two points, NaN, a
waypoint inside an obstacle, a speed above the thesis §7.1 ``v_max`` are refused with one
line naming the key.  A scenario with a path is a cascade run.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any, Mapping

from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.validation import plain_json
from ballbot_casadi.errors import BallbotTypeError, ScenarioError
from ballbot_casadi.guidance.mpc import MpcConfig
from ballbot_casadi.guidance.paths import Path, path_from_spec
from ballbot_casadi.sim.scenario.checker import FileChecker

__all__ = ["PathSection", "GUIDANCE_CHOICES", "LATENCY_LIMIT"]

#: The guidance laws a scenario may choose (the first is the default).
GUIDANCE_CHOICES = ("mpc", "pursuit", "mpc_balance")
#: ``guidance_latency`` is below this: the control periods of one MPC sample interval
#: (its ``dt`` over the control period, 20), so a sample's reference applies before the
#: next sample.
LATENCY_LIMIT = int(round(MpcConfig().dt / TS_CONTROL))


@dataclass(frozen=True)
class PathSection:
    """Path to follow (``path``: the file's ``[path]`` table, empty = none), its
    ``obstacles`` (rows ``(x, y, r)``), the ``guidance`` law and its
    ``guidance_latency`` (periods from a sample to its reference)."""

    path: Mapping[str, Any] = field(default_factory=dict)
    obstacles: tuple = ()
    guidance: str = GUIDANCE_CHOICES[0]
    guidance_latency: int = 0

    FIELDS = ("path", "obstacles", "guidance", "guidance_latency")
    TABLE_KEYS = ("path", "obstacle", "guidance", "guidance_latency")

    def check(self, run: Any) -> None:
        if not isinstance(self.path, Mapping):
            raise ScenarioError(f"path must be a table, got {type(self.path).__name__}", key="path")
        try:
            object.__setattr__(self, "path", plain_json(dict(self.path), "path"))
        except BallbotTypeError as e:
            raise ScenarioError(str(e), key="path") from None
        if self.guidance not in GUIDANCE_CHOICES:
            raise ScenarioError(f"guidance must be one of {', '.join(GUIDANCE_CHOICES)}, got "
                                f"{self.guidance!r}", key="guidance")
        lat = self.guidance_latency
        if not (isinstance(lat, int) and not isinstance(lat, bool) and 0 <= lat < LATENCY_LIMIT):
            raise ScenarioError(f"guidance_latency must be an integer in 0..{LATENCY_LIMIT - 1} "
                                f"control periods (less than a guidance sample interval), got "
                                f"{lat!r}", key="guidance_latency")
        if lat and self.guidance != "mpc":
            raise ScenarioError(f"guidance_latency = {lat} is an option of guidance = \"mpc\" "
                                f"(the velocity-feed MPC), got guidance = {self.guidance!r}",
                                key="guidance_latency")
        if lat and not self.path:
            raise ScenarioError(f"guidance_latency = {lat} needs a [path] to follow",
                                key="guidance_latency")
        rows = []
        for j, row in enumerate(self.obstacles):
            try:
                x, y, r = (float(v) for v in row)
            except (TypeError, ValueError):
                raise ScenarioError(f"obstacle[{j}] must be (x, y, r) in m, got {row!r}",
                                    key=f"obstacle[{j}]") from None
            rows.append((x, y, r))
        object.__setattr__(self, "obstacles", tuple(rows))
        if self.obstacles and not self.path:
            raise ScenarioError("obstacles need a [path] to follow", key="obstacle")
        if self.path:
            if not run.cascade:
                raise ScenarioError("a path is followed through the velocity loop: set "
                                    "cascade = true", key="path")
            self.build()

    def build(self) -> Path | None:
        """The :class:`Path` (``None`` without a path)."""
        return path_from_spec(copy.deepcopy(dict(self.path)), self.obstacles) if self.path else None

    @classmethod
    def from_file(cls, c: FileChecker, table: Mapping[str, Any]) -> "PathSection":
        path = table.get("path", {})
        if not isinstance(path, Mapping):
            raise c.fail("path", f"expected a table, got {type(path).__name__}")
        rows = []
        for j, row in enumerate(c.rows(table, "obstacle")):
            row = c.keys(row, f"obstacle[{j}]", ("x", "y", "r"), ("x", "y", "r"))
            rows.append((c.num(row, "x", f"obstacle[{j}].x"), c.num(row, "y", f"obstacle[{j}].y"),
                         c.num(row, "r", f"obstacle[{j}].r", lo=0.0, lo_open=True)))
        guidance = c.choice(table, "guidance", "guidance", GUIDANCE_CHOICES[0], GUIDANCE_CHOICES)
        latency = c.integer(table, "guidance_latency", "guidance_latency", 0, 0)
        return cls(dict(path), tuple(rows), guidance, latency)

    def to_file(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.path:
            out["path"] = dict(self.path)
        if self.obstacles:
            out["obstacle"] = [{"x": x, "y": y, "r": r} for x, y, r in self.obstacles]
        if self.guidance != GUIDANCE_CHOICES[0]:
            out["guidance"] = self.guidance
        if self.guidance_latency:
            out["guidance_latency"] = self.guidance_latency
        return out
