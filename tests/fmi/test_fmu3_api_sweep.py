"""Every FMI 3.0 function of the shared layer (fmu/layer/fmi3_functions.c) the other tests do
not reach, called on the FMI 3.0 plant FMU: what the FMU does not provide is refused with
fmi3Error and one logged line naming the function and the reason (nothing without an
instance); the types it has no variables of accept an empty call and refuse a value
reference; the FMU-state functions round-trip; the counts are the model's.
"""

from __future__ import annotations

import ctypes
from ctypes import byref, c_bool, c_char_p, c_double, c_int, c_size_t, c_uint32, c_void_p

import pytest
from fmpy import read_model_description
from fmpy.fmi3 import FMU3Model, FMU3Slave
from test_fmu3 import plant3

pytestmark = pytest.mark.needs_cc

OK, ERROR = 0, 3
NO_DEPS = "not provided (the dependencies are in modelDescription.xml)"
NO_CLOCKS = "the FMU has no clocks (the controller's period is its fixed step)"


class Api:
    """One Model Exchange instance with a log, and the binary's functions by name (through a
    handle of our own: fmpy's declares argument types, these calls pass raw pointers)."""

    def __init__(self, kind=FMU3Model) -> None:
        self.b = plant3()
        self.md = read_model_description(str(self.b.fmu))
        self.log: list[tuple[int, str]] = []
        self.fmu = kind(guid=self.b.guid, unzipDirectory=str(self.b.unzipped),
                        modelIdentifier=self.b.model_identifier, instanceName="sweep")
        self.fmu.instantiate(loggingOn=True, logMessage=lambda env, status, category, message:
                             self.log.append((status, message.decode())))
        assert self.log[0][1].startswith("fmi2Instantiate: ")  # the one info line
        self.log.clear()
        self.c = self.fmu.component
        self.dll = ctypes.CDLL(str(self.b.binary))

    def call(self, fn: str, *args) -> int:
        f = getattr(self.dll, fn)
        f.restype = c_int
        return f(*args)

    def free(self) -> None:
        self.fmu.freeInstance()


@pytest.fixture
def api():
    a = Api()
    yield a
    a.free()


Z, N = c_size_t(0), c_void_p(None)
NOT_PROVIDED = [
    ("fmi3GetNumberOfVariableDependencies", (c_uint32(0), N), NO_DEPS),
    ("fmi3GetVariableDependencies", (c_uint32(0), N, N, N, N, Z), NO_DEPS),
    ("fmi3EnterConfigurationMode", (), "the FMU has no structural parameters"),
    ("fmi3ExitConfigurationMode", (), "the FMU has no structural parameters"),
    ("fmi3GetIntervalDecimal", (N, Z, N, N), NO_CLOCKS),
    ("fmi3GetIntervalFraction", (N, Z, N, N, N), NO_CLOCKS),
    ("fmi3GetShiftDecimal", (N, Z, N), NO_CLOCKS),
    ("fmi3GetShiftFraction", (N, Z, N, N), NO_CLOCKS),
    ("fmi3SetIntervalDecimal", (N, Z, N), NO_CLOCKS),
    ("fmi3SetIntervalFraction", (N, Z, N, N), NO_CLOCKS),
    ("fmi3SetShiftDecimal", (N, Z, N), NO_CLOCKS),
    ("fmi3SetShiftFraction", (N, Z, N, N), NO_CLOCKS),
    ("fmi3ActivateModelPartition", (c_uint32(0), c_double(0.0)), NO_CLOCKS),
    ("fmi3EnterStepMode", (), "no event mode (hasEventMode = false): fmi3ExitInitializationMode "
                              "enters step mode"),
    ("fmi3UpdateDiscreteStates", (N, N, N, N, N, N), "NULL argument"),
    ("fmi3CompletedIntegratorStep", (c_bool(False), N, N), "NULL argument"),
]


@pytest.mark.parametrize("fn, args, why", NOT_PROVIDED, ids=[n for n, _, _ in NOT_PROVIDED])
def test_what_the_fmu_does_not_provide_is_refused_with_its_reason(api, fn, args, why):
    assert api.call(fn, c_void_p(api.c), *args) == ERROR
    assert api.log == [(ERROR, f"{fn}: {why}")]
    assert api.call(fn, c_void_p(None), *args) == ERROR  # no instance: nothing to log to
    assert len(api.log) == 1


NO_TYPES = ["Float32", "Int8", "UInt8", "Int16", "UInt16", "UInt32", "Int64", "UInt64", "String"]


@pytest.mark.parametrize("name", NO_TYPES)
@pytest.mark.parametrize("op", ["Get", "Set"])
def test_types_without_variables_accept_nothing_and_refuse_a_reference(api, name, op):
    fn = f"fmi3{op}{name}"
    vr = (c_uint32 * 1)(7)
    assert api.call(fn, c_void_p(api.c), vr, c_size_t(0), N, Z) == OK and api.log == []
    assert api.call(fn, c_void_p(api.c), vr, c_size_t(1), N, Z) == ERROR
    assert api.log == [(ERROR, f"{fn}: unknown value reference 7 (the FMU has no {name} "
                               "variables)")]
    assert api.call(fn, c_void_p(None), vr, c_size_t(0), N, Z) == ERROR


@pytest.mark.parametrize("fn, args", [
    ("fmi3GetBinary", (N, N, Z)), ("fmi3SetBinary", (N, N, Z)),
    ("fmi3GetClock", (N,)), ("fmi3SetClock", (N,))])
