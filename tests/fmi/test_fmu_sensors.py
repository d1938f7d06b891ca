"""The plant FMU's sampled sensors (accelerometer, gyroscope, encoders as the robot has them).

Oracle: :func:`ballbot_casadi.fmi.plant.oracle.plant_sensor_oracle`, a numpy RK4
run of the CasADi model Functions called from Python with NoiseStream noise (the FMU runs
the generated C of the same Functions and compiles the same Philox C file).  Measured:
bit-identical states and readings, noise on and off, for every step size tried; the
tests assert 1e-12 (states, IMU) and exact encoder readings.  Independent checks: the
sample-0 conventions, encoder counts against the quantised wheel angles, noise
statistics, the held values between samples, Model Exchange time events.
"""

from __future__ import annotations

import math
from ctypes import byref, c_double

import numpy as np
import pytest
from _fmu_support import ALL_STATES, NXW, SENSORS, X0_NAMES, Plant
from fmpy.fmi2 import fmi2EventInfo

from ballbot_casadi import load_params
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.fmi.plant.oracle import plant_sensor_oracle
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.model.sensors import (
    NOISE_STREAMS,
    encoder_count,
    make_encoders,
    make_gyro_bias_step,
    make_imu,
)

pytestmark = pytest.mark.needs_cc

P = load_params()
PV = P.to_vector()
S = load_sensor_params()
X0 = make_state(roll=0.03, pitch=-0.02, yaw=0.4, dx=0.1, omega_body=(0.05, -0.02, 0.1))
N = 200  # 1 s of 5 ms periods
T = np.arange(N)[:, None] * 0.005
TAU = 0.3 * np.sin(T * 20 + np.array([0.0, 1.0, 2.0]))
TAU[50:60] = 3.0  # saturated at tau_max
DIST = np.zeros_like(TAU)
DIST[100:110, 1] = 0.2
BIASED = S.replace(acc_bias=[0.05, -0.1, 0.2], gyro_bias0=[0.01, -0.02, 0.03],
                   gyro_scale=[1.02, 0.99, 1.0], imu_misalignment=[0.01, 0.0, -0.02],
                   imu_position=[0.0, 0.01, 0.2], gyro_bias_rw=[0.01, 0.02, 0.03])


@pytest.fixture(scope="module")
def sensor_fns(model_functions):
    return {"imu": make_imu(model_functions["ode"]), "enc": make_encoders(),
            "bias": make_gyro_bias_step(), "ode": model_functions["ode"]}


def _per_step(values: np.ndarray, step: float) -> np.ndarray:
    """The 5 ms torque sequence as inputs of steps of another size (held per 5 ms)."""
    n = int(round(N * 0.005 / step))
    idx = np.minimum((np.arange(n) * step / 0.005 + 1e-9).astype(int), N - 1)
    return values[idx]


def _sensor_params(s) -> dict[str, float]:
    return dict(zip(s.names, s.to_vector().tolist()))


def _fmu_run(step: float, noise_on: bool, seed: int = 42, sensors=S, **extra) -> np.ndarray:
    """FMU states and readings at every communication point: (n + 1, 15 + 9)."""
    tau, dist = _per_step(TAU, step), _per_step(DIST, step)
    p = Plant("cs")
    p.init(**dict(zip(X0_NAMES, X0.tolist())), noise_on=noise_on, seed=seed,
           **_sensor_params(sensors), **extra)
    rows = [np.r_[p.get(*ALL_STATES), p.get(*SENSORS)]]
    for i in range(len(tau)):
        p.set(**{f"tau{j}": tau[i, j] for j in range(3)},
              **{f"tau_dist{j}": dist[i, j] for j in range(3)})
        p.step(step)
        rows.append(np.r_[p.get(*ALL_STATES), p.get(*SENSORS)])
    assert p.errors() == []
    p.free()
    return np.array(rows)


