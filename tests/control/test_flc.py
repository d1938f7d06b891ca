"""Feedback-linearising balance controller (thesis ch. 8)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.control import (
    BALANCE_CONTROLLERS,
    BALANCE_DIAG_NAMES,
    balance_state_size,
    check_gains,
    controller_functions_list,
    default_balance_gains,
    make_balance_controller,
    make_flc,
    saturate_torques,
)
from ballbot_casadi.control.quaternion_error import (
    quaternion_error,
    quaternion_error_accel,
    quaternion_error_rate,
    shortest_path_sign,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ArgumentError, BallbotTypeError
from ballbot_casadi.model.integrators import make_rk4_n
from ballbot_casadi.model.linearization import linearize
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.sim.references import rpy_reference, sine

TS = 0.005  # controller period (200 Hz ZOH), plant RK4 at 1 ms


@pytest.fixture(scope="module")
def flc(model_functions):
    return make_flc(model_functions["affine"])


def _random_case(rng):
    x = make_state(
        x=rng.normal(), y=rng.normal(), roll=rng.uniform(-0.4, 0.4), pitch=rng.uniform(-0.4, 0.4),
        yaw=rng.uniform(-3, 3), dx=rng.normal(0, 0.3), dy=rng.normal(0, 0.3),
        omega_body=rng.normal(0, 0.5, 3),
    )
    q_ref = Q.from_rpy(*rng.uniform(-0.3, 0.3, 2), Q.to_rpy(x[2:6])[2] + rng.uniform(-1, 1))
    dq_ref = 0.5 * Q.mul(q_ref, Q.hat(rng.normal(0, 0.5, 3)))
    ddq_ref = rng.normal(0, 0.3, 4)
    return x, q_ref, dq_ref, ddq_ref


def _error_accel(model_functions, p, x, tau, q_ref, dq_ref, ddq_ref):
    f, g = model_functions["affine"](x, p)
    ddq = (np.asarray(f).ravel() + np.asarray(g) @ np.asarray(tau).ravel())[2:6]
    q, dq = x[2:6], x[8:12]
    s = shortest_path_sign(quaternion_error(q, q_ref))
    return s * quaternion_error_accel(q, dq, ddq, q_ref, dq_ref, ddq_ref)[1:]


def test_interface(flc):
    assert flc.name() == "ballbot_flc"
    assert flc.name_in() == ["x", "q_ref", "dq_ref", "ddq_ref", "p", "k"]
    assert flc.name_out() == ["tau", "diag"]
    assert flc.size1_out(1) == len(BALANCE_DIAG_NAMES) and BALANCE_DIAG_NAMES[0] == "singular"
    assert set(BALANCE_CONTROLLERS) == {"flc", "smc", "sta", "lqr", "flc_dob"}


def test_output_dynamics_are_exactly_the_designed_linear_ones(flc, model_functions, default_params, rng):
    """u = E^-1 (v - D) applied to the model gives ddy = v (thesis 8.11, 8.45)."""
    p = default_params.to_vector()
    k = default_balance_gains("flc")
    for _ in range(20):
        x, q_ref, dq_ref, ddq_ref = _random_case(rng)
        tau, diag = flc(x, q_ref, dq_ref, ddq_ref, p, k)
        diag = np.asarray(diag).ravel()
        s = shortest_path_sign(quaternion_error(x[2:6], q_ref))
        e = s * quaternion_error(x[2:6], q_ref)[1:]
        de = s * quaternion_error_rate(x[2:6], x[8:12], q_ref, dq_ref)[1:]
        v = -k[:3] * e - k[3:] * de  # (8.44) on the error output
        np.testing.assert_allclose(diag[3:6], e, atol=1e-14)
        np.testing.assert_allclose(diag[6:9], de, atol=1e-14)
        np.testing.assert_allclose(diag[9:12], v, atol=1e-12)
        assert diag[0] == 0.0
        ddy = _error_accel(model_functions, p, x, tau, q_ref, dq_ref, ddq_ref)
        np.testing.assert_allclose(ddy, v, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", ["flc", "smc", "sta", "lqr", "flc_dob"])
def test_every_balance_controller_has_the_common_frame(name, model_functions, default_params, rng):
    """One signature for all five (control.balance_frame), and ``diag`` means the same in
    each: ``y``, ``dy`` the independent error output, ``v`` the error acceleration that
    ``tau`` produces in the model (thesis 8.12-8.26; zero ``zb``: no disturbance estimate)."""
    f = make_balance_controller(name, model_functions["affine"])
    nz = balance_state_size(name)
    assert f.name() == f"ballbot_{name}"
    assert f.name_in() == ["x", "q_ref", "dq_ref", "ddq_ref", "p", "k", *(["zb"] if nz else [])]
    assert f.name_out() == ["tau", "diag", *(["zb_next"] if nz else [])]
    assert f.size_out(0) == (3, 1) and f.size1_out(1) == len(BALANCE_DIAG_NAMES)
    if nz:
        assert f.size1_in(6) == nz and f.size1_out(2) == nz
    p = default_params.to_vector()
    linear = linearize(default_params, functions=model_functions)
    k = default_balance_gains(name, linear)
    for _ in range(5):
        x, q_ref, dq_ref, ddq_ref = _random_case(rng)
        tau, diag, *_ = f(x, q_ref, dq_ref, ddq_ref, p, k, *([np.zeros(nz)] if nz else []))
        diag = np.asarray(diag).ravel()
        s = shortest_path_sign(quaternion_error(x[2:6], q_ref))
        assert diag[2] == s and diag[0] == 0.0
        np.testing.assert_allclose(diag[3:6], s * quaternion_error(x[2:6], q_ref)[1:],
                                   rtol=0, atol=1e-14)
        np.testing.assert_allclose(
            diag[6:9], s * quaternion_error_rate(x[2:6], x[8:12], q_ref, dq_ref)[1:],
            rtol=0, atol=1e-14)
        ddy = _error_accel(model_functions, p, x, tau, q_ref, dq_ref, ddq_ref)
        np.testing.assert_allclose(ddy, diag[9:12], rtol=0, atol=1e-9)


def test_axes_are_decoupled(flc, model_functions, default_params, rng):
    """Changing the gains of one axis changes only that axis' output acceleration."""
    p = default_params.to_vector()
    x, q_ref, dq_ref, ddq_ref = _random_case(rng)
    k = default_balance_gains("flc")
    base = _error_accel(model_functions, p, x, flc(x, q_ref, dq_ref, ddq_ref, p, k)[0], q_ref, dq_ref, ddq_ref)
    for axis in range(3):
        k2 = k.copy()
        k2[axis] *= 3.0
        k2[axis + 3] *= 2.0
        tau = flc(x, q_ref, dq_ref, ddq_ref, p, k2)[0]
        acc = _error_accel(model_functions, p, x, tau, q_ref, dq_ref, ddq_ref)
        others = [i for i in range(3) if i != axis]
        np.testing.assert_allclose(acc[others], base[others], atol=1e-9)
        assert abs(acc[axis] - base[axis]) > 1e-6


