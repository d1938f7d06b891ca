"""Super-twisting balance controller: the implicit law, a scalar system, the 5/5 deg test."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import (
    BALANCE_DIAG_NAMES,
    default_balance_gains,
    make_smc,
    saturate_torques,
)
from ballbot_casadi.control.super_twisting import (
    STA_DEFAULT_GAINS,
    STA_GAIN_NAMES,
    levant_gains,
    make_sta_step,
    make_super_twisting,
    moreno_osorio_time_bound,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import THESIS_LIMITS, TS_CONTROL
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.numeric import make_state

STEP = make_sta_step(1)


def test_interface_and_gain_rule(model_functions):
    st = make_super_twisting(model_functions["affine"])
    assert st.name() == "ballbot_sta"
    assert st.name_in() == ["x", "q_ref", "dq_ref", "ddq_ref", "p", "k", "zb"]
    assert st.name_out() == ["tau", "diag", "zb_next"]
    assert st.numel_in(5) == len(STA_GAIN_NAMES) and st.numel_in(6) == st.numel_out(2) == 3
    assert st.numel_out(1) == len(BALANCE_DIAG_NAMES)
    k1, k2 = levant_gains([4.0, 1.0])
    np.testing.assert_allclose(k1, [3.0, 1.5], rtol=0, atol=1e-15)
    np.testing.assert_allclose(k2, [4.4, 1.1], rtol=0, atol=1e-15)
    assert STA_DEFAULT_GAINS[-1] == TS_CONTROL
    with pytest.raises(ScenarioError, match="must be finite and > 0"):
        levant_gains([1.0, 0.0])


@pytest.mark.parametrize("s, z", [(0.3, 0.0), (-0.3, 2.0), (1e-6, 0.0), (-2e-5, 1e-3),
                                  (0.0, 0.0), (5.0, -3.0)])
def test_implicit_step_solves_the_implicit_equations(s, z):
    """S+ = S + h(-k1 |S+|^1/2 xi + z+), z+ = z - h k2 xi, xi in Sgn(S+)."""
    k1, k2, h = 1.8, 1.6, 0.005
    s1, z1, w = (float(v) for v in STEP(s, z, k1, k2, h))
    if s1 != 0.0:
        xi = np.sign(s1)
        assert xi == np.sign(s + h * z)
    else:
        xi = (s + h * z) / (h**2 * k2)
        assert abs(xi) <= 1.0
    assert z1 == pytest.approx(z - h * k2 * xi, rel=0, abs=1e-15)
    assert s1 == pytest.approx(s + h * (-k1 * np.sqrt(abs(s1)) * xi + z1), rel=0, abs=1e-14)
    assert w == pytest.approx((s1 - s) / h, rel=1e-12, abs=1e-14)


def _scalar_run(s0, L, h, T, delta=lambda t: 0.0):
    """ds/dt = w + delta(t), w held over each step, the implicit law in the loop."""
    k1, k2 = (float(v[0]) for v in levant_gains([L]))
    n = int(round(T / h))
    t = np.arange(n + 1) * h
    s, z = np.empty(n + 1), np.empty(n + 1)
    s[0], z[0] = s0, 0.0
    for i in range(n):
        _, z[i + 1], w = (float(v) for v in STEP(s[i], z[i], k1, k2, h))
        # exact integral of delta over the step (midpoint rule is exact enough at h = 1e-3)
        s[i + 1] = s[i] + h * w + h * delta(t[i] + h / 2)
    return t, s, z, k1, k2


def test_scalar_finite_time_convergence_within_the_moreno_osorio_bound():
    """Unperturbed: S reaches exactly zero before the Lyapunov bound and stays there."""
    t, s, z, k1, k2 = _scalar_run(1.0, 1.5, 1e-3, 8.0)
    bound = moreno_osorio_time_bound(1.0, 0.0, k1, k2)
    reached = np.nonzero(np.abs(s) <= 1e-12)[0]  # zero up to rounding of s + h (-s / h)
    t_reach = t[reached[0]]
    assert t_reach <= bound  # measured 1.42 s against a bound of 11.0 s
    assert bound < 10 * t_reach  # the bound is not vacuous
    assert np.abs(s[reached[0]:]).max() <= 1e-12 and np.abs(z[reached[0] + 1:]).max() <= 1e-9


def test_scalar_rejects_a_lipschitz_perturbation():
    """|d delta/dt| <= L: z tracks -delta (the integral term compensates the perturbation);
    S is left at the implicit discretisation's residual h |delta| (module docstring)."""
    L, h = 1.5, 1e-3
    delta = lambda t: 0.4 + (L / 2) * np.sin(2 * t)  # noqa: E731  |d delta| = L cos <= L
    t, s, z, _, _ = _scalar_run(0.5, L, h, 12.0, delta)
    late = t > 6.0
    assert np.abs(s[late]).max() <= 1.05 * h * np.abs(delta(t[late])).max()
    assert np.abs(z[late] + delta(t[late] - h / 2)).max() <= 0.005  # measured 1.5e-3


def _balance_run(ctrl, k, stateful, model_functions, params, n=400):
    step = make_rk4_n(model_functions["ode"], 5)
    p = params.to_vector()
    up, z4 = np.array([1.0, 0, 0, 0]), np.zeros(4)
    x, zb = make_state(roll=np.radians(5), pitch=np.radians(5)), np.zeros(3)
    S, U, W = [], [], []
    for _ in range(n):
        if stateful:
            tau, d, zb = ctrl(x, up, z4, z4, p, k, zb)
            zb = np.asarray(zb).ravel()
        else:
            tau, d = ctrl(x, up, z4, z4, p, k)
        d = np.asarray(d).ravel()
        S.append(d[6:9] + k[:3] * d[3:6])
        W.append(2 * Q.vee(Q.mul(Q.conj(x[2:6]), x[8:12])))  # body rate
        U.append(saturate_torques(np.asarray(tau).ravel(), params.tau_max))
        x = np.asarray(step(x, U[-1], p, TS_CONTROL)).ravel()
    return np.array(S), np.array(U), np.array(W), x


def test_five_five_degree_tilt_converges_on_the_manifold(model_functions, default_params):
    """Thesis §8.2 initial tilt 5/5 deg: |S| <= 1e-3 within 1 s and after; TV <= SMC's;
    the tilt rate within the §7.1 limit."""
    st = make_super_twisting(model_functions["affine"])
    S, U, W, x = _balance_run(st, STA_DEFAULT_GAINS, True, model_functions, default_params)
    t = np.arange(len(S)) * TS_CONTROL
    assert np.abs(S[t >= 1.0]).max() <= 1e-3  # measured 1e-8 (settles at 0.85 s)
    tilt_rate = np.linalg.norm(W[:, :2], axis=1).max()
    assert tilt_rate <= THESIS_LIMITS["tilt_rate_max"]  # measured 17.4 deg/s
    assert np.abs(U).max() <= default_params.tau_max + 1e-12
    assert np.abs(np.degrees(Q.to_rpy(x[2:6]))).max() < 0.01
    smc = make_smc(model_functions["affine"])
    _, U_smc, _, _ = _balance_run(smc, default_balance_gains("smc"), False, model_functions,
                                  default_params)
    tv, tv_smc = np.abs(np.diff(U, axis=0)).sum(), np.abs(np.diff(U_smc, axis=0)).sum()
    assert tv <= tv_smc  # measured 6.4 vs 7.6 N m
