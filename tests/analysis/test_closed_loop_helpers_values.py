"""Closed-loop analysis helpers against closed forms: the -3 dB and sensitivity bandwidths
(interpolated crossings, a loss at the first grid point, the low-frequency normalisation),
the discrete frequency response and the ZOH of a scalar system, the second-order bandwidth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis import closed_loop as cla


def test_bandwidths_of_a_scaled_first_order_lag():
    w = np.logspace(-2, 2, 4001)
    H = 2.5 / (1j * w + 1.0)  # DC gain 2.5: both bandwidths normalise by it
    assert cla.bandwidth_3db(w, np.abs(H)) == pytest.approx(1.0, rel=2e-3)
    assert cla.bandwidth_sensitivity(w, H) == pytest.approx(1.0, rel=2e-3)
    grid = np.array([0.5, 1.0, 2.0])
    assert cla.bandwidth_sensitivity(grid, np.array([1.0, 1.0, 1.0])) is None  # S = 0 throughout
    assert cla.bandwidth_3db(grid, np.ones(3)) is None


def test_interpolated_crossings_by_hand():
    grid = np.array([1.0, 10.0, 100.0])
    # dB: 0, -1, -5.0206: crosses -3.0103 halfway (in log-frequency) between 10 and 100
    mag = 10 ** (np.array([0.0, -1.0, -5.0206]) / 20)
    assert cla.bandwidth_3db(grid, mag) == pytest.approx(10 ** 1.5, rel=1e-9)
    # dB: 0, -6.0206: crosses halfway between 1 and 10
    mag = 10 ** (np.array([0.0, -6.0206, -9.0]) / 20)
    assert cla.bandwidth_3db(grid, mag) == pytest.approx(10 ** 0.5, rel=1e-9)
    # sensitivity |1 - H|: 0 at 1, 0.5 at 10, 1.0 at 100 (log-interpolated between 10 and 100)
    frac = (math.log10(1 / math.sqrt(2)) - math.log10(0.5)) / (0.0 - math.log10(0.5))
    got = cla.bandwidth_sensitivity(grid, np.array([1.0, 0.5, 0.0]))
    assert got == pytest.approx(10 ** (1.0 + frac), rel=1e-9)


def test_first_point_loss_returns_the_first_frequency():
    # |T| 3 dB down at the first point relative to itself cannot happen; at the second:
    assert cla.bandwidth_3db(np.array([0.7, 7.0]), np.array([1.0, 0.1])) < 7.0
    # the sensitivity uses H / |H[0]|: -1 at the first point gives S = 2 there
    assert cla.bandwidth_sensitivity(np.array([0.7, 7.0]), np.array([-3.0, 1.0])) == 0.7


def test_zoh_and_discrete_response_of_a_scalar_lag():
    a, b, Ts = -2.0, 3.0, 0.1
    Ad, Bd = cla.zoh(np.array([[a]]), np.array([[b]]), Ts)
    assert Ad[0, 0] == pytest.approx(math.exp(a * Ts), rel=1e-12)
    assert Bd[0, 0] == pytest.approx(b * (math.exp(a * Ts) - 1) / a, rel=1e-12)
    w = np.array([0.0, 5.0])
    G = cla.dfreq(Ad, Bd, np.array([[1.0]]), w, Ts)
    z = np.exp(1j * w * Ts)
    np.testing.assert_allclose(G[:, 0, 0], Bd[0, 0] / (z - Ad[0, 0]), rtol=1e-12)
    assert G[0, 0, 0].real == pytest.approx(-b / a, rel=1e-12)  # the DC gain survives the ZOH


@pytest.mark.parametrize("kp,kd", [(100.0, 20.0), (400.0, 10.0), (50.0, 30.0)])
def test_second_order_bandwidth_solves_the_half_power_equation(kp, kd):
    w = cla._second_order_bw(kp, kd)
    T = kp / (-(w**2) + 1j * kd * w + kp)
    assert abs(T) ** 2 == pytest.approx(0.5, rel=1e-12)


def test_discrete_stability_counts_neutral_modes():
    Ad = np.diag([1.0, 1.0 + 1e-9, 0.5, -0.8])
    d = cla._discrete_stability(Ad, 0.01)
    assert d["n_neutral_modes"] == 2
    assert d["max_real_pole"] == pytest.approx(math.log(0.8) / 0.01, rel=1e-12)
    assert d["stable_apart_from_neutral"]
    d = cla._discrete_stability(np.diag([1.0, 1.2]), 0.01)
    assert not d["stable_apart_from_neutral"]
    assert d["max_real_pole"] == pytest.approx(math.log(1.2) / 0.01, rel=1e-12)


def test_a_response_that_only_touches_minus_3_db_has_no_bandwidth():
    """The bandwidth is where |T| falls 3 dB below: a grid point exactly at db[0] - 3.0103
    followed by a rise is no loss (None); followed by a fall, the crossing is that point."""
    m1 = 0.1  # exactly -20 dB
    target = 20 * np.log10(m1)
    m0 = 10 ** ((target + 3.0103) / 20)
    for _ in range(64):  # the nearest float whose dB value lies exactly 3.0103 above (this libm)
        d = 20 * np.log10(m0) - 3.0103 - target
        if d == 0:
            break
        m0 = np.nextafter(m0, -np.inf if d > 0 else np.inf)
    assert 20 * np.log10(m0) - 3.0103 == target
    grid = np.array([1.0, 10.0, 100.0])
    assert cla.bandwidth_3db(grid, np.array([m0, m1, 0.5])) is None
    assert cla.bandwidth_3db(grid, np.array([m0, m1, 0.01])) == pytest.approx(10.0, rel=1e-12)


def test_a_crossing_towards_an_exact_zero_interpolates_in_magnitude():
    """A grid point where |T| (or the tracking error) is exactly 0 has no logarithm: the
    crossing is interpolated linearly in magnitude (log-frequency still) on that segment,
    never towards an arbitrary floor and never NaN."""
    grid = np.array([1.0, 10.0, 100.0])
    level = 10 ** (-3.0103 / 20)
    frac = (0.9 - level) / 0.9  # |T|: 1, 0.9, 0 -> falls through 0.7071 on the second segment
    assert cla.bandwidth_3db(grid, np.array([1.0, 0.9, 0.0])) == pytest.approx(10 ** (1 + frac), rel=1e-12)
    assert cla.bandwidth_3db(grid, np.array([0.0, 0.5, 0.0])) is None  # no low-frequency value
    # tracking error |1 - H|: 0, 0, 1 -> rises through 1/sqrt(2) at 0.7071 of the second segment
    got = cla.bandwidth_sensitivity(grid, np.array([1.0, 1.0, 0.0]))
    assert got == pytest.approx(10 ** (1 + 1 / math.sqrt(2)), rel=1e-12)
