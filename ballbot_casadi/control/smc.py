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

from ballbot_casadi.control.balance_frame import BalanceFrame, balance_controller
from ballbot_casadi.control.decoupling import DampedInverse

__all__ = ["make_smc", "SMC_GAIN_NAMES", "SMC_DEFAULT_GAINS"]

SMC_GAIN_NAMES = ("K1", "K2", "K3", "eta1", "eta2", "eta3", "eps1", "eps2", "eps3")
#: Defaults of the predecessor V2019 (thesis §8.3).
SMC_DEFAULT_GAINS = np.array([15.0, 15.0, 6.0, 6.0, 6.0, 3.0, 0.5, 0.5, 0.2])


def make_smc(affine: ca.Function, inverse: DampedInverse = DampedInverse()) -> ca.Function:
    """Build ``ballbot_smc``, the sliding-mode balance controller (thesis §8.3, V2019 baseline).

    ``affine``, ``inverse``, the signature and ``diag``: as in
    :func:`~ballbot_casadi.control.balance_frame.balance_controller`; ``k`` as
    :data:`SMC_GAIN_NAMES`; ``tau`` unsaturated.
    """

    def sliding_law(b: BalanceFrame) -> tuple[ca.MX, ca.MX]:
        K, eta, eps = b.k[0:3], b.k[3:6], b.k[6:9]
        S = b.o["dy"] + K * b.o["y"]  # sliding surface in the body frame
        sat = ca.fmin(ca.fmax(S / eps, -1), 1)
        v = -K * b.o["dy"] - eta * sat  # equivalent control + continuous switching
        return b.linearising_torque(v)  # (8.26)

    return balance_controller("smc", affine, len(SMC_GAIN_NAMES), sliding_law, inverse=inverse)