def test_shortest_path_sign_gives_identical_torque(flc, default_params, rng):
    """q_ref and -q_ref are the same attitude: same torque, the sign is reported."""
    p = default_params.to_vector()
    k = default_balance_gains("flc")
    x, q_ref, dq_ref, ddq_ref = _random_case(rng)
    t1, d1 = flc(x, q_ref, dq_ref, ddq_ref, p, k)
    t2, d2 = flc(x, -q_ref, -dq_ref, -ddq_ref, p, k)
    np.testing.assert_allclose(np.asarray(t1), np.asarray(t2), atol=1e-10)
    assert float(d1[2]) == -float(d2[2])


@pytest.mark.parametrize("angle_deg", [180.0, 179.99, 176.0, 170.0])
def test_near_singular_decoupling_matrix_is_damped_and_reported(flc, default_params, angle_deg):
    """A ~180 deg error makes E(x) (nearly) singular: finite torque, flag set."""
    p = default_params.to_vector()
    k = default_balance_gains("flc")
    x = make_state(roll=0.05, omega_body=(0.1, 0.0, 0.0))
    q_ref = Q.from_rotation_vector(np.array([0.0, 0.0, np.radians(angle_deg)]))
    tau, diag = flc(x, Q.mul(x[2:6], q_ref), np.zeros(4), np.zeros(4), p, k)
    tau, diag = np.asarray(tau).ravel(), np.asarray(diag).ravel()
    assert np.all(np.isfinite(tau)) and np.all(np.isfinite(diag))
    assert np.abs(tau).max() < 500
    assert diag[0] == (1.0 if angle_deg > 174.3 else 0.0)
    assert (diag[1] < 1) == (diag[0] == 1.0)


