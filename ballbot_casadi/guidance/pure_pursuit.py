"""Pure-pursuit baseline: a velocity reference towards a look-ahead point on the path.

The baseline the MPC is measured against (issue 18).  Every guidance period it projects
the position onto the path (locally, next to the previous projection, so a
figure-eight's crossing keeps its branch), takes the point ``lookahead`` metres further
along the path and commands a velocity of the path's reference speed (ramped down at the
end of an open path) towards that point, plus a proportional pull ``k_lat`` onto the
path; the velocity LQR below does the rest.  No limits are predicted: the velocity
controller's own limits (thesis §7.1) are all it has.  It is holonomic (the ballbot needs
no heading to move), so "pursuit" is a direction, not a steering curvature.
"""

from __future__ import annotations

import numpy as np

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.paths import Path

__all__ = ["PurePursuit"]


class PurePursuit:
    """Pure pursuit on ``path`` with look-ahead ``lookahead`` (m) and lateral gain ``k_lat`` (1/s)."""

    def __init__(self, path: Path, lookahead: float = 0.3, k_lat: float = 1.0) -> None:
        if not (np.isfinite(lookahead) and lookahead > 0):
            raise ScenarioError(f"lookahead must be > 0 m, got {lookahead!r}")
        self.path, self.lookahead, self.k_lat = path, float(lookahead), float(k_lat)
        self.s: float | None = None

    def step(self, x_loop: np.ndarray) -> np.ndarray:
        """Velocity reference (2) from the loop state (its last two entries: the position)."""
        p = np.asarray(x_loop, float)[-2:]
        self.s = self.path.project(p, self.s)
        speed = float(self.path.reference_speed(self.s))
        target = self.path.point(self.s + self.lookahead)
        d = target - p
        n = np.linalg.norm(d)
        v = speed * d / n if n > 1e-9 else np.zeros(2)
        v = v + self.k_lat * (self.path.point(self.s) - p)
        norm = np.linalg.norm(v)
        return v * min(1.0, self.path.speed / norm) if norm > 0 else v

    def progress(self) -> float:
        """Arc length of the last projection."""
        return float("nan") if self.s is None else float(self.s)
