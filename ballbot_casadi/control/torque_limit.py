"""The controllers' direction-preserving wheel-torque limit (thesis §9.1 discussion)."""

from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["saturate_torques"]


def saturate_torques(tau: object, tau_max: object) -> object:
    """Direction-preserving torque limit: scale ``tau`` so that ``max |tau_i| <= tau_max``.

    Clipping each wheel separately changes the direction of the torque vector and so
    leaks tilt demand into yaw (on the thesis §8.4.1 test the heading swings by ~20 deg
    with clipping and ~0.1 deg with scaling); scaling keeps the decoupling.  Works on
    numpy arrays and on CasADi SX/MX (then ``tau_max`` may be symbolic); the closed loop
    applies it at the controller's internal ``tau_max`` before the plant's per-wheel
    saturation.
    """
    if isinstance(tau, (ca.SX, ca.MX)) or isinstance(tau_max, (ca.SX, ca.MX)):
        m = ca.mmax(ca.fabs(tau))
        return tau * ca.fmin(1, tau_max / ca.fmax(m, 1e-300))
    t = np.asarray(tau, dtype=float).ravel()
    m = float(np.max(np.abs(t))) if t.size else 0.0
    return t * (float(tau_max) / m) if m > float(tau_max) else t.copy()
