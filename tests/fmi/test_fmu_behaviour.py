"""FMI behaviour of BallbotPlant.fmu: start values, parameters, reset, FMU state,
serialisation, directional derivatives, independent instances, bad input and fuzzing."""

from __future__ import annotations

from ctypes import c_double, c_int, c_uint

import numpy as np
import pytest
from _fmu_support import (
    ALL_STATES,
    NXW,
    SENSORS,
    STATES,
    X0_NAMES,
    Plant,
    fuzz_counts,
    plant_build,
    python_rk4,
    vrs,
)
from fmpy.fmi1 import FMICallException

from ballbot_casadi import load_params
from ballbot_casadi.fmi.build import plant_variables
from ballbot_casadi.model.dynamics import make_model_functions
from ballbot_casadi.model.numeric import make_state

P = load_params()
PV = P.to_vector()
TAU = np.array([0.3, -0.2, 0.1])
X_TILT = make_state(roll=0.03, pitch=-0.02, yaw=0.4, dx=0.1, omega_body=(0.05, -0.02, 0.1))


@pytest.fixture(scope="module")
def fns():
    return make_model_functions()


def _start(p: Plant, x=X_TILT, tau=TAU, **extra):
    p.init(**dict(zip(STATES, np.asarray(x).tolist())), tau0=tau[0], tau1=tau[1],
           tau2=tau[2], **extra)


def test_start_values_equal_values_after_initialisation():
    rows = [r for r in plant_variables() if r.start is not None]
    assert {r.type for r in rows} == {"Real", "Integer", "Boolean"}
    for kind in ("cs", "me"):
        p = Plant(kind)
        p.init()
        for t, get in (("Real", p.fmu.getReal), ("Integer", p.fmu.getInteger),
                       ("Boolean", p.fmu.getBoolean)):
            sel = [r for r in rows if r.type == t]
            assert list(get([r.vr for r in sel])) == [r.start for r in sel], t
        assert p.get_bool("noise_on") == [False] and p.get_int("seed", "sensor_sample") == [0, 0]
        assert p.logs == []  # quiet by default
        p.free()


def test_derivatives_and_outputs_match_the_python_model(fns):
    from ballbot_casadi.core import quaternion as Q
    from ballbot_casadi.model.sensors import make_sensors

    p = Plant("me")
    _start(p)
    xdot = p.get(*[f"der({n})" for n in STATES])
    np.testing.assert_allclose(xdot, np.asarray(fns["ode"](X_TILT, TAU, PV)).ravel(), rtol=0,
                               atol=1e-13)
    acc, gyro, enc = (np.asarray(v).ravel() for v in make_sensors(fns["ode"])(X_TILT, TAU, PV))
    np.testing.assert_allclose(p.get("acc_x", "acc_y", "acc_z"), acc, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p.get("gyro_x", "gyro_y", "gyro_z"), gyro, rtol=0, atol=1e-13)
    np.testing.assert_allclose(p.get("enc0", "enc1", "enc2"), enc, rtol=1e-13, atol=1e-8)
    np.testing.assert_allclose(p.get("roll", "pitch", "yaw"), Q.to_rpy(X_TILT[2:6]), atol=1e-13)
    np.testing.assert_allclose(p.get("dphi0", "dphi1", "dphi2"),
                               np.asarray(fns["wheel_speeds"](X_TILT, PV)).ravel(), atol=1e-13)
    p.free()


def test_torques_are_saturated_at_tau_max(fns):
    p = Plant("me")
    _start(p, tau=(5.0, -7.0, 0.5), tau_max=1.5)
    xdot = p.get(*[f"der({n})" for n in STATES])
    pv = P.replace(tau_max=1.5).to_vector()
    ref = np.asarray(fns["ode"](X_TILT, [1.5, -1.5, 0.5], pv)).ravel()
    np.testing.assert_allclose(xdot, ref, rtol=0, atol=1e-13)
    # saturated inputs have zero directional derivative
    d = p.fmu.getDirectionalDerivative(vrs("der(dx)"), vrs("tau0", "tau2"), [1.0, 0.0])
    assert d == [0.0]
    p.free()