def test_binary_and_clock_values_do_not_exist(api, fn, args):
    vr = (c_uint32 * 1)(3)
    name = "Binary" if "Binary" in fn else "Clock"
    assert api.call(fn, c_void_p(api.c), vr, c_size_t(0), *args) == OK
    assert api.call(fn, c_void_p(api.c), vr, c_size_t(1), *args) == ERROR
    assert api.log == [(ERROR, f"{fn}: unknown value reference 3 (the FMU has no {name} "
                               "variables)")]


def test_version_logging_reset_counts_and_discrete_states(api):
    f = api.dll.fmi3GetVersion
    f.restype = c_char_p
    assert f() == b"3.0"
    assert api.call("fmi3SetDebugLogging", c_void_p(api.c), c_bool(True), Z, N) == OK
    n = c_size_t(99)
    assert api.call("fmi3GetNumberOfEventIndicators", c_void_p(api.c), byref(n)) == OK
    assert n.value == 0
    assert api.call("fmi3GetNumberOfContinuousStates", c_void_p(api.c), byref(n)) == OK
    derivs = [v for v in api.md.modelVariables if v.derivative is not None]
    assert n.value == len(derivs) == 15  # 12 model states and 3 wheel angles
    for fn in ("fmi3GetNumberOfEventIndicators", "fmi3GetNumberOfContinuousStates"):
        assert api.call(fn, c_void_p(api.c), N) == ERROR
        assert api.call(fn, c_void_p(None), byref(n)) == ERROR
    assert api.call("fmi3EvaluateDiscreteStates", c_void_p(api.c)) == OK
    assert api.call("fmi3EvaluateDiscreteStates", c_void_p(None)) == ERROR
    assert api.call("fmi3Reset", c_void_p(api.c)) == OK
    assert [(st, m.split(":")[0]) for st, m in api.log] == [(OK, "fmi2SetDebugLogging"),
                                                             (OK, "fmi2Reset")]


def test_int32_values_read_through_the_fmi2_integers(api):
    ints = {v.name: v.valueReference for v in api.md.modelVariables if v.type == "Int32"}
    assert "seed" in ints
    api.fmu.enterInitializationMode()
    api.fmu.setInt32([ints["seed"]], [12345])
    assert api.fmu.getInt32([ints["seed"]]) == [12345]
    vr = (c_uint32 * 1)(ints["seed"])
    out = (ctypes.c_int32 * 2)()
    assert api.call("fmi3GetInt32", c_void_p(api.c), vr, c_size_t(1), out, c_size_t(2)) == ERROR
    assert "fmi3GetInt32: nValues = 2 but 1 value references" in api.log[-1][1]


def test_fmu_state_round_trip_through_the_fmi3_names(api):
    """Get, serialise, change the states, deserialise and set: the states come back."""
    vr = {v.name: v.valueReference for v in api.md.modelVariables}
    api.fmu.enterInitializationMode()
    api.fmu.setFloat64([vr["x0_x"]], [0.25])
    api.fmu.exitInitializationMode()
    api.fmu.enterContinuousTimeMode()
    buf = (c_double * 15)()

    def states() -> list[float]:
        api.fmu.getContinuousStates(buf, 15)
        return list(buf)

    x = states()
    assert x[0] == 0.25
    state = api.fmu.getFMUState()
    data = api.fmu.serializeFMUState(state)
    api.fmu.freeFMUState(state)
    api.fmu.setContinuousStates((c_double * 15)(*[v + 1.0 for v in x]), 15)
    assert api.fmu.getFloat64([vr["x"]]) == [1.25]
    restored = api.fmu.deserializeFMUState(data)
    api.fmu.setFMUState(restored)
    api.fmu.freeFMUState(restored)
    assert states() == x
    assert all(status == OK for status, _ in api.log)


def test_scheduled_execution_is_refused_with_a_message():
    b = plant3()
    got = []
    cb = ctypes.CFUNCTYPE(None, c_void_p, c_int, c_char_p, c_char_p)(
        lambda env, status, cat, msg: got.append((status, cat.decode(), msg.decode())))
    f = ctypes.CDLL(str(b.binary)).fmi3InstantiateScheduledExecution
    f.restype = c_void_p
    assert f(b"s", b.guid.encode(), N, c_bool(False), c_bool(True), N, cb, N, N, N) is None
    assert got == [(ERROR, "logStatusError",
                    "fmi3InstantiateScheduledExecution: scheduled execution is not provided")]


def test_a_step_without_its_result_pointers_is_refused():
    a = Api(FMU3Slave)
    try:
        a.fmu.enterInitializationMode()
        a.fmu.exitInitializationMode()
        args = (c_double(0.0), c_double(0.005), c_bool(True))
        assert a.call("fmi3DoStep", c_void_p(a.c), *args, N, N, N, N) == ERROR
        assert a.log[-1] == (ERROR, "fmi3DoStep: NULL argument")
        b = c_bool(False)
        t = c_double(-1.0)
        assert a.call("fmi3DoStep", c_void_p(a.c), *args, byref(b), byref(c_bool()), byref(c_bool()),
                      byref(t)) == OK
        assert t.value == pytest.approx(0.005, abs=1e-15)
        assert a.call("fmi3DoStep", c_void_p(None), c_double(0.005), c_double(0.005), c_bool(True),
                      byref(b), byref(b), byref(b), byref(t)) == ERROR
    finally:
        a.free()