def test_large_tilt_is_flagged_without_nan(flc, default_params):
    """Beyond ~95 deg tilt the torque -> acceleration map degrades: damped, reported."""
    p = default_params.to_vector()
    k = default_balance_gains("flc")
    for tilt, flagged in ((30.0, 0.0), (110.0, 1.0)):
        x = make_state(roll=np.radians(tilt))
        tau, diag = flc(x, np.array([1.0, 0, 0, 0]), np.zeros(4), np.zeros(4), p, k)
        assert np.all(np.isfinite(np.asarray(tau)))
        assert float(diag[0]) == flagged


def test_near_singular_solution_is_continuous(flc, default_params):
    """The damping rises continuously: no jump in torque across the threshold (174.3 deg)."""
    p = default_params.to_vector()
    k = default_balance_gains("flc")
    x = make_state(roll=0.05)
    taus = []
    for a in np.linspace(173.0, 176.0, 301):
        q_ref = Q.mul(x[2:6], Q.from_rotation_vector(np.array([0.0, 0.0, np.radians(a)])))
        taus.append(np.asarray(flc(x, q_ref, np.zeros(4), np.zeros(4), p, k)[0]).ravel())
    taus = np.array(taus)
    assert np.all(np.isfinite(taus))
    assert np.abs(np.diff(taus, axis=0)).max() < 0.01 * np.abs(taus).max()


def _closed_loop(model_functions, ctrl, k, x0, T, refs, p_plant, p_ctrl, tau_max):
    step = make_rk4_n(model_functions["ode"], 5)
    n = int(round(T / TS))
    x = np.array(x0, dtype=float)
    X, U = [x], []
    for i in range(n):
        q_ref, dq_ref, ddq_ref = refs(i * TS)
        tau = np.asarray(ctrl(x, q_ref, dq_ref, ddq_ref, p_ctrl, k)[0]).ravel()
        tau = saturate_torques(tau, tau_max)
        x = np.asarray(step(x, tau, p_plant, TS)).ravel()
        X.append(x)
        U.append(tau)
    return np.array(X), np.array(U)


def _upright_ref(t):
    return np.array([1.0, 0, 0, 0]), np.zeros(4), np.zeros(4)


def test_zero_reference_converges_from_5_deg(flc, model_functions, default_params):
    """Thesis §8.2.3: roll = pitch = 5 deg -> upright, steady-state error < 0.01 deg."""
    p = default_params.to_vector()
    X, U = _closed_loop(model_functions, flc, default_balance_gains("flc"),
                        make_state(roll=np.radians(5), pitch=np.radians(5)), 3.0,
                        _upright_ref, p, p, default_params.tau_max)
    rpy = np.degrees([Q.to_rpy(x[2:6]) for x in X[-40:]])
    assert np.abs(rpy).max() < 0.01
    assert np.all(np.isfinite(U))


