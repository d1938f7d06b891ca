"""``ballbot study full_cascade``: thesis §9.3.1 with the velocity controller in the loop.

The thesis's complete system (Fig. 9.8) runs the sine test through the cascade, where
the balance controller's attitude reference comes from the velocity controller; an
attitude sine cannot be given to it directly (a scenario with ``cascade = true`` and an
attitude reference is refused).  Here the sine goes *through* the cascade: the lateral
velocity reference is the one whose balance lean is the 3° roll sine at 0.5 Hz,
``vy(t) = A (1 - cos 2 pi f t)`` with ``A = g tan(3°) / (2 pi f)`` (the ball accelerates
at ``g tan(roll)``, so the lean follows ``sin 2 pi f t`` from upright), sampled as
velocity keyframes every :data:`KEYFRAME_S` (piecewise-linear, within the 1 m/s² of §7.1).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from ballbot_casadi.analysis.metrics import rpy_deg, run_metrics
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.scenario import set_value

__all__ = ["KEYFRAME_S", "SETTLE_S", "cascade_sine_expand", "cascade_sine_metrics"]

#: Spacing of the velocity keyframes that sample the sine (s).
KEYFRAME_S = 0.05
#: Start-up excluded from the error metrics (s).
SETTLE_S = 2.0
_G = 9.81


def cascade_sine_expand(tables: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The (last) file's roll sine turned into the lateral velocity reference of the cascade."""
    main = tables[-1]
    roll = main["attitude"]["roll"]
    f, amp = float(roll["frequency_hz"]), math.radians(float(roll["amplitude_deg"]))
    A = _G * math.tan(amp) / (2 * math.pi * f)
    t = np.arange(0.0, float(main["duration_s"]) - KEYFRAME_S / 2, KEYFRAME_S)
    v = A * (1 - np.cos(2 * math.pi * f * (t + KEYFRAME_S)))  # target reached at the next keyframe
    prev = np.concatenate([[0.0], v[:-1]])
    rows = [{"t_s": float(ti), "vy_mps": float(vi),
             "accel_mps2": float(max(abs(vi - pi) / KEYFRAME_S * 1.001, 1e-3))}
            for ti, vi, pi in zip(t, v, prev)]
    out = {k: val for k, val in main.items() if k not in ("attitude", "initial", "spec")}
    out = set_value(set_value(set_value(out, "cascade", True), "velocity", rows), "name",
                    f"{main.get('name', 'sine')}_cascade")
    return [out]


def cascade_sine_metrics(logs: Sequence[SimulationLog]) -> dict[str, Any]:
    """Roll amplitude reached through the cascade and the pitch / yaw tracking errors
    against the velocity controller's attitude reference (after :data:`SETTLE_S`)."""
    log = logs[-1]
    a = log.arrays
    n = a["q_ref"].shape[0]
    t = a["time"][:n]
    win = t >= SETTLE_S
    ang = rpy_deg(a["state"][:n, STATE["q"]])
    ref = rpy_deg(a["q_ref"])
    err = (ang - ref + 180.0) % 360.0 - 180.0
    m = run_metrics(log)
    return {"roll_amplitude_deg": float((np.max(ang[win, 0]) - np.min(ang[win, 0])) / 2),
            "pitch_error_max_deg": float(np.max(np.abs(err[win, 1]))),
            "yaw_error_max_deg": float(np.max(np.abs(err[win, 2]))),
            "yaw_error_final_deg": float(err[-1, 2]),
            "tilt_error_max_deg": m.get("tilt_error_max_deg"),
            "heading_error_max_deg": m.get("heading_error_max_deg")}
