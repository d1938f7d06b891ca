"""The shared discrete LQR design: optimal gain on a scalar case, refusal naming the loop."""

import numpy as np
import pytest

from ballbot_casadi.control.dlqr import stabilising_dlqr
from ballbot_casadi.errors import ParameterError


def test_scalar_gain_matches_the_closed_form_riccati_solution():
    # x+ = a x + b u, cost q x^2 + r u^2: P = q + a^2 P - (a b P)^2 / (r + b^2 P)
    a, b, q, r = 1.2, 0.5, 2.0, 0.3
    c2, c1, c0 = b**2, r - r * a**2 - q * b**2, -q * r    # b^2 P^2 + (r - a^2 r - q b^2) P - q r = 0
    P = (-c1 + np.sqrt(c1**2 - 4 * c2 * c0)) / (2 * c2)
    K = stabilising_dlqr(np.array([[a]]), np.array([[b]]), np.array([q]), np.array([r]), "loop")
    np.testing.assert_allclose(K, [[a * b * P / (r + b**2 * P)]], rtol=1e-10, atol=0)
    assert abs(a - b * K[0, 0]) < 1.0


def test_unstabilisable_model_is_refused_naming_the_loop():
    # an unstable mode the input cannot reach
    Ad = np.diag([1.5, 0.5])
    Bd = np.array([[0.0], [1.0]])
    with pytest.raises(ParameterError, match=r"^no gain for the test loop"):
        stabilising_dlqr(Ad, Bd, np.ones(2), np.ones(1), "no gain for the test loop")


@pytest.mark.parametrize("pole", [1.0, -1.0])
def test_a_marginally_stable_closed_loop_is_refused(pole):
    # a mode on the unit circle that the input cannot reach and the cost does not weigh:
    # the Riccati solution exists, the closed loop keeps the pole (spectral radius exactly 1)
    Ad = np.diag([pole, 0.5])
    Bd = np.array([[0.0], [1.0]])
    with pytest.raises(ParameterError, match=r"^marginal loop: the closed loop has spectral radius 1 >= 1"):
        stabilising_dlqr(Ad, Bd, np.array([0.0, 1.0]), np.ones(1), "marginal loop")