def _ref_run(step: float, noise_on: bool, seed: int = 42, sensors=S, **kw) -> np.ndarray:
    ref = plant_sensor_oracle(X0, _per_step(TAU, step), _per_step(DIST, step), step=step,
                                 sensors=sensors, seed=seed, noise_on=noise_on, **kw)
    return np.hstack([ref["xw"], ref["acc"], ref["gyro"], ref["enc"]])


def _compare(fmu: np.ndarray, ref: np.ndarray) -> None:
    assert fmu.shape == ref.shape
    err = np.abs(fmu - ref)
    print(f"FMU vs Python oracle: states {err[:, :NXW].max():.3e}, IMU "
          f"{err[:, NXW:NXW + 6].max():.3e}, encoders {err[:, NXW + 6:].max():.3e}")
    np.testing.assert_allclose(fmu[:, :NXW], ref[:, :NXW], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fmu[:, NXW:NXW + 6], ref[:, NXW:NXW + 6], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fmu[:, NXW + 6:], ref[:, NXW + 6:])  # whole ticks / Ts


@pytest.mark.parametrize("noise_on", [False, True])
def test_readings_equal_the_python_reference(noise_on):
    fmu, ref = _fmu_run(0.005, noise_on, sensors=BIASED), _ref_run(0.005, noise_on,
                                                                     sensors=BIASED)
    _compare(fmu, ref)
    # not vacuous: the robot moves, the wheels turn through many ticks, noise is present
    assert np.abs(fmu[:, NXW + 6:]).max() > 1000 and np.ptp(fmu[:, 12:15], axis=0).min() > 0.05
    quiet = _ref_run(0.005, not noise_on, sensors=BIASED)
    assert (np.abs(quiet[:, NXW:NXW + 6] - ref[:, NXW:NXW + 6]).max() > 1e-3)


@pytest.mark.parametrize("step", [0.01, 0.0025, 0.003])
def test_any_step_size_samples_at_the_sample_instants(step):
    """Steps spanning two instants, half steps and unaligned steps (stops inside a step)."""
    _compare(_fmu_run(step, True), _ref_run(step, True))


def test_the_step_size_does_not_move_the_sample_instants():
    """Constant torques: every step size samples the same instants; the readings differ
    only by the RK4 grid (identical grid for 10 ms steps: 5 ms segments)."""
    runs = {}
    for step in (0.005, 0.01, 0.0025, 0.003):
        p = Plant("cs")
        p.init(**dict(zip(X0_NAMES, X0.tolist())), tau0=0.2, tau1=-0.1, tau2=0.3, noise_on=True,
               seed=8)
        t, rows = 0.0, {0: p.get(*SENSORS)}
        for _ in range(int(round(0.3 / step))):
            p.step(step)
            t += step
            k = round(t / 0.005)
            if abs(t - k * 0.005) < 1e-12:
                rows[k] = p.get(*SENSORS)
        runs[step] = rows
        p.free()
    base = runs[0.005]
    for step, tol in ((0.01, 1e-12), (0.0025, 1e-8), (0.003, 1e-8)):
        common = sorted(runs[step])
        assert len(common) >= 20
        diff = max(np.abs(runs[step][k][:6] - base[k][:6]).max() for k in common)
        print(f"step {step}: readings at the shared instants differ by {diff:.2e}")
        assert diff <= tol
        assert all(np.array_equal(runs[step][k][6:], base[k][6:]) for k in common)


def test_readings_are_held_between_sample_instants():
    fmu = _fmu_run(0.0025, True)
    held = fmu[1::2, NXW:]  # t = 2.5 ms, 7.5 ms, ...: no new sample
    np.testing.assert_array_equal(held, fmu[0:-1:2, NXW:])
    assert not np.array_equal(fmu[2::2, NXW:], fmu[1::2, NXW:])  # new sample at 5 ms, ...


