"""The Moreno-Osorio reaching-time bound of the super-twisting algorithm against an
independent reference: the Lyapunov equation ``A^T P + P A = -I`` solved as a Kronecker
linear system (not scipy's solver), on asymmetric ``(s0, z0, k1, k2)`` so that a flipped
sign, a swapped gain or a swapped eigenvalue shows."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control.super_twisting import moreno_osorio_time_bound


def _bound_by_hand(s0: float, z0: float, k1: float, k2: float) -> float:
    A = np.array([[-k1 / 2, 0.5], [-k2, 0.0]])
    eye = np.eye(2)
    # vec(A^T P) = (I kron A^T) vec P, vec(P A) = (A^T kron I) vec P (column-major vec)
    M = np.kron(eye, A.T) + np.kron(A.T, eye)
    P = np.linalg.solve(M, -eye.reshape(-1, order="F")).reshape(2, 2, order="F")
    lam_min, lam_max = np.linalg.eigvalsh(P)
    zeta = np.array([np.sign(s0) * abs(s0) ** 0.5, z0])
    return 2.0 * np.sqrt(zeta @ P @ zeta) * lam_max / np.sqrt(lam_min)


@pytest.mark.parametrize("s0, z0, k1, k2", [(4.0, 0.7, 3.0, 2.0), (-4.0, 0.7, 3.0, 2.0),
                                            (0.25, -1.3, 1.8, 1.65), (-9.0, 0.0, 2.5, 5.0),
                                            (0.0, 2.0, 3.0, 2.0)])
def test_bound_equals_the_kronecker_lyapunov_reference(s0, z0, k1, k2):
    assert moreno_osorio_time_bound(s0, z0, k1, k2) == pytest.approx(
        _bound_by_hand(s0, z0, k1, k2), rel=1e-12, abs=0)


def test_bound_sees_the_sign_of_s_and_scales_with_the_initial_state():
    # P has a cross term: s0 and z0 of the same sign and of opposite signs give different bounds
    same, opposite = (moreno_osorio_time_bound(s, 0.7, 3.0, 2.0) for s in (4.0, -4.0))
    assert same != pytest.approx(opposite, rel=1e-3)
    # zeta scales as sqrt(|s0|) and z0: V^(1/2) and so the bound are homogeneous of degree 1
    base = moreno_osorio_time_bound(1.0, 0.5, 3.0, 2.0)
    assert moreno_osorio_time_bound(4.0, 1.0, 3.0, 2.0) == pytest.approx(2.0 * base, rel=1e-12)
    assert moreno_osorio_time_bound(0.0, 0.0, 3.0, 2.0) == 0.0
