"""Every reference generator's first and second derivatives against central finite
differences of its own value (an independent reference: a wrong scale, sign or window of
a derivative shows), for positive and negative amplitudes."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.sim import references as R

H = 1e-5


def _fd(gen, t):
    """Central differences of the value of ``gen(t)`` (first and second)."""
    p, m, c = gen(t + H).value, gen(t - H).value, gen(t).value
    return (p - m) / (2 * H), (p - 2 * c + m) / H**2


# sample times away from the corners where a derivative jumps (t_step, t_step + rise, ...)
T = np.linspace(0.013, 2.987, 211)


@pytest.mark.parametrize("name,gen", [
    ("step", lambda t: R.step(t, 0.7, 0.5, 1.3, offset=0.2)),
    ("step_neg", lambda t: R.step(t, -2.5, 0.3, 0.6)),
    ("ramp", lambda t: R.ramp(t, 1.2, 0.4, 0.9)),
    ("ramp_neg", lambda t: R.ramp(t, -1.2, 0.4, 0.9, offset=0.1)),
    ("sine", lambda t: R.sine(t, -0.4, 1.7, 0.3, offset=0.05)),
    ("chirp", lambda t: R.chirp(t, 0.3, 0.2, 2.0, 2.5)),
])
def test_derivatives_match_finite_differences(name, gen):
    s = gen(T)
    d1, d2 = _fd(gen, T)
    smooth = np.ones(T.size, bool)
    if name.startswith("ramp"):   # the corners at t_start and t_start + |A| / rate
        amp = 1.2
        for corner in (0.4, 0.4 + amp / 0.9):
            smooth &= np.abs(T - corner) > 2 * H
        np.testing.assert_allclose(s.d1[smooth], d1[smooth], rtol=0, atol=1e-6)
        assert np.all(s.d2 == 0.0)
        # the slope acts exactly while the value moves
        moving = (T > 0.4) & (T < 0.4 + amp / 0.9)
        assert np.all(np.abs(s.d1[moving]) == 0.9) and np.all(s.d1[~moving & smooth] == 0.0)
        return
    scale = max(1.0, float(np.max(np.abs(s.d2))))
    np.testing.assert_allclose(s.d1, d1, rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(s.d2, d2, rtol=0, atol=2e-3 * scale)


def test_velocity_profile_rate_is_the_derivative_of_its_value():
    kf = ((0.2, 0.3, -0.2, 0.5, 1.0), (1.5, -0.1, 0.25, -0.4, 0.5))
    t = np.linspace(0.0, 3.0, 3001)
    s = R.velocity_profile(t, kf)
    d = np.gradient(s.value, t, axis=0)
    inner = np.ones(t.size, bool)
    # away from the ramps' corners
    for ts, *_ in kf:
        inner &= np.abs(t - ts) > 2e-3
    ends = np.nonzero(np.any(np.abs(np.diff(s.d1, axis=0)) > 1e-9, axis=1))[0]
    for k in ends:
        inner[max(k - 2, 0):k + 3] = False
    np.testing.assert_allclose(s.d1[inner], d[inner], rtol=0, atol=1e-9)
    # and the ramps respect the translational limit as a vector norm
    assert np.max(np.hypot(s.d1[:, 0], s.d1[:, 1])) <= 1.0 + 1e-12
