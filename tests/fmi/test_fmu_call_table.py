"""The shared layer's call table against the FMI 2.0 state tables (sections 3.2.3, 4.2.4).

Every call below is made in every reachable state of a fresh instance, with arguments
that are valid wherever the call is allowed: it must succeed exactly where the expected
table (written here from the standard) says so, and otherwise return fmi2Error with a
logged "not allowed in state <state>" / "only available for" message and change nothing.
Deliberate deviations from the standard: no value getter or directional derivative in
the error state (the values may be NaN there).
"""

from __future__ import annotations

from ctypes import byref, c_char, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p

import numpy as np
import pytest
from _fmu_support import NXW, STATES, X0_NAMES, Plant, vrs
from fmpy.fmi2 import fmi2EventInfo

from ballbot_casadi.model.numeric import make_state

pytestmark = pytest.mark.needs_cc

CS_STATES = ("instantiated", "initializationMode", "stepComplete", "stepFailed", "terminated",
             "error")
ME_STATES = ("instantiated", "initializationMode", "eventMode", "continuousTimeMode",
             "terminated", "error")


def _enter(kind: str, state: str) -> Plant:
    """A fresh instance in the given state."""
    p = Plant(kind, name=f"{kind}-{state}")
    if state == "instantiated":
        return p
    p.fmu.setupExperiment(startTime=0.0)
    p.fmu.enterInitializationMode()
    if state == "initializationMode":
        return p
    if state == "stepFailed":  # a diverging step is discarded (Co-Simulation)
        x = make_state(roll=0.3, omega_body=(200.0, 0.0, 0.0))
        p.set(**dict(zip(X0_NAMES, x.tolist())), h_internal=0.5)
        p.fmu.exitInitializationMode()
        assert p.raw("fmi2DoStep", c_double(0.0), c_double(500.0), 1) == 2  # fmi2Discard
        return p
    if state == "error":  # derivatives overflow: exiting initialisation fails
        x = make_state().tolist()
        x[STATES.index("dq1")] = 1e200
        p.set(**dict(zip(X0_NAMES, x)))
        assert p.raw("fmi2ExitInitializationMode") == 3
        assert "NaN or Inf" in p.errors()[-1]
        return p
    p.fmu.exitInitializationMode()
    if state == "continuousTimeMode":
        p.fmu.enterContinuousTimeMode()
    elif state == "terminated":
        p.fmu.terminate()
    return p