def test_parameters_before_initialisation_take_effect_fixed_ones_after_are_refused(fns):
    p = Plant("cs")
    p.fmu.setupExperiment(startTime=0.0)
    p.set(Mb=20.0, l=0.3)  # in the instantiated state
    p.fmu.enterInitializationMode()
    p.set(Jbz=0.2, **dict(zip(X0_NAMES, X_TILT.tolist())), tau0=TAU[0], tau1=TAU[1], tau2=TAU[2])
    p.fmu.exitInitializationMode()
    pv = P.replace(Mb=20.0, l=0.3, Jbz=0.2).to_vector()
    p.step(0.005)
    ref = python_rk4(X_TILT, TAU, pv, 0.005, 1)[-1]
    np.testing.assert_allclose(p.state(), ref, rtol=0, atol=1e-14)
    for name in ("Mb", "h_internal"):
        with pytest.raises(FMICallException):
            p.set(**{name: 1.0})
        assert "fixed parameters can only be set before initialisation ends" in p.errors()[-1]
    with pytest.raises(FMICallException):  # states of a CS instance neither
        p.set(x=1.0)
    assert p.get("Mb")[0] == 20.0
    p.free()


def test_internal_step_parameter_sub_steps_rk4():
    p = Plant("cs")
    _start(p, h_internal=2.5e-3)
    p.step(0.01, 3)
    ref = python_rk4(X_TILT, TAU, PV, 0.01, 3, h_int=2.5e-3)[-1]
    np.testing.assert_allclose(p.state(), ref, rtol=0, atol=1e-14)
    p.free()


def _run(p: Plant, n: int = 40):
    """Steps with changing torques; every Real, Integer and Boolean value after each."""
    out = []
    for k in range(n):
        p.set(tau0=0.1 * np.sin(k / 5), tau1=-0.05, tau2=0.02 * k / n)
        p.step(0.005)
        r, i, b = p.snapshot()
        out.append(r + i + b)
    return np.array(out)


def test_reset_reproduces_a_run_bit_exactly():
    p = Plant("cs")
    _start(p)
    a = _run(p)
    p.fmu.reset()
    _start(p)
    b = _run(p)
    assert np.array_equal(a, b, equal_nan=True)  # the held NaN heading reading
    p.fmu.reset()  # after reset the start values are back
    p.init()
    assert p.state().tolist() == make_state().tolist()
    p.free()


def test_get_set_fmu_state_rolls_back_bit_exactly():
    for kind in ("cs", "me"):
        p = Plant(kind)
        _start(p)
        if kind == "cs":
            p.step(0.005, 10)
        s = p.fmu.getFMUstate()
        t0 = p.t
        x0 = p.state()
        if kind == "cs":
            a = _run(p, 20)
        else:
            xw = p.get(*ALL_STATES) + 0.01
            p.fmu.setContinuousStates((c_double * NXW)(*xw), NXW)
            p.fmu.setTime(1.0)
        p.fmu.setFMUstate(s)
        p.t = t0
        assert np.array_equal(p.state(), x0)
        if kind == "cs":
            b = _run(p, 20)
            assert np.array_equal(a, b, equal_nan=True)
        p.fmu.freeFMUstate(s)
        p.free()


def test_serialised_state_continues_identically_in_a_fresh_instance():
    p = Plant("cs", name="first")
    _start(p)
    p.step(0.005, 10)
    s = p.fmu.getFMUstate()
    blob = p.fmu.serializeFMUstate(s)
    p.fmu.freeFMUstate(s)
    a = _run(p, 20)
    q = Plant("cs", name="second")
    s2 = q.fmu.deSerializeFMUstate(blob)
    q.fmu.setFMUstate(s2)
    q.fmu.freeFMUstate(s2)
    q.t = p.t - 20 * 0.005
    b = _run(q, 20)
    assert np.array_equal(a, b, equal_nan=True)
    # corrupt states are rejected with a message
    for bad in (blob[:-1], blob[:20] + bytes([blob[20] ^ 0x40]) + blob[21:], b"x" * len(blob)):
        with pytest.raises(FMICallException):
            q.fmu.deSerializeFMUstate(bad)
        assert "corrupt state" in q.errors()[-1] or "different GUID" in q.errors()[-1]
    # a Co-Simulation state cannot be loaded into a Model Exchange instance
    m = Plant("me")
    with pytest.raises(FMICallException):
        m.fmu.deSerializeFMUstate(blob)
    assert "Co-Simulation" in m.errors()[-1]
    for x in (p, q, m):
        x.free()


