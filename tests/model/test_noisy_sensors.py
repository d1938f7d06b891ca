"""Realistic sensor models (thesis §3.1): IMU with lever arm, bias, noise; encoders."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import trapezoid

from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import NS, load_sensor_params
from ballbot_casadi.core.toolchain import build_library, load_library
from ballbot_casadi.errors import BallbotTypeError
from ballbot_casadi.model.integrators import make_rk4
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.model.sensors import (
    NOISE_STREAMS,
    encoder_count,
    make_encoder_model,
    make_encoders,
    make_gyro_bias_step,
    make_imu,
    make_sensors,
    make_specific_force,
    make_wheel_angle_ode,
)

P = load_params()
PV = P.to_vector()
S0 = load_sensor_params()
Z3 = np.zeros(3)


@pytest.fixture(scope="module")
def fns(model_functions):
    f = model_functions
    return {
        "ode": f["ode"],
        "wheel_speeds": f["wheel_speeds"],
        "imu": make_imu(f["ode"]),
        "sf": make_specific_force(f["ode"]),
        "sens": make_sensors(f["ode"]),
        "bias": make_gyro_bias_step(),
        "enc": make_encoders(),
    }


def _imu(fns, x, tau=Z3, s=S0, b=Z3, n_acc=Z3, n_gyro=Z3, p=PV):
    acc, gyro = fns["imu"](x, tau, p, s.to_vector(), b, n_acc, n_gyro)
    return np.asarray(acc).ravel(), np.asarray(gyro).ravel()


def _random_states(n, seed=11):
    g = np.random.default_rng(seed)
    for _ in range(n):
        yield (make_state(roll=0.2 * g.normal(), pitch=0.2 * g.normal(), yaw=g.normal(),
                          dx=g.normal(), dy=g.normal(), omega_body=g.normal(size=3)),
               g.normal(size=3))


def test_noise_free_limit_equals_make_sensors(fns, model_functions):
    r = np.array([0.05, -0.02, 0.3])
    sens_r = make_sensors(model_functions["ode"], imu_position=r)
    s_r = S0.replace(imu_position=r)
    for x, tau in _random_states(6):
        acc, gyro = _imu(fns, x, tau)
        acc0, gyro0, _ = fns["sens"](x, tau, PV)
        np.testing.assert_array_equal(acc, np.asarray(acc0).ravel())  # same expression at r = 0
        np.testing.assert_array_equal(gyro, np.asarray(gyro0).ravel())
        acc_r, _ = _imu(fns, x, tau, s=s_r)
        acc0_r, _, _ = sens_r(x, tau, PV)  # lever arm by differentiating R(q) r there
        np.testing.assert_allclose(acc_r, np.asarray(acc0_r).ravel(), rtol=0, atol=1e-12)


@pytest.mark.parametrize("r", [(0, 0, 0), (0.1, -0.2, 0.5), (-0.3, 0.0, -0.1)])
def test_at_rest_upright_reads_plus_g_wherever_the_imu_is(fns, r):
    x = make_state(yaw=0.9)
    acc, gyro = _imu(fns, x, s=S0.replace(imu_position=r), b=np.array([1e-3, -2e-3, 3e-3]))
    np.testing.assert_allclose(acc, [0, 0, P.g], rtol=0, atol=1e-12)
    np.testing.assert_allclose(gyro, [1e-3, -2e-3, 3e-3], rtol=0, atol=1e-15)  # only the bias


def test_spinning_upright_with_offset_imu_reads_centripetal_acceleration(fns):
    """Yaw spin at w about the vertical: f = g e_z - w^2 (r_x, r_y, 0) in the body frame."""
    w, r = 2.0, np.array([0.12, -0.07, 0.4])
    x = make_state(yaw=0.4, omega_body=(0.0, 0.0, w))
    xdot = np.asarray(fns["ode"](x, Z3, PV)).ravel()
    assert np.allclose(xdot[6:8], 0, atol=1e-15)  # the spin is a steady motion
    acc, gyro = _imu(fns, x, s=S0.replace(imu_position=r))
    np.testing.assert_allclose(acc, [-w**2 * r[0], -w**2 * r[1], P.g], rtol=0, atol=1e-12)
    np.testing.assert_allclose(gyro, [0, 0, w], rtol=0, atol=1e-14)


def test_lever_arm_matches_finite_difference_of_imu_position(fns):
    """General motion: R(q) f - g e_z = second time derivative of the IMU position."""
    r = np.array([0.05, -0.02, 0.3])
    x0 = make_state(roll=0.08, pitch=0.03, dx=0.1, omega_body=(0.2, -0.1, 0.3))
    tau = np.array([0.3, -0.2, 0.1])
    step = make_rk4(fns["ode"])

    def flow(x, t, n=10):
        for _ in range(n):
            x = np.asarray(step(x, tau, PV, t / n)).ravel()
        return x

    def pos(x):
        return np.array([x[0], x[1], 0.0]) + Q.rotate(x[2:6], r)

    dt = 1e-3
    a_fd = (pos(flow(x0, dt)) - 2 * pos(x0) + pos(flow(x0, -dt))) / dt**2
    f, _ = fns["sf"](x0, tau, PV, r)
    R = Q.rotation_matrix(x0[2:6])
    np.testing.assert_allclose(R @ np.asarray(f).ravel(), a_fd + [0, 0, P.g], rtol=0, atol=1e-5)


def test_scale_bias_misalignment_and_noise_enter_as_in_thesis(fns):
    x, tau = next(_random_states(1, seed=3))
    f, omega = (np.asarray(v).ravel() for v in fns["sf"](x, tau, PV, Z3))
    th = math.radians(2.0)
    Rm = np.array([[math.cos(th), -math.sin(th), 0], [math.sin(th), math.cos(th), 0], [0, 0, 1]])
    s = S0.replace(acc_scale=[1.02, 0.97, 1.0], acc_bias=[0.1, -0.05, 0.2],
                   gyro_scale=[0.99, 1.0, 1.03], imu_misalignment=[0, 0, "2 deg"],
                   acc_noise_var=[4e-4, 1e-4, 9e-4], gyro_noise_var=[1e-4, 4e-4, 2.5e-5])
    b = np.array([0.01, 0.0, -0.02])
    n_acc, n_gyro = np.array([1.0, -2.0, 0.5]), np.array([0.3, 1.0, -1.0])
    acc, gyro = _imu(fns, x, tau, s=s, b=b, n_acc=n_acc, n_gyro=n_gyro)
    # (3.3): K R_{B->IMU} f + b + sqrt(Sigma) n, R_{B->IMU} = Rz(2 deg)^T
    expected_acc = np.array([1.02, 0.97, 1.0]) * (Rm.T @ f) + [0.1, -0.05, 0.2] \
        + np.sqrt([4e-4, 1e-4, 9e-4]) * n_acc
    expected_gyro = (np.array([0.99, 1.0, 1.03]) * (Rm.T @ omega) + b
                     + np.sqrt([1e-4, 4e-4, 2.5e-5]) * n_gyro)
    np.testing.assert_allclose(acc, expected_acc, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(gyro, expected_gyro, rtol=1e-14, atol=1e-14)


def test_imu_noise_covariance_is_the_thesis_covariance(fns):
    """Standard normals from the Philox stream through ballbot_imu: Cov = diag (3.4), (3.8)."""
    n = 20_000
    noise = NoiseStream(5)
    x = make_state(roll=0.05, omega_body=(0.1, 0.2, -0.3))
    imu_n = fns["imu"].map(n)
    acc, gyro = imu_n(x, Z3, PV, S0.to_vector(), Z3, noise.normal(NOISE_STREAMS["acc"], n, 3).T,
                      noise.normal(NOISE_STREAMS["gyro"], n, 3).T)
    acc0, gyro0 = _imu(fns, x)
    for meas, mean, var in ((acc, acc0, S0.acc_noise_var), (gyro, gyro0, S0.gyro_noise_var)):
        m = np.asarray(meas).T
        tol = 4.5 * math.sqrt(2 / n)
        np.testing.assert_allclose(np.var(m, axis=0) / var, 1.0, rtol=0, atol=tol)
        np.testing.assert_allclose((m.mean(axis=0) - mean) / np.sqrt(var), 0,
                                   atol=4.5 / math.sqrt(n))
        corr = np.corrcoef(m.T)[np.triu_indices(3, 1)]
        assert np.all(np.abs(corr) < 4.5 / math.sqrt(n))  # diagonal covariance


def test_gyro_bias_random_walk_variance_grows_as_sigma2_t(fns):
    m, n_steps, Ts = 4000, 200, 0.005
    sigma = np.array([2e-5, 5e-5, 1e-4])
    s = S0.replace(gyro_bias_rw=sigma).to_vector()
    noise = NoiseStream(77)
    step = fns["bias"].map(m)
    b0 = np.array([0.01, -0.02, 0.0])
    b = np.tile(b0[:, None], (1, m))
    var = {}
    for k in range(1, n_steps + 1):
        n_rw = noise.normal(NOISE_STREAMS["gyro_bias_rw"], m, 3, start=(k - 1) * m).T
        b = np.asarray(step(b, s, Ts, n_rw))
        if k in (50, 100, 200):
            var[k] = (b - b0[:, None]).var(axis=1), (b - b0[:, None]).mean(axis=1)
    for k, (v, mean) in var.items():
        expected = sigma**2 * k * Ts
        np.testing.assert_allclose(v / expected, 1.0, rtol=0, atol=4.5 * math.sqrt(2 / m))
        np.testing.assert_allclose(mean / np.sqrt(expected), 0, atol=4.5 / math.sqrt(m))
    # one step is exactly b + sqrt(Ts) sigma n
    nn = np.array([1.0, -1.0, 2.0])
    np.testing.assert_allclose(np.asarray(fns["bias"](b0, s, Ts, nn)).ravel(),
                               b0 + math.sqrt(Ts) * sigma * nn, rtol=1e-15, atol=0)


def test_encoder_round_is_thesis_half_away_from_zero(fns):
    p = load_params(n_ticks=2 * math.pi).to_vector()  # n_ticks / (2 pi) = 1: count = round(phi)
    enc, dticks = fns["enc"]([2.5, -2.5, 0.49], Z3, p, 0.01)
    np.testing.assert_array_equal(np.asarray(dticks).ravel(), [3, -3, 0])  # (3.13); floor: 2, -3
    np.testing.assert_allclose(np.asarray(enc).ravel(), [300, -300, 0], rtol=1e-15)
    np.testing.assert_array_equal(encoder_count(np.array([0.5, -0.5, 1.49999]), 2 * math.pi),
                                  [1, -1, 1])


def test_encoder_counts_are_integers_bounded_and_do_not_drift(fns):
    g = np.random.default_rng(2)
    Ts = 0.005
    phi = np.cumsum(g.normal(scale=2e-3, size=(400, 3)), axis=0) + g.uniform(-5, 5, size=3)
    enc_n = fns["enc"].map(399)
    enc, dticks = (np.asarray(v).T for v in enc_n(phi[1:].T, phi[:-1].T, PV, Ts))
    np.testing.assert_array_equal(dticks, np.round(dticks))  # whole ticks
    np.testing.assert_allclose(enc * Ts, np.round(enc * Ts), rtol=0, atol=1e-9)
    c = P.n_ticks / (2 * math.pi)
    assert np.max(np.abs(dticks - c * np.diff(phi, axis=0))) <= 1.0  # (3.16)
    ref = np.sign(c * phi) * np.floor(np.abs(c * phi) + 0.5)  # independent (3.11), (3.13)
    np.testing.assert_array_equal(dticks, np.diff(ref, axis=0))
    np.testing.assert_array_equal(dticks.sum(axis=0), ref[-1] - ref[0])  # no accumulated drift


def test_wheel_angle_ode_and_encoders_along_a_trajectory(fns):
    f = make_wheel_angle_ode(fns["ode"], fns["wheel_speeds"])
    x = make_state(roll=0.04, pitch=-0.03, dx=0.2, omega_body=(0.1, -0.1, 0.5))
    xw = np.concatenate([x, [0.1, -0.2, 0.3]])
    xwdot = np.asarray(f(xw, Z3, PV)).ravel()
    np.testing.assert_array_equal(xwdot[:12], np.asarray(fns["ode"](x, Z3, PV)).ravel())
    np.testing.assert_array_equal(xwdot[12:], np.asarray(fns["wheel_speeds"](x, PV)).ravel())
    # integrate 0.2 s at 1 ms, read the encoders every 5 ms
    step = make_rk4(f)
    Ts, tau = 0.005, np.array([0.2, -0.1, 0.05])
    phis, rates = [xw[12:]], []
    for k in range(200):
        rates.append(np.asarray(fns["sens"](xw[:12], tau, PV)[2]).ravel())
        xw = np.asarray(step(xw, tau, PV, 1e-3)).ravel()
        if (k + 1) % 5 == 0:
            phis.append(xw[12:])
    phis = np.array(phis)
    _, dticks = fns["enc"].map(len(phis) - 1)(phis[1:].T, phis[:-1].T, PV, Ts)
    total = np.asarray(dticks).sum(axis=1)
    # the counts integrate the noise-free encoder rate (ticks/s) to within one tick
    expected = trapezoid(np.vstack([rates, np.asarray(fns["sens"](xw[:12], tau, PV)[2]).T]),
                        dx=1e-3, axis=0)
    assert np.all(np.abs(total - expected) <= 1.0 + 1e-3)
    assert np.all(np.abs(total) > 10)  # the wheels did turn


def test_encoder_model_is_thesis_3_15(fns):
    m = make_encoder_model(fns["wheel_speeds"])
    x = make_state(dx=0.3, omega_body=(0.0, 0.1, 0.2))
    n = np.array([1.0, -3.0, 0.0])
    z = np.asarray(m(x, PV, S0.to_vector(), 0.005, n)).ravel()
    dphi = np.asarray(fns["wheel_speeds"](x, PV)).ravel()
    np.testing.assert_allclose(z, P.n_ticks / (2 * math.pi) * 0.005 * dphi + n / 3,
                               rtol=1e-14, atol=1e-12)


def test_function_names_and_io(fns, model_functions):
    imu = fns["imu"]
    assert imu.name() == "ballbot_imu"
    assert imu.name_in() == ["x", "tau", "p", "s", "bias_gyro", "n_acc", "n_gyro"]
    assert [imu.size1_in(i) for i in range(7)] == [12, 3, len(PV), NS, 3, 3, 3]
    assert imu.name_out() == ["acc", "gyro"]
    assert fns["enc"].name_in() == ["phi", "phi_prev", "p", "Ts"]
    assert fns["enc"].name_out() == ["enc", "dticks"]
    assert fns["bias"].name_in() == ["bias_gyro", "s", "Ts", "n_rw"]
    # the ODE and the specific-force block stay called Functions inside the IMU model
    assert {"ballbot_ode", "ballbot_specific_force"} <= {g.name() for g in imu.find_functions()}
    wa = make_wheel_angle_ode(model_functions["ode"], model_functions["wheel_speeds"])
    assert {"ballbot_ode", "ballbot_wheel_speeds"} <= {g.name() for g in wa.find_functions()}
    assert len(set(NOISE_STREAMS.values())) == len(NOISE_STREAMS)


def test_bad_arguments(model_functions):
    f = model_functions
    with pytest.raises(BallbotTypeError):
        make_imu(f["energy"])
    with pytest.raises(BallbotTypeError):
        make_wheel_angle_ode(f["ode"], f["ode"])
    with pytest.raises(BallbotTypeError):
        make_encoder_model(f["energy"])


@pytest.mark.needs_cc
def test_compiled_sensors_equal_python(fns, tmp_path):
    """The sensor Functions compile with the strict flags; C gives the Python numbers."""
    funcs = [fns["imu"], fns["bias"], fns["enc"]]
    lib = build_library("sensors_noisy_test", funcs, root=tmp_path)
    ext = load_library(lib, [g.name() for g in funcs])
    noise = NoiseStream(3)
    x, tau = next(_random_states(1, seed=5))
    s = S0.replace(imu_position=[0.0, 0.1, 0.4], imu_misalignment=[0.01, 0, -0.02]).to_vector()
    args = (x, tau, PV, s, [1e-3, 0, 0], *noise.normal(0, 2, 3))
    for a, b in zip(ext["ballbot_imu"](*args), fns["imu"](*args)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-13, atol=1e-13)
    e_args = ([0.3, -1.2, 7.0], [0.29, -1.1, 6.9], PV, 0.005)
    for a, b in zip(ext["ballbot_encoders"](*e_args), fns["enc"](*e_args)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    b_args = ([0.0, 1e-3, 0.0], s, 0.005, noise.normal(2, 1, 3).ravel())
    np.testing.assert_array_equal(np.asarray(ext["ballbot_gyro_bias_step"](*b_args)),
                                  np.asarray(fns["bias"](*b_args)))


def test_quantisation_error_statistics(fns):
    """Many ticks per sample: the count-change error is the difference of two independent
    U(-1/2, 1/2) rounding errors, variance 1/6 (the thesis' filters assume 1/9, (3.17))."""
    g = np.random.default_rng(4)
    n = 50_000
    phi_prev = g.uniform(-10, 10, size=(3, n))
    dphi = g.normal(scale=0.01, size=(3, n))
    _, dticks = fns["enc"].map(n)(phi_prev + dphi, phi_prev, PV, 0.005)
    err = np.asarray(dticks) - P.n_ticks / (2 * math.pi) * dphi
    assert np.max(np.abs(err)) <= 1.0
    # triangular on [-1, 1]: fourth moment 1/15, so Var(sample variance) = (1/15 - 1/36) / n
    np.testing.assert_allclose(err.var(axis=1), 1 / 6, rtol=0,
                               atol=4.5 * math.sqrt((1 / 15 - 1 / 36) / n))
    np.testing.assert_allclose(err.mean(axis=1), 0, atol=4.5 * math.sqrt(1 / 6 / n))
