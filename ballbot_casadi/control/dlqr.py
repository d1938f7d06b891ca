"""One discrete LQR design with the stability check both LQR controllers need.

The balance LQR (:mod:`ballbot_casadi.control.balance_lqr`) and the velocity LQR
(:mod:`ballbot_casadi.control.velocity`) both solve the discrete Riccati equation of a
ZOH model (``control.dlqr``) and must refuse a gain whose closed loop is not stable;
this module is that one design step.
"""

from __future__ import annotations

import control
import numpy as np

from ballbot_casadi.errors import ParameterError

__all__ = ["stabilising_dlqr"]


def stabilising_dlqr(Ad: np.ndarray, Bd: np.ndarray, Qw: np.ndarray, Rw: np.ndarray,
                     none: str) -> np.ndarray:
    """Discrete LQR gain ``K`` (``u = -K x``) of ``x+ = Ad x + Bd u`` with diagonal weights.

    Parameters
    ----------
    Ad, Bd
        Discrete model (n x n, n x m).
    Qw, Rw
        Diagonal state (n) and input (m) weights.
    none
        The start of the error message when no stabilising gain exists, naming the loop.

    Raises
    ------
    ParameterError
        The Riccati equation has no stabilising solution, or the closed loop
        ``Ad - Bd K`` has spectral radius >= 1 (the message starts with ``none``).
    """
    try:
        K, _, _ = control.dlqr(Ad, Bd, np.diag(Qw), np.diag(Rw), method="scipy")
    except (np.linalg.LinAlgError, ValueError, ArithmeticError) as exc:
        raise ParameterError(f"{none} ({exc})") from None
    K = np.asarray(K, dtype=float)
    rho = np.max(np.abs(np.linalg.eigvals(Ad - Bd @ K))) if np.all(np.isfinite(K)) else np.inf
    if not rho < 1.0:
        raise ParameterError(f"{none}: the closed loop has spectral radius {rho:.9g} >= 1")
    return K