def test_directional_derivatives_equal_analytic_jacobian_and_finite_differences(fns):
    p = Plant("me")
    _start(p)
    A, B = (np.asarray(m) for m in fns["jac"](X_TILT, TAU, PV))
    der = vrs(*[f"der({n})" for n in STATES])
    known = vrs(*STATES) + vrs("tau0", "tau1", "tau2")
    J = np.zeros((12, 15))
    for j, k in enumerate(known):
        J[:, j] = p.fmu.getDirectionalDerivative(der, [k], [1.0])
    np.testing.assert_allclose(J, np.hstack([A, B]), rtol=0, atol=1e-12)
    # a combined seed is the linear combination
    rng = np.random.default_rng(7)
    seed = rng.normal(size=15)
    np.testing.assert_allclose(p.fmu.getDirectionalDerivative(der, known, seed.tolist()),
                               J @ seed, rtol=1e-12, atol=1e-12)
    # outputs w.r.t. inputs and states against central finite differences
    outs = vrs("roll", "pitch", "yaw", "dphi0", "dphi1", "dphi2", "acc_x", "acc_y", "acc_z",
               "gyro_x", "gyro_y", "gyro_z")
    Jy = np.array([p.fmu.getDirectionalDerivative(outs, [k], [1.0]) for k in known]).T
    eps = 1e-6
    base_x, base_u = X_TILT.copy(), TAU.copy()
    fd = np.zeros_like(Jy)
    for j in range(15):
        vals = []
        for sgn in (1, -1):
            x, u = base_x.copy(), base_u.copy()
            if j < 12:
                x[j] += sgn * eps
            else:
                u[j - 12] += sgn * eps
            p.fmu.setContinuousStates((c_double * NXW)(*x, 0.0, 0.0, 0.0), NXW)
            p.set(tau0=u[0], tau1=u[1], tau2=u[2])
            vals.append(np.array(p.fmu.getReal(outs)))
        fd[:, j] = (vals[0] - vals[1]) / (2 * eps)
    np.testing.assert_allclose(Jy, fd, rtol=1e-6, atol=1e-6)
    # states as outputs: identity
    assert p.fmu.getDirectionalDerivative(vrs("q1"), vrs("q1", "q2"), [2.0, 5.0]) == [2.0]
    p.free()


def test_directional_derivatives_of_the_wheel_angle_states(fns):
    import casadi as ca

    p = Plant("me")
    _start(p)
    xs = ca.SX.sym("x", 12)
    W = np.asarray(ca.Function("W", [xs], [ca.jacobian(fns["wheel_speeds"](xs, PV), xs)])(X_TILT))
    der_phi = vrs("der(phi0)", "der(phi1)", "der(phi2)")
    known = vrs(*ALL_STATES, "tau0", "tau1", "tau2", "tau_dist0")
    J = np.array([p.fmu.getDirectionalDerivative(der_phi, [k], [1.0]) for k in known]).T
    # d dphi/dx is the inverse kinematics' Jacobian; nothing depends on phi or on torques
    np.testing.assert_allclose(J, np.hstack([W, np.zeros((3, 7))]), rtol=0, atol=1e-12)
    assert np.abs(W).max() > 1.0  # a non-trivial Jacobian
    outs = vrs(*[f"der({n})" for n in ALL_STATES], "roll", "dphi0", "acc_x", "gyro_z", "enc1")
    for phi in ("phi0", "phi1", "phi2"):
        assert p.fmu.getDirectionalDerivative(outs, vrs(phi), [1.0]) == [0.0] * len(outs)
    assert p.fmu.getDirectionalDerivative(vrs("phi2"), vrs("phi2"), [3.0]) == [3.0]
    # discrete outputs, locals and parameters are no unknowns / knowns
    for unknown, known_, text in ((SENSORS[0], "q1", "is not a derivative, state or continuous"),
                                  ("sensor_gyro_bias_x", "q1", "is not a derivative"),
                                  ("der(q1)", "Mb", "is not a state or a continuous input")):
        st = p.raw("fmi2GetDirectionalDerivative", (c_uint * 1)(*vrs(unknown)), 1,
                   (c_uint * 1)(*vrs(known_)), 1, (c_double * 1)(1.0), (c_double * 1)())
        _expect_error(p, st, text)
    p.free()