def test_sample_zero_conventions(sensor_fns):
    """Sample 0: the start state, zero torque (nothing acted yet), b_0, encoders read 0."""
    p = Plant("cs")
    tau = (0.4, -0.3, 0.2)
    p.init(**dict(zip(X0_NAMES, X0.tolist())), tau0=tau[0], tau1=tau[1], tau2=tau[2],
           noise_on=True, seed=5, **_sensor_params(BIASED))
    ns = NoiseStream(5)
    n_acc = ns.normal(NOISE_STREAMS["acc"], 1, 3)[0]
    n_gyro = ns.normal(NOISE_STREAMS["gyro"], 1, 3)[0]
    acc, gyro = (np.asarray(v).ravel() for v in sensor_fns["imu"](
        X0, np.zeros(3), PV, BIASED.to_vector(), BIASED.gyro_bias0, n_acc, n_gyro))
    np.testing.assert_array_equal(p.get(*SENSORS[:3]), acc)
    np.testing.assert_array_equal(p.get(*SENSORS[3:6]), gyro)
    assert p.get(*SENSORS[6:]).tolist() == [0.0, 0.0, 0.0]
    assert p.get_int("sensor_sample") == [0]
    np.testing.assert_array_equal(p.get("sensor_gyro_bias_x", "sensor_gyro_bias_y",
                                        "sensor_gyro_bias_z"), BIASED.gyro_bias0)
    # the continuous noise-free output uses the current torque, the reading does not
    with_tau = np.asarray(sensor_fns["imu"](X0, tau, PV, S.to_vector(), np.zeros(3),
                                            np.zeros(3), np.zeros(3))[0]).ravel()
    np.testing.assert_allclose(p.get("acc_x", "acc_y", "acc_z"), with_tau, rtol=0, atol=1e-12)
    assert np.abs(with_tau - acc).max() > 0.01
    # sample 1 uses the torque of the first step, b_1 from the random walk
    p.step(0.005)
    n_rw = ns.normal(NOISE_STREAMS["gyro_bias_rw"], 1, 3)[0]
    b1 = np.asarray(sensor_fns["bias"](BIASED.gyro_bias0, BIASED.to_vector(), 0.005, n_rw)).ravel()
    np.testing.assert_array_equal(p.get("sensor_gyro_bias_x", "sensor_gyro_bias_y",
                                        "sensor_gyro_bias_z"), b1)
    np.testing.assert_array_equal(p.get("sensor_tau_prev0", "sensor_tau_prev1",
                                        "sensor_tau_prev2"), tau)
    assert p.get_int("sensor_sample") == [1]
    p.free()


def test_encoder_counts_are_the_quantised_wheel_angles():
    """Sum of the readings times Ts = count difference of the end points (no drift)."""
    fmu = _fmu_run(0.005, False)
    dticks = fmu[1:, NXW + 6:] * 0.005
    np.testing.assert_allclose(dticks, np.round(dticks), rtol=0, atol=1e-9)  # whole ticks
    phi = fmu[:, 12:15]
    counts = encoder_count(phi, P.n_ticks)
    np.testing.assert_allclose(np.round(dticks), np.diff(counts, axis=0), rtol=0, atol=0)
    # and the wheel angles are the integral of the wheel speeds (trapezoid, 5 ms)
    p = Plant("cs")
    p.init(**dict(zip(X0_NAMES, X0.tolist())))
    speeds, angles = [p.get("dphi0", "dphi1", "dphi2")], [p.get("phi0", "phi1", "phi2")]
    for i in range(N):
        p.set(tau0=TAU[i, 0], tau1=TAU[i, 1], tau2=TAU[i, 2], tau_dist1=DIST[i, 1])
        p.step(0.005)
        speeds.append(p.get("dphi0", "dphi1", "dphi2"))
        angles.append(p.get("phi0", "phi1", "phi2"))
    speeds, angles = np.array(speeds), np.array(angles)
    trap = np.vstack([np.zeros(3), np.cumsum((speeds[1:] + speeds[:-1]) / 2 * 0.005, axis=0)])
    np.testing.assert_allclose(angles, trap, rtol=0, atol=2e-3 * np.abs(angles).max())
    p.free()


