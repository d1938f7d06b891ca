"""Kinematics (thesis App. B): wheel map, inverse and forward kinematics."""

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.model import kinematics as K
from ballbot_casadi.model.numeric import make_state


def test_W_tilde_matches_B46(default_params):
    P = default_params
    a, g, k = P.alpha, P.gamma, P.rk / P.rw
    expected = k * np.array([
        [0, -np.cos(a), 0, np.sin(a)],
        [0, -np.cos(g) * np.cos(a), -np.sin(g) * np.cos(a), np.sin(a)],
        [0, -np.cos(2 * g) * np.cos(a), -np.sin(2 * g) * np.cos(a), np.sin(a)],
    ])
    np.testing.assert_allclose(K.W_tilde(P), expected, atol=1e-15)
    # Each row is (1/rw) (p_Ci x d_i) from the contact point (B.30) and wheel direction (B.32).
    for i, pc in enumerate(K.contact_points(P)):
        d = np.array([-np.sin(i * g), np.cos(i * g), 0.0])
        np.testing.assert_allclose(K.W_tilde(P)[i, 1:], np.cross(pc, d) / P.rw, atol=1e-15)


def test_wheel_speeds_match_reference(kugle_reference, model_functions):
    from ballbot_casadi import load_params

    rp = kugle_reference["params"]
    P = load_params(alpha=rp["alpha"], gamma=rp["gamma"], rk=rp["rk"], rw=rp["rw"])
    for rec in kugle_reference["records"]:
        dphi = np.array(model_functions["wheel_speeds"](rec["state"], P.to_vector())).ravel()
        np.testing.assert_allclose(dphi, rec["dpsi_InverseKinematics"], rtol=0, atol=1e-12,
                                   err_msg=rec["name"])


def test_body_rate_matches_reference(kugle_reference):
    for rec in kugle_reference["records"]:
        x = np.asarray(rec["state"])
        if not rec["on_manifold"]:
            continue
        np.testing.assert_allclose(K.body_angular_velocity(x[2:6], x[8:12]), rec["omega_body"],
                                   atol=1e-12)


def test_forward_inverse_roundtrip(default_params, rng):
    P = default_params
    for _ in range(20):
        x = make_state(roll=rng.uniform(-0.3, 0.3), pitch=rng.uniform(-0.3, 0.3),
                       yaw=rng.uniform(-3, 3), dx=rng.normal(), dy=rng.normal(),
                       omega_body=rng.normal(size=3))
        dphi = K.wheel_speeds(x[2:6], x[8:12], x[6], x[7], P)
        np.testing.assert_allclose(K.forward_kinematics(x[2:6], x[8:12], dphi, P), x[6:8],
                                   atol=1e-12)


def test_pure_yaw_spins_all_wheels_equally(default_params):
    x = make_state(yaw=0.7, omega_body=[0, 0, 1.3])
    dphi = K.wheel_speeds(x[2:6], x[8:12], 0.0, 0.0, default_params)
    # Body yawing at +w over a still ball: omega_{K'|B} = -w z, dphi_i = -w (rk/rw) sin(alpha).
    expected = -1.3 * default_params.rk / default_params.rw * np.sin(default_params.alpha)
    np.testing.assert_allclose(dphi, expected * np.ones(3), atol=1e-13)


def test_rolling_upright_B48(default_params):
    # Upright: dphi = W~ (1/rk) [0, -dy, dx, 0] (B.48)
    x = make_state(dx=0.3, dy=-0.2)
    dphi = K.wheel_speeds(x[2:6], x[8:12], x[6], x[7], default_params)
    expected = K.W_tilde(default_params) @ (np.array([0, 0.2, 0.3, 0]) / default_params.rk)
    np.testing.assert_allclose(dphi, expected, atol=1e-14)


def test_casadi_and_numpy_agree(default_params, rng):
    from ballbot_casadi.core.params import ParamView

    xs, ps = ca.SX.sym("x", 12), ca.SX.sym("p", 21)
    P = ParamView(ps)
    f = ca.Function("f", [xs, ps], [K.wheel_speeds(xs[2:6], xs[8:12], xs[6], xs[7], P),
                                   K.forward_kinematics(xs[2:6], xs[8:12], xs[9:12], P)])
    x = make_state(roll=0.1, pitch=-0.05, yaw=1.0, dx=0.2, dy=0.1, omega_body=[0.1, 0.2, 0.3])
    a, b = f(x, default_params.to_vector())
    np.testing.assert_allclose(np.array(a).ravel(),
                               K.wheel_speeds(x[2:6], x[8:12], x[6], x[7], default_params), atol=1e-14)
    np.testing.assert_allclose(np.array(b).ravel(),
                               K.forward_kinematics(x[2:6], x[8:12], x[9:12], default_params),
                               atol=1e-14)
    assert Q.norm(x[2:6]) == pytest.approx(1.0)