def _calls():
    """name -> function(plant) -> status, with arguments valid where the call is allowed."""
    one = (c_uint * 1)
    info = fmi2EventInfo()
    b1, b2 = c_int(), c_int()
    return {
        "fmi2SetupExperiment": lambda p: p.raw("fmi2SetupExperiment", 0, c_double(0.0),
                                               c_double(0.0), 0, c_double(0.0)),
        "fmi2EnterInitializationMode": lambda p: p.raw("fmi2EnterInitializationMode"),
        "fmi2ExitInitializationMode": lambda p: p.raw("fmi2ExitInitializationMode"),
        "fmi2Terminate": lambda p: p.raw("fmi2Terminate"),
        "fmi2Reset": lambda p: p.raw("fmi2Reset"),
        "fmi2GetReal": lambda p: p.raw("fmi2GetReal", one(*vrs("x")), 1, (c_double * 1)()),
        "fmi2GetInteger": lambda p: p.raw("fmi2GetInteger", one(*vrs("seed")), 1,
                                          (c_int * 1)()),
        "fmi2GetBoolean": lambda p: p.raw("fmi2GetBoolean", one(*vrs("noise_on")), 1,
                                          (c_int * 1)()),
        "fmi2SetReal": lambda p: p.raw("fmi2SetReal", one(*vrs("tau0")), 1,
                                       (c_double * 1)(0.1)),
        "fmi2GetDirectionalDerivative": lambda p: p.raw(
            "fmi2GetDirectionalDerivative", one(*vrs("der(dx)")), 1, one(*vrs("tau0")), 1,
            (c_double * 1)(1.0), (c_double * 1)()),
        "fmi2DoStep": lambda p: p.raw("fmi2DoStep", c_double(0.0), c_double(0.005), 1),
        "fmi2GetStatus": lambda p: p.raw("fmi2GetStatus", 0, byref(c_int())),
        "fmi2EnterEventMode": lambda p: p.raw("fmi2EnterEventMode"),
        "fmi2NewDiscreteStates": lambda p: p.raw("fmi2NewDiscreteStates", byref(info)),
        "fmi2EnterContinuousTimeMode": lambda p: p.raw("fmi2EnterContinuousTimeMode"),
        "fmi2CompletedIntegratorStep": lambda p: p.raw("fmi2CompletedIntegratorStep", 1,
                                                       byref(b1), byref(b2)),
        "fmi2SetTime": lambda p: p.raw("fmi2SetTime", c_double(0.0)),
        "fmi2GetDerivatives": lambda p: p.raw("fmi2GetDerivatives", (c_double * NXW)(), NXW),
        "fmi2GetContinuousStates": lambda p: p.raw("fmi2GetContinuousStates",
                                                   (c_double * NXW)(), NXW),
        "fmi2GetFMUstate": _get_state,
        # the remaining calls, each with no values (nvr = 0) where it takes values, so that
        # only the call table can refuse them
        "fmi2SetDebugLogging": lambda p: p.raw("fmi2SetDebugLogging", 0, c_size_t(0), None),
        "fmi2SetInteger": lambda p: p.raw("fmi2SetInteger", one(), c_size_t(0), (c_int * 1)()),
        "fmi2SetBoolean": lambda p: p.raw("fmi2SetBoolean", one(), c_size_t(0), (c_int * 1)()),
        "fmi2SetString": lambda p: p.raw("fmi2SetString", one(), c_size_t(0), (c_char_p * 1)()),
        "fmi2GetString": lambda p: p.raw("fmi2GetString", one(), c_size_t(0), (c_char_p * 1)()),
        "fmi2SetFMUstate": lambda p: _with_state(p, lambda s: p.raw("fmi2SetFMUstate", s)),
        "fmi2FreeFMUstate": lambda p: p.raw("fmi2FreeFMUstate", byref(c_void_p())),
        "fmi2SerializedFMUstateSize": lambda p: _with_state(
            p, lambda s: p.raw("fmi2SerializedFMUstateSize", s, byref(c_size_t()))),
        "fmi2SerializeFMUstate": lambda p: _with_state(p, lambda s: _serialize(p, s)[0]),
        "fmi2DeSerializeFMUstate": lambda p: _with_state(p, lambda s: _deserialize(p, s)),
        "fmi2GetEventIndicators": lambda p: p.raw("fmi2GetEventIndicators", None, c_size_t(0)),
        "fmi2GetNominalsOfContinuousStates": lambda p: p.raw(
            "fmi2GetNominalsOfContinuousStates", (c_double * NXW)(), c_size_t(NXW)),
        "fmi2SetContinuousStates": lambda p: p.raw(
            "fmi2SetContinuousStates", (c_double * NXW)(*make_state(), 0.0, 0.0, 0.0),
            c_size_t(NXW)),
        "fmi2SetRealInputDerivatives": lambda p: p.raw(
            "fmi2SetRealInputDerivatives", one(), c_size_t(0), (c_int * 1)(), (c_double * 1)()),
        "fmi2GetRealOutputDerivatives": lambda p: p.raw(
            "fmi2GetRealOutputDerivatives", one(), c_size_t(0), (c_int * 1)(), (c_double * 1)()),
        "fmi2CancelStep": lambda p: p.raw("fmi2CancelStep"),
        "fmi2GetRealStatus": lambda p: p.raw("fmi2GetRealStatus", 2, byref(c_double())),
        "fmi2GetIntegerStatus": lambda p: p.raw("fmi2GetIntegerStatus", 2, byref(c_int())),
        "fmi2GetBooleanStatus": lambda p: p.raw("fmi2GetBooleanStatus", 3, byref(c_int())),
        "fmi2GetStringStatus": lambda p: p.raw("fmi2GetStringStatus", 2, byref(c_char_p())),
    }


def _get_state(p: Plant) -> int:
    s = c_void_p()
    st = p.raw("fmi2GetFMUstate", byref(s))
    if st == 0:
        p.raw("fmi2FreeFMUstate", byref(s))
    return st


def _with_state(p: Plant, call) -> int:
    """``call(state)`` on an FMU state of ``p`` taken just before (fmi2GetFMUstate is allowed
    in every state), the state freed after."""
    s = c_void_p()
    assert p.raw("fmi2GetFMUstate", byref(s)) == 0
    try:
        return call(s)
    finally:
        p.raw("fmi2FreeFMUstate", byref(s))