def test_two_interleaved_instances_stay_independent():
    a, b = Plant("cs", "a"), Plant("cs", "b")
    _start(a)
    _start(b, x=make_state(pitch=0.05), tau=(-0.1, 0.2, 0.0), Mb=18.0)
    xa, xb = [], []
    for k in range(30):
        a.set(tau0=0.1 * k / 30)
        a.step(0.005)
        b.step(0.005)
        xa.append(a.state())
        xb.append(b.state())
    alone_a, alone_b = Plant("cs", "alone_a"), Plant("cs", "alone_b")
    _start(alone_a)
    ya = []
    for k in range(30):
        alone_a.set(tau0=0.1 * k / 30)
        alone_a.step(0.005)
        ya.append(alone_a.state())
    _start(alone_b, x=make_state(pitch=0.05), tau=(-0.1, 0.2, 0.0), Mb=18.0)
    yb = []
    for _ in range(30):
        alone_b.step(0.005)
        yb.append(alone_b.state())
    assert np.array_equal(np.array(xa), np.array(ya))
    assert np.array_equal(np.array(xb), np.array(yb))
    for x in (a, b, alone_a, alone_b):
        x.free()


# --------------------------------------------------------------------------- bad input

ERR = 3


def _expect_error(p: Plant, status: int, text: str) -> None:
    assert status == ERR, status
    assert p.errors(), "no log message"
    assert text in p.errors()[-1], p.errors()[-1]


def test_unknown_value_references_are_errors():
    p = Plant("cs")
    _start(p)
    n = len(plant_variables())
    for vr in (n, n + 1, 2**32 - 1):
        vals = (c_double * 1)()
        st = p.raw("fmi2GetReal", (c_uint * 1)(vr), 1, vals)
        _expect_error(p, st, f"unknown value reference {vr}")
        st = p.raw_set_real([vr], [0.0])
        _expect_error(p, st, f"unknown value reference {vr}")
    st = p.raw("fmi2GetInteger", (c_uint * 1)(0), 1, (c_int * 1)())
    _expect_error(p, st, "unknown value reference 0")
    p.free()


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_nan_and_inf_inputs_and_parameters_are_errors(value):
    p = Plant("cs")
    p.fmu.setupExperiment(startTime=0.0)
    p.fmu.enterInitializationMode()
    for name in ("tau0", "Mb", "x0_q0", "h_internal"):
        st = p.raw_set_real(vrs(name), [value])
        _expect_error(p, st, "must be finite")
    p.fmu.exitInitializationMode()
    st = p.raw_set_real(vrs("tau1"), [value])
    _expect_error(p, st, "must be finite")
    assert p.get("tau1")[0] == 0.0  # nothing stored
    p.free()


@pytest.mark.parametrize("name,value", [("Mb", -1.0), ("Mb", 0.0), ("alpha", 2.0),
                                        ("gamma", 0.0), ("Bvk", -0.1), ("h_internal", 0.0),
                                        ("tau_max", -1.0), ("g", -9.81)])
def test_non_physical_parameters_are_refused(name, value):
    p = Plant("cs")
    st = p.raw_set_real(vrs(name), [value])
    _expect_error(p, st, "non-physical value")
    p.init()
    expected = 1e-3 if name == "h_internal" else getattr(P, name)
    assert p.get(name)[0] == expected  # the refused value was not stored
    p.free()


def test_all_or_nothing_set_real():
    p = Plant("cs")
    st = p.raw_set_real(vrs("Mb", "l"), [10.0, -1.0])
    _expect_error(p, st, "non-physical")
    p.init()
    assert p.get("Mb")[0] == P.Mb
    p.free()