def test_noise_statistics_at_rest():
    """Upright at rest: readings = g along z plus white noise of the configured variance;
    bias increments of variance sigma_rw^2 Ts."""
    s = S.replace(gyro_bias_rw=[0.5, 0.5, 0.5])
    p = Plant("cs")
    p.init(noise_on=True, seed=77, **_sensor_params(s))
    n = 2000
    r, b = [], []
    for _ in range(n):
        p.step(0.005)
        r.append(p.get(*SENSORS))
        b.append(p.get("sensor_gyro_bias_x", "sensor_gyro_bias_y", "sensor_gyro_bias_z"))
    r, b = np.array(r), np.array(b)
    assert np.abs(p.state() - make_state()).max() < 1e-12  # the equilibrium: still at rest
    acc = r[:, :3] - [0.0, 0.0, P.g]
    # 5 sigma bounds: mean sigma/sqrt(n); variance relative sd sqrt(2/n)
    var = np.array(s.acc_noise_var)
    assert np.all(np.abs(acc.mean(axis=0)) < 5 * np.sqrt(var / n))
    assert np.all(np.abs(acc.var(axis=0) / var - 1) < 5 * math.sqrt(2 / n))
    gyro = r[:, 3:6] - b  # the gyroscope reads its bias plus white noise at rest
    gvar = np.array(s.gyro_noise_var)
    assert np.all(np.abs(gyro.var(axis=0) / gvar - 1) < 5 * math.sqrt(2 / n))
    inc = np.diff(b, axis=0)
    assert np.all(np.abs(inc.var(axis=0) / (0.25 * 0.005) - 1) < 5 * math.sqrt(2 / n))
    assert np.all(r[:, 6:] == 0.0)  # the wheels do not turn
    # axes are independent streams
    assert abs(np.corrcoef(acc[:, 0], acc[:, 1])[0, 1]) < 5 / math.sqrt(n)
    p.free()


def test_seed_changes_the_noise_and_noise_off_is_deterministic():
    a, b = _fmu_run(0.005, True, seed=1), _fmu_run(0.005, True, seed=2)
    np.testing.assert_array_equal(a[:, :NXW], b[:, :NXW])  # the plant does not see the noise
    assert np.abs(a[:, NXW:NXW + 6] - b[:, NXW:NXW + 6]).min() > 0.0
    c, d = _fmu_run(0.005, False, seed=1), _fmu_run(0.005, False, seed=2)
    np.testing.assert_array_equal(c, d)


