"""Sliding-mode balance controller, the V2019 baseline (thesis §8.3)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control import (
    BALANCE_DIAG_NAMES,
    check_gains,
    default_balance_gains,
    make_balance_controller,
    make_smc,
    saturate_torques,
)
from ballbot_casadi.control.quaternion_error import (
    quaternion_error,
    quaternion_error_accel,
    quaternion_error_rate,
    shortest_path_sign,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ArgumentError
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.numeric import make_state


@pytest.fixture(scope="module")
def smc(model_functions):
    return make_smc(model_functions["affine"])


def test_interface_and_defaults(smc):
    assert smc.name() == "ballbot_smc"
    assert smc.name_in() == ["x", "q_ref", "dq_ref", "ddq_ref", "p", "k"]
    assert smc.name_out() == ["tau", "diag"]
    assert smc.size1_out(1) == len(BALANCE_DIAG_NAMES)
    np.testing.assert_array_equal(
        default_balance_gains("smc"), [15, 15, 6, 6, 6, 3, 0.5, 0.5, 0.2]
    )
    with pytest.raises(ArgumentError, match="9 entries"):
        check_gains("smc", default_balance_gains("flc"))
    with pytest.raises(ArgumentError, match="finite"):
        check_gains("smc", [15, 15, np.inf, 6, 6, 3, 0.5, 0.5, 0.2])


@pytest.mark.parametrize("scale", [0.05, 3.0])  # inside / outside the boundary layer
def test_sliding_variable_obeys_the_reaching_law(smc, model_functions, default_params, rng, scale):
    """dS/dt = -eta sat(S/eps) exactly, with S = vec(dq_e) + K vec(q_e) (body frame)."""
    p = default_params.to_vector()
    k = default_balance_gains("smc")
    K, eta, eps = k[:3], k[3:6], k[6:]
    for _ in range(5):
        x = make_state(roll=rng.uniform(-0.2, 0.2), pitch=rng.uniform(-0.2, 0.2),
                       yaw=rng.uniform(-1, 1), dx=rng.normal(0, 0.2),
                       omega_body=rng.normal(0, scale, 3))
        q_ref = Q.from_rpy(*rng.uniform(-0.1, 0.1, 3))
        dq_ref = 0.5 * Q.mul(q_ref, Q.hat(rng.normal(0, 0.3, 3)))
        ddq_ref = rng.normal(0, 0.2, 4)
        tau, diag = smc(x, q_ref, dq_ref, ddq_ref, p, k)
        f, g = model_functions["affine"](x, p)
        ddq = (np.asarray(f).ravel() + np.asarray(g) @ np.asarray(tau).ravel())[2:6]
        q, dq = x[2:6], x[8:12]
        s = shortest_path_sign(quaternion_error(q, q_ref))
        e = s * quaternion_error(q, q_ref)[1:]
        de = s * quaternion_error_rate(q, dq, q_ref, dq_ref)[1:]
        dde = s * quaternion_error_accel(q, dq, ddq, q_ref, dq_ref, ddq_ref)[1:]
        S = de + K * e
        dS = dde + K * de
        np.testing.assert_allclose(dS, -eta * np.clip(S / eps, -1, 1), rtol=0, atol=1e-9)
        assert float(diag[0]) == 0.0


def test_zero_reference_converges(model_functions, default_params):
    """Roll = pitch = 5 deg to upright with the V2019 gains (200 Hz ZOH, 1 ms RK4)."""
    smc = make_balance_controller("smc", model_functions["affine"])
    step = make_rk4_n(model_functions["ode"], 5)
    p = default_params.to_vector()
    k = default_balance_gains("smc")
    x = make_state(roll=np.radians(5), pitch=np.radians(5))
    up = np.array([1.0, 0, 0, 0])
    U = []
    for _ in range(600):
        tau = saturate_torques(np.asarray(smc(x, up, np.zeros(4), np.zeros(4), p, k)[0]).ravel(),
                               default_params.tau_max)
        x = np.asarray(step(x, tau, p, 0.005)).ravel()
        U.append(tau)
    assert np.abs(np.degrees(Q.to_rpy(x[2:6]))).max() < 0.01
    assert np.abs(np.diff(U, axis=0)[200:]).max() < 0.05  # continuous switching: no chattering