def test_the_state_starts_from_the_x0_parameters_and_cannot_be_set_before_init():
    for kind in ("cs", "me"):
        p = Plant(kind)
        p.fmu.setupExperiment(startTime=0.0)
        p.fmu.enterInitializationMode()
        np.testing.assert_array_equal(p.get(*STATES), p.get(*X0_NAMES))  # the defaults
        assert p.get("q0")[0] == 1.0
        p.set(**dict(zip(X0_NAMES, X_TILT.tolist())))
        np.testing.assert_array_equal(p.get(*STATES), X_TILT)  # follows x0_* at once
        st = p.raw_set_real(vrs("q1"), [0.0])
        _expect_error(p, st, "starts from the parameter 'x0_q1'")
        p.fmu.exitInitializationMode()
        np.testing.assert_array_equal(p.get(*STATES), X_TILT)
        p.free()


def test_non_unit_start_quaternion_is_refused_at_initialisation():
    for kind in ("cs", "me"):
        p = Plant(kind)
        p.fmu.setupExperiment(startTime=0.0)
        p.fmu.enterInitializationMode()
        p.set(x0_q0=1.0, x0_q1=0.1)
        st = p.raw("fmi2ExitInitializationMode")
        _expect_error(p, st, "must be a unit quaternion")
        assert "x0_q0, x0_q1, x0_q2, x0_q3" in p.errors()[-1]  # names what to fix
        p.set(x0_q0=float(np.sqrt(1 - 0.01)))  # fixed: now accepted
        p.fmu.exitInitializationMode()
        p.free()


def test_wrong_call_order_is_an_error():
    p = Plant("cs")
    st = p.raw("fmi2DoStep", c_double(0.0), c_double(0.005), 1)
    _expect_error(p, st, "not allowed in state instantiated")
    st = p.raw("fmi2ExitInitializationMode")
    _expect_error(p, st, "not allowed in state instantiated")
    vals = (c_double * 1)()
    st = p.raw("fmi2GetReal", (c_uint * 1)(0), 1, vals)
    _expect_error(p, st, "not allowed")
    st = p.raw("fmi2GetDerivatives", (c_double * 12)(), 12)
    _expect_error(p, st, "only available for Model Exchange")
    st = p.raw_set_real(vrs("roll"), [0.1])
    _expect_error(p, st, "outputs are calculated and cannot be set")
    st = p.raw_set_real(vrs("der(x)"), [0.1])
    _expect_error(p, st, "derivatives are calculated and cannot be set")
    p.init()
    st = p.raw("fmi2EnterInitializationMode")
    _expect_error(p, st, "not allowed in state stepComplete")
    p.fmu.terminate()
    st = p.raw("fmi2DoStep", c_double(0.0), c_double(0.005), 1)
    _expect_error(p, st, "not allowed in state terminated")
    p.free()
    m = Plant("me")
    m.init()
    st = m.raw("fmi2DoStep", c_double(0.0), c_double(0.005), 1)
    _expect_error(m, st, "only available for Co-Simulation")
    st = m.raw("fmi2SetContinuousStates", (c_double * 11)(), 11)
    _expect_error(m, st, "size 11, the model has 15")
    m.free()


def test_wrong_guid_is_refused_with_a_message():
    with pytest.raises(Exception, match="Failed to instantiate"):
        Plant("cs", guid="{00000000-0000-0000-0000-000000000000}")
    # the logger of the failed instance received the reason
    logs = []

    class Capture(Plant):
        def __init__(self):
            try:
                super().__init__("cs", guid="{bogus}")
            except Exception:
                pass

        def _log(self, env, name, status, category, message):
            logs.append(message.decode())

    Capture()
    assert any("wrong GUID" in m for m in logs)


@pytest.mark.parametrize("h", [0.0, -0.005, float("nan"), float("inf")])
def test_bad_step_sizes_are_errors(h):
    p = Plant("cs")
    _start(p)
    x0 = p.state()
    st = p.raw("fmi2DoStep", c_double(0.0), c_double(h), 1)
    _expect_error(p, st, "communicationStepSize must be finite and > 0")
    st = p.raw("fmi2DoStep", c_double(0.3), c_double(0.005), 1)
    _expect_error(p, st, "differs from the FMU time")
    assert np.array_equal(p.state(), x0)
    p.step(0.005)  # still usable
    p.free()


@pytest.mark.parametrize("t, off, ok", [(0.0, 0.9e-9, True), (0.0, -0.9e-9, True), (0.0, 1.1e-9, False),
                                       (0.0, -1.1e-9, False), (1.0, 1.9e-9, True), (1.0, -1.9e-9, True),
                                       (1.0, 2.1e-9, False), (1.0, -2.1e-9, False)])