@pytest.mark.parametrize("start", [1.25, -2.5])  # FMI allows any start time
def test_start_time_and_sensor_period_parameters(start):
    """Samples at startTime + k Ts_sensor; Ts_sensor 10 ms holds each reading two steps."""
    ref = plant_sensor_oracle(X0, TAU[:40], step=0.005, Ts_sensor=0.01, start_time=start,
                              noise_on=True, seed=3)
    p = Plant("cs")
    p.init(start_time=start, **dict(zip(X0_NAMES, X0.tolist())), Ts_sensor=0.01, noise_on=True,
           seed=3)
    rows = [p.get(*SENSORS)]
    for i in range(40):
        p.set(tau0=TAU[i, 0], tau1=TAU[i, 1], tau2=TAU[i, 2])
        p.step(0.005)
        rows.append(p.get(*SENSORS))
    rows = np.array(rows)
    np.testing.assert_allclose(rows, np.hstack([ref["acc"], ref["gyro"], ref["enc"]]), rtol=0,
                               atol=1e-12)
    assert ref["sample"].tolist() == [k // 2 for k in range(41)]
    assert p.get_int("sensor_sample") == [20]
    p.free()


def test_steps_with_too_many_samples_are_refused():
    p = Plant("cs")
    p.init(Ts_sensor=1e-9)
    x0 = p.state()
    st = p.raw("fmi2DoStep", c_double(0.0), c_double(0.005), 1)
    assert st == 3 and "sensor samples" in p.errors()[-1] and "refused" in p.errors()[-1]
    assert np.array_equal(p.state(), x0) and p.get_int("sensor_sample") == [0]
    p.step(1e-6)  # still usable (1000 samples)
    assert p.get_int("sensor_sample") == [1000]
    # the count in the refusal is from the last sample taken (1000), not from the start
    st = p.raw("fmi2DoStep", c_double(1e-6), c_double(0.005), 1)
    assert st == 3 and p.errors()[-1].endswith(
        "step 0.005 from t = 1e-06 spans 5e+06 sensor samples of Ts_sensor = 1e-09 (at most "
        "1e+06 per step, sample index at most 2147483647)"), p.errors()[-1]
    p.free()


def test_model_exchange_refuses_an_event_too_many_samples_on():
    """At an event, the samples due since the last one taken are bounded as a step's are
    (MAX_SAMPLES); the refusal counts them from that sample."""
    m = Plant("me")
    m.init(Ts_sensor=1e-9)
    m.fmu.setTime(1e-6)
    m.fmu.enterEventMode()
    assert m.raw("fmi2NewDiscreteStates", byref(fmi2EventInfo())) == 1  # a warning: late
    assert m.get_int("sensor_sample") == [1000]
    m.fmu.enterContinuousTimeMode()
    m.fmu.setTime(0.005 + 1e-6)
    m.fmu.enterEventMode()
    assert m.raw("fmi2NewDiscreteStates", byref(fmi2EventInfo())) == 3
    assert m.errors()[-1].endswith(
        "time 0.005001 is 5e+06 sensor samples past the last one (at most 1e+06)"), m.errors()[-1]
    m.free()


def test_fmu_state_with_sensors_continues_bit_identically():
    p = Plant("cs", name="first")
    p.init(**dict(zip(X0_NAMES, X0.tolist())), noise_on=True, seed=11, **_sensor_params(BIASED))

    def run(q: Plant, start: int, n: int) -> list:
        out = []
        for i in range(start, start + n):
            q.set(tau0=TAU[i, 0], tau1=TAU[i, 1], tau2=TAU[i, 2])
            q.step(0.005 if i % 3 else 0.0025)  # also restores between sample instants
            out.append(q.snapshot())
        return out

    run(p, 0, 7)
    s = p.fmu.getFMUstate()
    blob = p.fmu.serializeFMUstate(s)
    t0 = p.t
    a = run(p, 7, 30)
    p.fmu.setFMUstate(s)  # roll back in the same instance
    p.t = t0
    # repr: bit-identical doubles print alike, and the held NaN heading reading equals itself
    assert repr(run(p, 7, 30)) == repr(a)
    p.fmu.freeFMUstate(s)
    q = Plant("cs", name="second")  # and in a fresh one, from the serialised state
    s2 = q.fmu.deSerializeFMUstate(blob)
    q.fmu.setFMUstate(s2)
    q.fmu.freeFMUstate(s2)
    q.t = t0
    assert repr(run(q, 7, 30)) == repr(a)
    assert a[-1][1][1] > 10  # sensor_sample advanced (Integer values are compared too)
    p.fmu.reset()  # reset, same start: the same noisy run
    p.init(**dict(zip(X0_NAMES, X0.tolist())), noise_on=True, seed=11, **_sensor_params(BIASED))
    b = run(p, 0, 37)
    assert repr(b[7:]) == repr(a)
    for x in (p, q):
        x.free()


def test_model_exchange_samples_at_time_events(sensor_fns):
    m = Plant("me")
    m.fmu.setupExperiment(startTime=0.0)
    m.fmu.enterInitializationMode()
    m.set_bool(noise_on=True)
    m.set_int(seed=9)
    m.set(**dict(zip(X0_NAMES, X0.tolist())), tau0=0.2, tau1=-0.1, tau2=0.05,
          **_sensor_params(BIASED))
    m.fmu.exitInitializationMode()
    *_, defined, t_next = m.fmu.newDiscreteStates()
    assert defined and t_next == 0.005 and m.get_int("sensor_sample") == [0]
    m.fmu.enterContinuousTimeMode()
    x1 = np.r_[make_state(roll=0.05, pitch=0.01, dx=0.2, omega_body=(0.1, 0.0, 0.3)),
               0.3, -0.2, 0.1]
    m.fmu.setTime(0.005)
    m.fmu.setContinuousStates((c_double * NXW)(*x1), NXW)
    m.fmu.completedIntegratorStep()
    m.fmu.enterEventMode()
    m.set(tau0=-0.5)  # the importer changes the input at the event: not seen by sample 1
    *_, defined, t_next = m.fmu.newDiscreteStates()
    assert defined and t_next == 0.01 and m.get_int("sensor_sample") == [1]
    assert not any("did not stop at nextEventTime" in msg for _, _, msg in m.logs)  # on time
    ns = NoiseStream(9)
    nrm = {k: ns.normal(v, 2, 3) for k, v in NOISE_STREAMS.items()}
    sv = BIASED.to_vector()
    b1 = np.asarray(sensor_fns["bias"](BIASED.gyro_bias0, sv, 0.005, nrm["gyro_bias_rw"][0])).ravel()
    acc, gyro = (np.asarray(v).ravel() for v in sensor_fns["imu"](
        x1[:12], [0.2, -0.1, 0.05], PV, sv, b1, nrm["acc"][1], nrm["gyro"][1]))
    enc = np.asarray(sensor_fns["enc"](x1[12:], np.zeros(3), PV, 0.005)[0]).ravel()  # phi(0) = 0
    np.testing.assert_array_equal(m.get(*SENSORS[:3]), acc)
    np.testing.assert_array_equal(m.get(*SENSORS[3:6]), gyro)
    np.testing.assert_array_equal(m.get(*SENSORS[6:]), enc)
    assert np.abs(enc).max() > 100
    # an importer that overshoots sample instants gets them late, with a warning
    m.fmu.enterContinuousTimeMode()
    m.fmu.setTime(0.0231)
    m.fmu.enterEventMode()
    *_, defined, t_next = m.fmu.newDiscreteStates()
    assert m.get_int("sensor_sample") == [4] and t_next == pytest.approx(0.025, abs=1e-15)
    assert any("did not stop at nextEventTime" in msg for s, _, msg in m.logs if s == 1)
    m.free()


def test_fmpy_model_exchange_and_co_simulation_readings_agree():
    """fmpy's ME loop (CVode, time events) and CS give the same readings at the instants."""
    from _fmu_support import plant_build
    from fmpy import simulate_fmu

    fmu = str(plant_build().fmu)
    sv = {**dict(zip(X0_NAMES, X0.tolist())), "tau0": 0.1, "tau1": -0.05, "noise_on": True,
          "seed": 4}
    out = [*SENSORS, "sensor_sample"]
    cs = simulate_fmu(fmu, fmi_type="CoSimulation", stop_time=0.5, output_interval=0.005,
                      start_values=sv, output=out)
    me = simulate_fmu(fmu, fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-12,
                      stop_time=0.5, output_interval=0.005, start_values=sv, output=out,
                      record_events=False)
    assert np.array_equal(cs["sensor_sample"], np.arange(101))
    assert np.array_equal(me["sensor_sample"], cs["sensor_sample"])
    for name in SENSORS[:6]:
        np.testing.assert_allclose(me[name], cs[name], rtol=0, atol=1e-6)
    for name in SENSORS[6:]:  # at most one tick apart (quantisation of nearby angles)
        assert np.abs(me[name] - cs[name]).max() <= 200.0