def _serialize(p: Plant, s: c_void_p) -> tuple[int, bytes]:
    """Status of fmi2SerializeFMUstate and the bytes (the size is asked without the table)."""
    n = c_size_t()
    p.raw("fmi2SerializedFMUstateSize", s, byref(n))
    buf = (c_char * n.value)()
    st = p.raw("fmi2SerializeFMUstate", s, buf, n)
    return st, bytes(buf)


def _deserialize(p: Plant, s: c_void_p) -> int:
    data = _serialize(p, s)[1]
    out = c_void_p()
    st = p.raw("fmi2DeSerializeFMUstate", (c_char * len(data))(*data), c_size_t(len(data)),
               byref(out))
    if st == 0:
        p.raw("fmi2FreeFMUstate", byref(out))
    return st


# expected: 1 allowed, 0 refused; "-" not for this interface; "e" allowed by the call table
# but answered with an error (a feature the FMU does not provide)
CS_TABLE = {  # instantiated, initializationMode, stepComplete, stepFailed, terminated, error
    # (stepFailed, FMI 2.0: getters, status, terminate, reset, FMU states; no setter or step)
    "fmi2SetupExperiment": "100000",
    "fmi2EnterInitializationMode": "100000",
    "fmi2ExitInitializationMode": "010000",
    "fmi2Terminate": "001100",
    "fmi2Reset": "111111",
    "fmi2GetReal": "011110",
    "fmi2GetInteger": "011110",
    "fmi2GetBoolean": "011110",
    "fmi2SetReal": "111000",
    "fmi2GetDirectionalDerivative": "011110",
    "fmi2DoStep": "001000",
    "fmi2GetStatus": "001110",
    "fmi2GetFMUstate": "111111",
    "fmi2SetDebugLogging": "111111",
    "fmi2SetInteger": "111000",
    "fmi2SetBoolean": "111000",
    "fmi2SetString": "111000",
    "fmi2GetString": "011110",
    "fmi2SetFMUstate": "111111",
    "fmi2FreeFMUstate": "111111",
    "fmi2SerializedFMUstateSize": "111111",
    "fmi2SerializeFMUstate": "111111",
    "fmi2DeSerializeFMUstate": "111111",
    "fmi2SetRealInputDerivatives": "111000",
    "fmi2GetRealOutputDerivatives": "001110",
    "fmi2CancelStep": "00ee00",
    "fmi2GetRealStatus": "001110",
    "fmi2GetIntegerStatus": "00eee0",
    "fmi2GetBooleanStatus": "001110",
    "fmi2GetStringStatus": "00eee0",
    "fmi2GetEventIndicators": "-", "fmi2GetNominalsOfContinuousStates": "-",
    "fmi2SetContinuousStates": "-",
    "fmi2EnterEventMode": "-", "fmi2NewDiscreteStates": "-", "fmi2SetTime": "-",
    "fmi2EnterContinuousTimeMode": "-", "fmi2CompletedIntegratorStep": "-",
    "fmi2GetDerivatives": "-", "fmi2GetContinuousStates": "-",
}
ME_TABLE = {  # instantiated, initializationMode, eventMode, continuousTimeMode, terminated, error
    "fmi2SetupExperiment": "100000",
    "fmi2EnterInitializationMode": "100000",
    "fmi2ExitInitializationMode": "010000",
    "fmi2Terminate": "001100",
    "fmi2Reset": "111111",
    "fmi2GetReal": "011110",
    "fmi2GetInteger": "011110",
    "fmi2GetBoolean": "011110",
    "fmi2SetReal": "111100",
    "fmi2GetDirectionalDerivative": "011110",
    "fmi2EnterEventMode": "001100",
    "fmi2NewDiscreteStates": "001000",
    "fmi2EnterContinuousTimeMode": "001000",
    "fmi2CompletedIntegratorStep": "000100",
    "fmi2SetTime": "001100",
    "fmi2GetDerivatives": "011110",
    "fmi2GetContinuousStates": "011110",
    "fmi2GetFMUstate": "111111",
    "fmi2SetDebugLogging": "111111",
    "fmi2SetInteger": "111100",
    "fmi2SetBoolean": "111100",
    "fmi2SetString": "111100",
    "fmi2GetString": "011110",
    "fmi2SetFMUstate": "111111",
    "fmi2FreeFMUstate": "111111",
    "fmi2SerializedFMUstateSize": "111111",
    "fmi2SerializeFMUstate": "111111",
    "fmi2DeSerializeFMUstate": "111111",
    "fmi2GetEventIndicators": "011110",
    "fmi2GetNominalsOfContinuousStates": "111110",
    "fmi2SetContinuousStates": "000100",
    "fmi2DoStep": "-", "fmi2GetStatus": "-",
    "fmi2SetRealInputDerivatives": "-", "fmi2GetRealOutputDerivatives": "-",
    "fmi2CancelStep": "-", "fmi2GetRealStatus": "-", "fmi2GetIntegerStatus": "-",
    "fmi2GetBooleanStatus": "-", "fmi2GetStringStatus": "-",
}


