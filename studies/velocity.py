"""``ballbot study velocity``: the Fig. 9.3-like profile (thesis §9.2), and the same profile
at the thesis's own acceleration limit (§7.1 item 2: 1 m/s²).

The shipped profile ramps at 0.25 m/s²; :func:`accel_limit_expand` runs it a second time
with every ramp at :data:`THESIS_ACCEL_LIMIT`, so the §7.1 limits are measured where the
thesis allows the robot to operate (:func:`velocity_study_metrics`: the main run's
metrics plus ``accel_limit_<metric>`` of that run).
"""

from __future__ import annotations

from typing import Any, Sequence

from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.scenario import set_value

__all__ = ["THESIS_ACCEL_LIMIT", "accel_limit_expand", "velocity_study_metrics"]

#: Linear acceleration limit of thesis §7.1 item 2 (m/s²).
THESIS_ACCEL_LIMIT = 1.0
_KEYS = ("velocity_error_rms_delayed_mps", "max_abs_roll_pitch_deg", "max_acceleration_mps2",
         "max_speed_mps", "peak_tilt_rate_deg_s")


def accel_limit_expand(tables: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The profile with every ramp at the thesis's acceleration limit, then as shipped."""
    main = tables[-1]
    rows = [{**row, "accel_mps2": THESIS_ACCEL_LIMIT} for row in main.get("velocity", [])]
    fast = set_value(set_value(main, "velocity", rows), "name", f"{main.get('name', 'velocity')}_accel_limit")
    return [fast, main]


def velocity_study_metrics(logs: Sequence[SimulationLog]) -> dict[str, Any]:
    """``accel_limit_<k>`` of the run at the thesis's acceleration limit (first run)."""
    m = run_metrics(logs[0])
    return {f"accel_limit_{k}": m.get(k) for k in _KEYS}