def test_sine_roll_tracking_is_decoupled(flc, model_functions, default_params):
    """Thesis §8.2.5: roll sine 3 deg 0.5 Hz; pitch/yaw stay < 0.01 deg, roll lag < 0.02 s."""
    p = default_params.to_vector()

    def refs(t):
        q, dq, ddq = rpy_reference(sine(t, np.radians(3), 0.5), 0.0, 0.0)
        return q[0], dq[0], ddq[0]

    X, U = _closed_loop(model_functions, flc, default_balance_gains("flc"), make_state(), 3.0,
                        refs, p, p, default_params.tau_max)
    t = np.arange(len(X)) * TS
    rpy = np.degrees([Q.to_rpy(x[2:6]) for x in X])
    ref = np.degrees(np.radians(3) * np.sin(np.pi * t))
    assert np.abs(rpy[:, 1:]).max() < 0.01
    late = t > 1.0
    lags = np.arange(-0.02, 0.0201, 0.001)
    cost = [np.abs(np.interp(t[late] - L, t, ref) - rpy[late, 0]).max() for L in lags]
    assert abs(lags[int(np.argmin(cost))]) <= 0.02
    assert np.abs(rpy[late, 0] - ref[late]).max() < 0.05
    assert np.abs(np.diff(U, axis=0)).max() < 0.2  # smooth torques, no chattering


def test_robust_to_mass_and_inertia_error(flc, model_functions, default_params):
    """Thesis §8.4.1: plant mass +10 %, inertias x3.2, controller on the nominal model."""
    P = default_params
    plant = P.replace(Mb=1.1 * P.Mb, Jbx=3.2 * P.Jbx, Jby=3.2 * P.Jby, Jbz=3.2 * P.Jbz)
    X, _ = _closed_loop(model_functions, flc, default_balance_gains("flc"),
                        make_state(roll=np.radians(5), pitch=np.radians(-5)), 4.0,
                        _upright_ref, plant.to_vector(), P.to_vector(), P.tau_max)
    rpy = np.degrees([Q.to_rpy(x[2:6]) for x in X[-40:]])
    assert np.abs(rpy).max() < 0.05


def test_bad_inputs_raise_clear_errors(model_functions):
    with pytest.raises(ArgumentError, match="allowed: flc, flc_dob, lqr, smc, sta"):
        default_balance_gains("pid")
    with pytest.raises(ArgumentError, match="allowed"):
        make_balance_controller("pid", model_functions["affine"])
    with pytest.raises(ArgumentError, match="finite"):
        check_gains("flc", [1.0, np.nan, 1, 1, 1, 1])
    with pytest.raises(ArgumentError, match="6 entries"):
        check_gains("flc", [1.0, 2.0])
    np.testing.assert_array_equal(check_gains("flc", default_balance_gains("flc")),
                                  default_balance_gains("flc"))
    with pytest.raises(BallbotTypeError, match="affine"):
        make_flc(model_functions["ode"])


def test_controllers_generate_strict_c(model_functions, default_params, tmp_path, rng):
    from ballbot_casadi.core.toolchain import build_library, load_library

    funcs = controller_functions_list(model_functions["affine"])
    names = ("flc", "smc", "sta", "lqr", "flc_dob")
    assert [f.name() for f in funcs] == [*(f"ballbot_{n}" for n in names), "ballbot_velocity"]
    lib = build_library("ballbot_control_test", funcs, root=tmp_path)
    ext = load_library(lib, [f"ballbot_{n}" for n in names])
    p = default_params.to_vector()
    x, q_ref, dq_ref, ddq_ref = _random_case(rng)
    linear = linearize(default_params, functions=model_functions)
    for name, f in zip(names, funcs):
        k = default_balance_gains(name, linear)
        zb = 0.01 * np.arange(1, f.numel_in(6) + 1) if f.n_in() == 7 else None  # a state of its own
        args = (x, q_ref, dq_ref, ddq_ref, p, k, *([zb] if f.n_in() == 7 else []))
        for a, b in zip(f(*args), ext[f.name()](*args)):
            np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-12, atol=1e-12)
    assert isinstance(ext["ballbot_flc"], ca.Function)
    # the model stays a called Function (one copy of the dynamics in the C code)
    assert "ballbot_affine" in lib.source.read_text()
