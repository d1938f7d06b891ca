"""FMI 2.0 corners of the shared layer no other test reaches: the platform and version
strings, an instantiation without memory callbacks or of an unknown interface type (refused
with one logged line, no instance), a NULL value-reference array with a count, and the
Model Exchange calls' refusals: NULL arrays and pointers, wrong counts, a non-finite time or
state (nothing of it set), a non-finite seed and a directional derivative that overflows."""

from __future__ import annotations

import ctypes
from ctypes import c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p

import pytest
from _fmu_support import ALL_STATES, Plant, fmi2_callbacks, plant_build, plant_dll, vrs

pytestmark = pytest.mark.needs_cc


def test_platform_and_version_strings():
    dll = plant_dll()
    for fn, want in (("fmi2GetTypesPlatform", b"default"), ("fmi2GetVersion", b"2.0")):
        f = getattr(dll, fn)
        f.restype = c_char_p
        assert f() == want


@pytest.mark.parametrize("fmu_type, missing, message", [
    (1, "allocateMemory", "fmi2Instantiate: allocateMemory/freeMemory is NULL"),
    (1, "freeMemory", "fmi2Instantiate: allocateMemory/freeMemory is NULL"),
    (7, None, "fmi2Instantiate: unknown fmuType 7"),
    (-1, None, "fmi2Instantiate: unknown fmuType -1"),
])
def test_an_instance_the_layer_cannot_make_is_refused_with_a_line(fmu_type, missing, message):
    got = []
    cb = fmi2_callbacks(lambda env, name, status, category, msg: got.append((status, msg.decode())),
                        allocate=missing != "allocateMemory", free=missing != "freeMemory")
    f = plant_dll().fmi2Instantiate
    f.restype = c_void_p
    inst = f(b"corner", c_int(fmu_type), plant_build().guid.encode(), b"", ctypes.byref(cb),
             c_int(0), c_int(0))
    assert inst is None
    assert got == [(3, message)]


def test_a_null_value_reference_array_with_a_count_is_refused():
    p = Plant("cs", name="nullvr")
    try:
        p.init()
        buf = (c_double * 2)()
        for n in (2, 1):
            assert p.raw("fmi2GetReal", None, c_size_t(n), buf) == 3
            assert p.errors()[-1] == f"fmi2GetReal: vr is NULL but nvr = {n}"
        assert p.raw("fmi2GetReal", None, c_size_t(0), buf) == 0  # nothing asked: nothing read
    finally:
        p.free()


def _me_plant(name: str) -> Plant:
    p = Plant("me", name=name)
    p.init()
    return p


def test_model_exchange_calls_refuse_null_and_non_finite_arguments():
    p = _me_plant("mecorners")
    try:
        nx = len(ALL_STATES)
        assert p.raw("fmi2CompletedIntegratorStep", c_int(1), None, None) == 3
        assert p.errors()[-1] == "fmi2CompletedIntegratorStep: NULL argument"
        flag = c_int(7)
        assert p.raw("fmi2CompletedIntegratorStep", c_int(1), ctypes.byref(flag), None) == 3
        assert p.raw("fmi2SetTime", c_double(float("nan"))) == 3
        assert p.errors()[-1] == "fmi2SetTime: time must be finite, got nan"
        assert p.raw("fmi2SetTime", c_double(float("-inf"))) == 3
        assert p.errors()[-1] == "fmi2SetTime: time must be finite, got -inf"
        for fn in ("fmi2SetContinuousStates", "fmi2GetContinuousStates",
                   "fmi2GetDerivatives", "fmi2GetNominalsOfContinuousStates"):
            assert p.raw(fn, None, c_size_t(nx)) == 3
            assert p.errors()[-1] == f"{fn}: NULL array"
            assert p.raw(fn, (c_double * nx)(), c_size_t(nx - 1)) == 3
            assert p.errors()[-1] == f"{fn}: size {nx - 1}, the model has {nx}"
        x = (c_double * nx)(*p.get(*ALL_STATES))
        before = list(x)
        x[4] = float("inf")
        assert p.raw("fmi2SetContinuousStates", x, c_size_t(nx)) == 3
        assert p.errors()[-1] == (f"fmi2SetContinuousStates: state '{ALL_STATES[4]}' must be "
                                  "finite, got inf")
        assert list(p.get(*ALL_STATES)) == before  # nothing of the refused vector was set
        # the instance is still usable, and the counts above were the only wrong thing
        flags = (c_int(5), c_int(5))
        assert p.raw("fmi2CompletedIntegratorStep", c_int(1), ctypes.byref(flags[0]),
                     ctypes.byref(flags[1])) == 0
        assert (flags[0].value, flags[1].value) == (0, 0)
        nominal = (c_double * nx)()
        assert p.raw("fmi2GetNominalsOfContinuousStates", nominal, c_size_t(nx)) == 0
        assert list(nominal) == [1.0] * nx
        assert p.raw("fmi2GetEventIndicators", (c_double * 1)(), c_size_t(1)) == 3
        assert p.errors()[-1] == ("fmi2GetEventIndicators: the model has no event indicators, "
                                  "got ni = 1")
        assert p.raw("fmi2EnterEventMode") == 0
        assert p.raw("fmi2NewDiscreteStates", None) == 3
        assert p.errors()[-1] == "fmi2NewDiscreteStates: eventInfo is NULL"
    finally:
        p.free()


def test_directional_derivatives_refuse_null_seeds_non_finite_seeds_and_overflow():
    p = _me_plant("dircorners")
    try:
        der, known = vrs("der(dx)"), vrs("q2", "tau0")
        out = (c_double * 1)()
        unk = (c_uint * 1)(*der)
        kn = (c_uint * 2)(*known)
        f = "fmi2GetDirectionalDerivative"
        for n_known in (1, 2):  # one value is an array too
            assert p.raw(f, unk, 1, kn, n_known, None, out) == 3
            assert p.errors()[-1] == f"{f}: NULL value array"
            assert p.raw(f, unk, 1, kn, n_known, (c_double * 2)(1.0, 1.0), None) == 3
            assert p.errors()[-1] == f"{f}: NULL value array"
        assert p.raw(f, unk, 1, kn, 2, (c_double * 2)(1.0, float("nan")), out) == 3
        assert p.errors()[-1] == f"{f}: seed[1] is not finite"
        # d der(dx) / d q2 is of order g (a pitch accelerates the ball): 1e308 of it overflows
        assert p.raw(f, unk, 1, kn, 2, (c_double * 2)(1.0, 0.0), out) == 0
        assert abs(out[0]) > 1.0
        assert p.raw(f, unk, 1, kn, 2, (c_double * 2)(1e308, 0.0), out) == 3
        assert p.errors()[-1] == f"{f}: the directional derivative is not finite"
    finally:
        p.free()
