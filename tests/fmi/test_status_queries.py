"""The co-simulation status queries answer exactly what they provide: fmi2GetStatus only
fmi2DoStepStatus, fmi2GetRealStatus only fmi2LastSuccessfulTime, fmi2GetBooleanStatus only
fmi2Terminated, each with a non-NULL value; every other kind, a NULL value, and the
integer and string queries are refused with fmi2Error and their own logged line, the
value left untouched.  What is provided reads the instance: the time of the last step,
not terminated."""

from __future__ import annotations

from ctypes import byref, c_char_p, c_double, c_int

import pytest
from _fmu_support import Plant

pytestmark = pytest.mark.needs_cc

OK, ERROR = 0, 3
KINDS = {"fmi2DoStepStatus": 0, "fmi2PendingStatus": 1, "fmi2LastSuccessfulTime": 2, "fmi2Terminated": 3}
QUERIES = {  # function -> (value type, the one kind provided, its refusal line)
    "fmi2GetStatus": (c_int, "fmi2DoStepStatus",
                      "fmi2GetStatus: only fmi2DoStepStatus is provided (non-NULL value)"),
    "fmi2GetRealStatus": (c_double, "fmi2LastSuccessfulTime",
                          "fmi2GetRealStatus: only fmi2LastSuccessfulTime is provided"),
    "fmi2GetBooleanStatus": (c_int, "fmi2Terminated",
                             "fmi2GetBooleanStatus: only fmi2Terminated is provided"),
    "fmi2GetIntegerStatus": (c_int, None, "fmi2GetIntegerStatus: no integer status is provided"),
    "fmi2GetStringStatus": (c_char_p, None, "fmi2GetStringStatus: no string status is provided"),
}


@pytest.fixture
def stepped():
    p = Plant("cs", name="status")
    p.init()
    p.step(0.01, 3)
    yield p
    p.free()


@pytest.mark.parametrize("query", QUERIES)
def test_each_query_answers_only_its_kind(stepped, query):
    kind_type, provided, line = QUERIES[query]
    for kind, code in KINDS.items():
        value = kind_type(-7) if kind_type is not c_char_p else c_char_p(b"untouched")
        before = len(stepped.errors())
        status = stepped.raw(query, code, byref(value))
        if kind == provided:
            assert status == OK, (query, kind, stepped.errors()[before:])
        else:
            assert status == ERROR, (query, kind)
            assert stepped.errors()[before:] == [line], (query, kind)
            if kind_type is c_char_p:
                assert value.value == b"untouched"
            else:
                assert value.value == -7, (query, kind)


@pytest.mark.parametrize("query", ["fmi2GetStatus", "fmi2GetRealStatus", "fmi2GetBooleanStatus"])
def test_a_null_value_is_refused(stepped, query):
    _, provided, line = QUERIES[query]
    before = len(stepped.errors())
    assert stepped.raw(query, KINDS[provided], None) == ERROR
    assert stepped.errors()[before:] == [line]


def test_what_is_provided_reads_the_instance(stepped):
    status, t, term = c_int(-1), c_double(-1.0), c_int(-1)
    assert stepped.raw("fmi2GetStatus", KINDS["fmi2DoStepStatus"], byref(status)) == OK
    assert stepped.raw("fmi2GetRealStatus", KINDS["fmi2LastSuccessfulTime"], byref(t)) == OK
    assert stepped.raw("fmi2GetBooleanStatus", KINDS["fmi2Terminated"], byref(term)) == OK
    assert (status.value, term.value) == (OK, 0)
    assert t.value == pytest.approx(0.03, abs=1e-12)


def test_without_setup_experiment_and_after_reset_time_starts_at_zero():
    """fmi2SetupExperiment is optional here: the experiment then starts at t = 0 (the
    first step's communication point), and fmi2Reset returns to it."""
    p = Plant("cs", name="no-setup")
    try:
        t = c_double(-1.0)
        assert p.raw("fmi2EnterInitializationMode") == OK and p.raw("fmi2ExitInitializationMode") == OK
        assert p.raw("fmi2DoStep", c_double(0.0), c_double(0.01), 1) == OK, p.errors()
        assert p.raw("fmi2GetRealStatus", KINDS["fmi2LastSuccessfulTime"], byref(t)) == OK
        assert t.value == 0.01
        assert p.raw("fmi2Reset") == OK
        assert p.raw("fmi2EnterInitializationMode") == OK and p.raw("fmi2ExitInitializationMode") == OK
        assert p.raw("fmi2DoStep", c_double(0.0), c_double(0.02), 1) == OK, p.errors()
        assert p.raw("fmi2GetRealStatus", KINDS["fmi2LastSuccessfulTime"], byref(t)) == OK
        assert t.value == 0.02
    finally:
        p.free()
