"""Reference generators: analytic derivatives, limits, quaternion references."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.sim.references import (
    FIG93_ACCEL,
    FIG93_KEYFRAMES,
    SPEC,
    _qmul,
    chirp,
    rpy_reference,
    sine,
    step,
    velocity_profile,
)

H = 1e-5


def _check_derivatives(fun, t, atol1=1e-6, atol2=1e-4):
    """First/second derivatives of a generator against central differences."""
    s = fun(t)
    sp, sm = fun(t + H), fun(t - H)
    np.testing.assert_allclose(s.d1, (sp.value - sm.value) / (2 * H), rtol=1e-6, atol=atol1)
    np.testing.assert_allclose(s.d2, (sp.d1 - sm.d1) / (2 * H), rtol=1e-6, atol=atol2)


def test_sine_derivatives():
    t = np.linspace(0, 3, 301)
    _check_derivatives(lambda s: sine(s, 0.05, 0.5, phase=0.3, offset=0.1), t)
    np.testing.assert_allclose(sine(np.array([0.5]), 2.0, 0.5).value, [2.0], atol=1e-15)


def test_smoothed_step_derivatives_and_ends():
    t = np.linspace(-0.5, 2.5, 301) + 1e-3  # avoid the kinks at the ramp ends
    _check_derivatives(lambda s: step(s, 0.3, t_step=0.5, rise_time=1.0), t, atol2=1e-3)
    s = step(np.array([0.0, 0.5, 1.5, 3.0]), 0.3, t_step=0.5, rise_time=1.0, offset=1.0)
    np.testing.assert_allclose(s.value, [1.0, 1.0, 1.3, 1.3], atol=1e-15)
    ideal = step(np.array([0.9, 1.0, 1.1]), 2.0, t_step=1.0)
    np.testing.assert_array_equal(ideal.value, [0.0, 2.0, 2.0])
    np.testing.assert_array_equal(ideal.d1, 0.0)


def test_chirp_derivatives_and_frequency():
    t = np.linspace(0.01, 12, 1201)
    _check_derivatives(lambda s: chirp(s, 0.05, 0.05, 1.05, 10.0), t, atol2=1e-3)
    # instantaneous frequency = dphi/dt / 2 pi: the envelope of d1/amplitude
    s = chirp(np.array([5.0]), 1.0, 0.05, 1.05, 10.0)
    f_inst = 0.05 + 0.1 * 5.0
    assert np.hypot(s.d1[0] / (2 * np.pi * f_inst), s.value[0]) == pytest.approx(1.0, rel=1e-12)
    with pytest.raises(ScenarioError, match="duration"):
        chirp(t, 1.0, 0.1, 1.0, 0.0)


def test_velocity_profile_respects_the_specification():
    t = np.arange(0, 20, 0.001)
    s = velocity_profile(t)
    speed = np.hypot(s.value[:, 0], s.value[:, 1])
    assert speed.max() <= SPEC["v_max"] + 1e-12
    assert np.abs(s.value[:, 2]).max() <= SPEC["yaw_rate_max"] + 1e-12
    assert np.hypot(s.d1[:, 0], s.d1[:, 1]).max() <= SPEC["a_max"] + 1e-12
    assert np.abs(s.d1[:, 2]).max() <= SPEC["yaw_acc_max"] + 1e-12
    # piecewise linear: the value is the integral of d1
    integral = np.cumsum(s.d1, axis=0) * 0.001
    np.testing.assert_allclose(integral, s.value, atol=2e-3)
    np.testing.assert_allclose(s.value[-1], FIG93_KEYFRAMES[-1][1:4], atol=1e-12)
    assert np.hypot(s.d1[:, 0], s.d1[:, 1]).max() == pytest.approx(FIG93_ACCEL, rel=1e-12)


@pytest.mark.parametrize(
    "keyframes, match",
    [
        ([(0.0, 0.6, 0.0, 0.0)], "exceeds"),
        ([(0.0, 0.0, 0.0, 1.5)], "exceeds"),
        ([(1.0, 0.5, 0.0, 0.0), (1.2, 0.0, 0.0, 0.0)], "before the previous ramp"),
        ([(1.0, np.nan, 0.0, 0.0)], "NaN"),
        ([(1.0, 0.3, 0.0, 0.0, 1.5)], "ramp acceleration"),
    ],
)
def test_velocity_profile_rejects_bad_keyframes(keyframes, match):
    with pytest.raises(ScenarioError, match=match):
        velocity_profile(np.linspace(0, 5, 11), keyframes)


def test_bad_time_and_shapes():
    with pytest.raises(ShapeError):
        sine(np.zeros((2, 2)), 1.0, 1.0)
    with pytest.raises(ScenarioError):
        sine(np.array([0.0, np.nan]), 1.0, 1.0)
    with pytest.raises(ShapeError):
        velocity_profile(np.zeros(3), [(0.0, 0.1)])
    with pytest.raises(ScenarioError, match="a_max"):
        velocity_profile(np.zeros(3), a_max=2.0)


def test_rpy_reference_matches_from_rpy_and_derivatives():
    t = np.linspace(0.01, 3.9, 390)  # inside the chirp (its frequency has kinks at 0 and 4 s)

    def make(s):
        return rpy_reference(sine(s, 0.3, 0.5), chirp(s, 0.2, 0.1, 1.0, 4.0), sine(s, 1.0, 0.2, 0.4))

    q, dq, ddq = make(t)
    roll, pitch, yaw = sine(t, 0.3, 0.5).value, chirp(t, 0.2, 0.1, 1.0, 4.0).value, sine(t, 1.0, 0.2, 0.4).value
    for i in range(0, t.size, 50):
        np.testing.assert_allclose(q[i], Q.from_rpy(roll[i], pitch[i], yaw[i]), atol=1e-15)
    qp, dqp, _ = make(t + H)
    qm, dqm, _ = make(t - H)
    np.testing.assert_allclose(dq, (qp - qm) / (2 * H), atol=1e-8)
    np.testing.assert_allclose(ddq, (dqp - dqm) / (2 * H), atol=1e-7)
    # unit norm is preserved along the trajectory: q . dq = 0
    np.testing.assert_allclose(np.einsum("ij,ij->i", q, dq), 0.0, atol=1e-14)


def test_rpy_reference_constant_angles():
    q, dq, ddq = rpy_reference(0.1, -0.2, 0.3)
    assert q.shape == (1, 4)
    np.testing.assert_allclose(q[0], Q.from_rpy(0.1, -0.2, 0.3), atol=1e-15)
    np.testing.assert_array_equal(dq, 0.0)
    np.testing.assert_array_equal(ddq, 0.0)
    with pytest.raises(ShapeError):
        rpy_reference((np.zeros(3), np.zeros(3)), 0.0, 0.0)


@pytest.mark.parametrize("f0, f1, duration, refused", [
    (0.1, 1.0, 0.0, True), (0.1, 1.0, -1.0, True), (-0.1, 1.0, 5.0, True), (0.1, -1.0, 5.0, True),
    (-0.1, -1.0, 5.0, True), (0.0, 0.0, 5.0, False), (0.1, 1.0, 1e-9, False)])
def test_chirp_refuses_each_bad_argument_alone(f0, f1, duration, refused):
    """duration > 0 and both frequencies >= 0, each condition refused on its own, with the
    values read back."""
    t = np.linspace(0, 1, 5)
    if refused:
        with pytest.raises(ScenarioError, match=rf"chirp needs duration > 0 and frequencies >= 0, got "
                                                rf"duration={duration}, f0={f0}, f1={f1}$"):
            chirp(t, 1.0, f0, f1, duration)
    else:
        assert np.all(np.isfinite(chirp(t, 1.0, f0, f1, duration).value))


def test_the_row_wise_product_is_the_hamilton_product():
    """``_qmul`` (rows of quaternions) against :func:`ballbot_casadi.core.quaternion.mul` on
    general quaternions, every component non-zero (rpy_reference only multiplies
    elementary rotations, whose zeros hide some terms)."""
    rng = np.random.default_rng(23)
    a, b = rng.normal(size=(6, 4)), rng.normal(size=(6, 4))
    want = np.array([np.asarray(Q.mul(x, y), float).ravel() for x, y in zip(a, b)])
    np.testing.assert_allclose(_qmul(a, b), want, rtol=1e-13, atol=1e-14)
    assert not np.allclose(_qmul(a, b), _qmul(b, a))      # not commutative
