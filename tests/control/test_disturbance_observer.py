"""The FLC with a disturbance observer ("flc_dob", thesis ch. 11 future work): the
estimate converges to a known constant wheel-torque disturbance and removes the static
error the FLC alone keeps."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control import (
    default_balance_gains,
    make_balance_controller,
    saturate_torques,
)
from ballbot_casadi.control.disturbance_observer import DOB_GAIN_NAMES, DOB_NZ, DOB_STATE
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import GENERALISED, STATE
from ballbot_casadi.core.params import Params, load_params
from ballbot_casadi.model.dynamics import make_affine, make_ode
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.sim.scenario import initial_state
from ballbot_casadi.sim.scenario.file import parse_scenario

TS = 0.005
TAU_D = np.array([0.3, -0.2, 0.1])  # N m on the wheel axes, constant from t = 0


@pytest.fixture(scope="module")
def loops() -> dict[str, dict[str, np.ndarray]]:
    """An independent loop: each controller Function with its state carried by hand, the
    direction-preserving limit, the plant's saturation, a constant wheel-torque
    disturbance added after it, RK4; the upright reference, 2.5 s from a 2/-1 deg tilt."""
    p = load_params().to_vector()
    tau_max = Params.from_vector(p).tau_max
    rk4 = make_rk4_n(make_ode(), 4)
    affine = make_affine()
    q_ref, zero = np.array([1.0, 0, 0, 0]), np.zeros(4)
    out = {}
    for name in ("flc", "flc_dob"):
        ctrl = make_balance_controller(name, affine)
        k = default_balance_gains(name, Ts=TS)
        x, zb = np.array(initial_state(2.0, -1.0)), np.zeros(DOB_NZ)
        taus, zbs, xs = [], [], []
        for _ in range(500):
            args = (x, q_ref, zero, zero, p, k)
            if name == "flc_dob":
                tau, _, zb = (np.asarray(v).ravel() for v in ctrl(*args, zb))
            else:
                tau, _ = (np.asarray(v).ravel() for v in ctrl(*args))
            u = np.clip(saturate_torques(tau, tau_max), -tau_max, tau_max) + TAU_D
            x = np.asarray(rk4(x, u, p, TS)).ravel()
            taus.append(tau), zbs.append(zb.copy()), xs.append(x)
        out[name] = {"tau": np.array(taus), "zb": np.array(zbs), "x": np.array(xs)}
    return out


def _body_acceleration_map() -> ca.Function:
    """``G(x)``: torque -> body angular acceleration, ``2 vec(q* o g_q)``, from the model's
    affine form directly (body rate omega = 2 vec(q* o dq))."""
    x = ca.MX.sym("x", STATE.size)
    _, g = make_affine()(x, load_params().to_vector())
    q = x[STATE["q"]]
    cols = [2 * Q.vee(Q.mul(Q.conj(q), g[GENERALISED["q"], j])) for j in range(3)]
    return ca.Function("G", [x], [ca.horzcat(*cols)])


def _tilt_deg(x: np.ndarray) -> np.ndarray:
    return np.degrees(np.abs(np.array([Q.to_rpy(q) for q in x[:, STATE["q"]]])))


def test_estimate_converges_to_the_constant_torque_disturbance(loops):
    r = loops["flc_dob"]
    G = _body_acceleration_map()
    # at rest and upright the only torque balancing the disturbance is -tau_d itself
    np.testing.assert_allclose(r["tau"][-1], -TAU_D, rtol=0, atol=1e-5)  # measured ~1e-6
    assert np.abs(_tilt_deg(r["x"][-1:])).max() < 1e-3  # measured 1.5e-4 deg (yaw)
    # the estimate is G tau_d, the body acceleration the disturbance causes
    x_last = r["x"][-2]
    d_hat = r["zb"][-1][DOB_STATE["d_hat"]]
    np.testing.assert_allclose(d_hat, np.asarray(G(x_last)).reshape(3, 3) @ TAU_D, rtol=1e-4)
    assert np.abs(d_hat).min() > 1e-2
    # first-order convergence at the observer bandwidth: the error of the estimate
    # against the true lumped disturbance G(x) tau_d decays as (1 - L h)^k
    k = default_balance_gains("flc_dob", Ts=TS)
    L = k[[DOB_GAIN_NAMES.index(f"L{i}") for i in (1, 2, 3)]]
    err = np.array([zb[DOB_STATE["d_hat"]] - np.asarray(G(x)).reshape(3, 3) @ TAU_D
                    for zb, x in zip(r["zb"], np.vstack([initial_state(2.0, -1.0), r["x"][:-1]]))])
    np.testing.assert_allclose(err[0], -np.asarray(G(initial_state(2.0, -1.0))).reshape(3, 3) @ TAU_D,
                               rtol=1e-12)  # the arming period estimates nothing
    for n in (1, 2):  # periods after the first estimate (later the state's motion adds)
        np.testing.assert_allclose(err[1 + n], (1 - L * TS) ** n * err[1], rtol=0.05)
    # after 0.1 s only the Euler prediction error of the moving state is left (measured 0.4 %)
    assert np.all(np.abs(err[20]) < 1e-2 * np.abs(err[1]).max())
    assert r["zb"][-1][DOB_STATE["armed"]] == 1.0


def test_flc_alone_keeps_a_static_error_the_observer_removes(loops):
    flc = _tilt_deg(loops["flc"]["x"][-1:])[0]
    dob = _tilt_deg(loops["flc_dob"]["x"][-1:])[0]
    assert flc[:2].max() > 0.1 and flc[2] > 1.0  # the FLC's y = delta / K_p (yaw several deg)
    assert dob.max() < 1e-3 * flc.max()


def test_power_on_is_bumpless():
    """The zero power-on state arms the predictor first: the first torque is the FLC's."""
    p = load_params().to_vector()
    affine = make_affine()
    x = np.array(initial_state(3.0, -2.0, 10.0))
    x[STATE["dq"]] = Q.mul(x[STATE["q"]], np.array([0.0, 0.2, -0.1, 0.3])) / 2  # moving
    args = (x, np.array([1.0, 0, 0, 0]), np.zeros(4), np.zeros(4), p)
    flc = make_balance_controller("flc", affine)(*args, default_balance_gains("flc"))[0]
    dob = make_balance_controller("flc_dob", affine)(*args, default_balance_gains("flc_dob"),
                                                      np.zeros(DOB_NZ))[0]
    np.testing.assert_allclose(np.asarray(dob), np.asarray(flc), rtol=0, atol=1e-12)


def test_scenario_file_selects_flc_dob_and_its_step_is_the_period():
    sc = parse_scenario({"name": "t", "controller": "flc_dob", "duration_s": 0.1,
                         "control_period_s": 0.004}).scenario
    k = sc.inputs()["k_bal"]
    assert sc.controller == "flc_dob" and k.size == len(DOB_GAIN_NAMES)
    assert k[DOB_GAIN_NAMES.index("h")] == 0.004
    np.testing.assert_array_equal(k[:6], default_balance_gains("flc")[:6])
