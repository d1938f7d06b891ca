"""Sliding-mode balance controller, the predecessor's baseline (V2019, thesis §8.3).

``ballbot_smc(x, q_ref, dq_ref, ddq_ref, p, k) -> (tau, diag)``, same interface as
:func:`~ballbot_casadi.control.flc.make_flc`.

Control law
-----------
Sliding surface in the body frame, on the shortest-path error quaternion (thesis 7.4,
7.5, §7.4)::
    S = vec(dq_e) + K vec(q_e)

With ``ddy = D + E tau`` (the exact error-output dynamics of
:mod:`~ballbot_casadi.control.decoupling`, thesis 8.12-8.25) the equivalent
control makes ``dS = 0``; the continuous switching term (boundary layer of width
``epsilon`` instead of ``sign``, no chattering) drives ``S`` to zero::
    tau = E^-1 (v - D),   v = -K dy - eta sat(S / epsilon)

Inside the boundary layer ``dS = -(eta/epsilon) S``; on ``S = 0`` the error decays as
``dy = -K y``.  Gains ``k = [K1, K2, K3, eta1, eta2, eta3, eps1, eps2, eps3]``, default
``K = diag(15, 15, 6)``, ``eta = (6, 6, 3)``, ``epsilon = (0.5, 0.5, 0.2)`` (V2019).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.control.decoupling import DAMPING_MU, QE0_MIN, RCOND_MIN
from ballbot_casadi.control.flc import balance_controller

__all__ = ["make_smc", "SMC_GAIN_NAMES", "SMC_DEFAULT_GAINS"]

SMC_GAIN_NAMES = ("K1", "K2", "K3", "eta1", "eta2", "eta3", "eps1", "eps2", "eps3")
#: Defaults of the predecessor V2019 (thesis §8.3).
SMC_DEFAULT_GAINS = np.array([15.0, 15.0, 6.0, 6.0, 6.0, 3.0, 0.5, 0.5, 0.2])


def make_smc(
    affine: ca.Function,
    qe0_min: float = QE0_MIN,
    rcond_min: float = RCOND_MIN,
    mu: float = DAMPING_MU,
) -> ca.Function:
    """Build the sliding-mode balance controller (thesis §8.3, V2019 baseline).

    Parameters
    ----------
    affine
        The model Function ``affine(x, p) -> (f, g)``; it stays a called Function.
    qe0_min, rcond_min, mu
        Singularity thresholds and relative damping of the regularised inverse
        (:func:`~ballbot_casadi.control.decoupling.damped_solve`).

    Returns
    -------
    casadi.Function
        ``ballbot_smc(x[12], q_ref[4], dq_ref[4], ddq_ref[4], p[NP], k[9]) ->
        (tau[3], diag[12])``; same ``diag`` layout as the FLC.
    """

    def sliding_law(o: dict[str, ca.MX], k: ca.MX) -> ca.MX:
        K, eta, eps = k[0:3], k[3:6], k[6:9]
        S = o["dy"] + K * o["y"]  # sliding surface in the body frame
        sat = ca.fmin(ca.fmax(S / eps, -1), 1)
        return -K * o["dy"] - eta * sat  # equivalent control + continuous switching

    return balance_controller(
        "smc", affine, len(SMC_GAIN_NAMES), sliding_law, qe0_min, rcond_min, mu
    )