@pytest.mark.parametrize("kind, states, table", [("cs", CS_STATES, CS_TABLE),
                                                  ("me", ME_STATES, ME_TABLE)])
def test_calls_are_allowed_exactly_in_the_states_of_the_standard(kind, states, table):
    calls = _calls()
    assert set(table) == set(calls)
    checked = 0
    for name, row in table.items():
        for i, state in enumerate(states):
            p = _enter(kind, state)
            before = p.snapshot() if state not in ("instantiated", "error") else None
            n_err = len(p.errors())
            st = calls[name](p)
            if row == "-":
                assert st == 3, (name, state)
                assert "only available for" in p.errors()[-1]
            elif row[i] == "1":
                assert st in (0, 1), (name, state, st, p.errors()[-1:])
            elif row[i] == "e":  # past the table, refused by the call itself
                assert st == 3, (name, state, st)
                assert len(p.errors()) == n_err + 1
                assert "not allowed in state" not in p.errors()[-1], p.errors()[-1]
                assert p.errors()[-1].startswith(name), p.errors()[-1]
            else:
                assert st == 3, (name, state, st)
                assert len(p.errors()) == n_err + 1
                assert f"not allowed in state {state}" in p.errors()[-1], p.errors()[-1]
                if before is not None:
                    assert repr(p.snapshot()) == repr(before)  # refused: nothing changed
            checked += 1
            p.free()
    assert checked == len(table) * len(states)


def test_settability_by_kind_and_state():
    """Inputs between steps, parameters and states only before initialisation ends (CS),
    states also in ME event/continuous-time mode; calculated and local values never."""
    cs = _enter("cs", "stepComplete")
    for name, ok in (("tau0", True), ("Mb", False), ("q1", False), ("roll", False),
                     ("sensor_acc_x", False), ("sensor_gyro_bias_x", False),
                     ("der(q1)", False)):
        st = cs.raw_set_real(vrs(name), [0.0])
        assert (st == 0) == ok, name
    assert "local variables are internal states" in cs.errors()[-2]
    for fn, name in (("fmi2SetInteger", "seed"), ("fmi2SetBoolean", "noise_on"),
                     ("fmi2SetInteger", "sensor_sample")):
        assert cs.raw(fn, (c_uint * 1)(*vrs(name)), 1, (c_int * 1)(1)) == 3, name
    assert "cannot set 'sensor_sample'" in cs.errors()[-1]
    cs.free()
    me = _enter("me", "continuousTimeMode")
    assert me.raw_set_real(vrs("q1", "tau0"), [0.0, 0.2]) == 0
    assert me.raw_set_real(vrs("Mb"), [20.0]) == 3
    me.free()
    ini = _enter("cs", "initializationMode")
    assert ini.raw("fmi2SetInteger", (c_uint * 1)(*vrs("seed")), 1, (c_int * 1)(3)) == 0
    assert ini.raw("fmi2SetBoolean", (c_uint * 1)(*vrs("noise_on")), 1, (c_int * 1)(1)) == 0
    ini.fmu.exitInitializationMode()
    assert ini.get_int("seed") == [3] and ini.get_bool("noise_on") == [True]
    assert np.isfinite(ini.get("sensor_acc_z")[0])
    ini.free()


def test_type_mismatched_value_references_are_unknown():
    p = _enter("cs", "stepComplete")
    st = p.raw("fmi2GetInteger", (c_uint * 1)(*vrs("x")), 1, (c_int * 1)())
    assert st == 3 and "no Integer variable has it" in p.errors()[-1]
    st = p.raw("fmi2GetBoolean", (c_uint * 1)(*vrs("seed")), 1, (c_int * 1)())
    assert st == 3 and "no Boolean variable has it" in p.errors()[-1]
    st = p.raw("fmi2GetReal", (c_uint * 1)(*vrs("noise_on")), 1, (c_double * 1)())
    assert st == 3 and "no Real variable has it" in p.errors()[-1]
    st = p.raw("fmi2GetString", (c_uint * 1)(0), 1, (c_char_p * 1)())
    assert st == 3 and "no String variable has it" in p.errors()[-1]
    p.free()