def test_the_communication_point_may_differ_from_the_fmu_time_by_round_off_only(t, off, ok):
    """At most 1e-9 (1 + |t|) s either way: 1e-9 s at t = 0, 2e-9 s at t = 1 s."""
    p = Plant("cs")
    _start(p)
    if t:
        p.step(t)
    st = p.raw("fmi2DoStep", c_double(t + off), c_double(0.005), 1)
    if ok:
        assert st == 0, p.errors()
    else:
        _expect_error(p, st, "differs from the FMU time")
    p.free()


def test_diverging_step_is_discarded_and_rolled_back():
    p = Plant("cs")
    _start(p, x=make_state(roll=0.3, omega_body=(200.0, 0, 0)), h_internal=0.5)
    x0 = p.state()
    st = p.raw("fmi2DoStep", c_double(0.0), c_double(500.0), 1)
    assert st == 2  # fmi2Discard
    assert any("discarded" in m for m in p.errors())
    # logged as a warning, in the warning category (an error category would hide it from
    # a master that shows warnings only, and be filtered with the errors)
    warned = [(s, c) for s, c, m in p.logs if "discarded" in m]
    assert warned == [(2, "logStatusWarning")], p.logs
    assert np.array_equal(p.state(), x0)
    p.free()


def test_fuzz_1e5_random_api_calls_from_c():
    for seed in (1, 2, 3):
        s = fuzz_counts(plant_build(), 120000, seed)
        assert s["silent"] == 0, s
        assert s["calls"] + s["null_instance"] >= 100000
        assert s["error"] > 10000 and s["ok"] > 10000 and s["steps_ok"] > 100, s
        assert s["bad_guid"] > 0 and s["init_ok"] > 100
        # Integer and Boolean calls (seed, noise_on, sensor_sample; bad values too)
        assert min(s["integer_ok"], s["boolean_ok"]) > 150, s
        assert min(s["integer_error"], s["boolean_error"]) > 1000, s


def test_logging_categories():
    p = Plant("cs", logging_on=True)  # logCalls on
    p.init()
    assert any(c == "logCalls" for _, c, _ in p.logs)
    p.fmu.setDebugLogging(False, [])  # calls off, errors still on
    n = len(p.logs)
    p.step(0.005)
    assert len(p.logs) == n
    st = p.raw_set_real([10**6], [0.0])
    _expect_error(p, st, "unknown value reference")
    with pytest.raises(FMICallException):
        p.fmu.setDebugLogging(True, ["noSuchCategory"])
    assert "unknown log category" in p.errors()[-1]
    p.free()


def test_many_instances_at_once():
    ps = [Plant("cs", f"p{i}") for i in range(6)]
    for i, p in enumerate(ps):
        _start(p, tau=(0.01 * i, 0.0, 0.0))
    for _ in range(5):
        for p in ps:
            p.step(0.005)
    xs = np.array([p.state() for p in ps])
    assert len({tuple(x) for x in xs}) == 6
    for i, p in enumerate(ps):
        ref = python_rk4(X_TILT, np.array([0.01 * i, 0, 0]), PV, 0.005, 5)[-1]
        np.testing.assert_allclose(xs[i], ref, rtol=0, atol=1e-14)
        p.free()


def test_initial_unknowns_read_in_initialization_mode_are_the_initialized_ones():
    """FMI 2.0 section 3.2.3: an importer may read the held sensor readings before
    fmi2ExitInitializationMode; they are computed from the start state set so far (tilted:
    the accelerometer sees gravity off the body axis), and exiting keeps them."""
    p = Plant("cs")
    p.fmu.setupExperiment(startTime=0.0)
    p.fmu.enterInitializationMode()
    upright = p.get(*SENSORS)
    p.set(**dict(zip(X0_NAMES, X_TILT.tolist())))
    during = p.get(*SENSORS)
    p.fmu.exitInitializationMode()
    after = p.get(*SENSORS)
    np.testing.assert_array_equal(during, after)
    acc = list(SENSORS).index("sensor_acc_y")
    assert abs(during[acc] - upright[acc]) > 0.1       # roll 0.03 rad: g sin(roll) ~ 0.3 m/s^2
    p.free()
