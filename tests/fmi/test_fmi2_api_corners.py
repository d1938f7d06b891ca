"""FMI 2.0 corners of the shared layer no other test reaches: the platform and version
strings, an instantiation without memory callbacks or of an unknown interface type (refused
with one logged line, no instance), and a NULL value-reference array with a count."""

from __future__ import annotations

import ctypes
from ctypes import c_char_p, c_double, c_int, c_size_t, c_void_p

import pytest
from _fmu_support import Plant, plant_build

pytestmark = pytest.mark.needs_cc


def _dll():
    return ctypes.CDLL(str(plant_build().binary))


def test_platform_and_version_strings():
    dll = _dll()
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
    from fmpy import calloc, free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )

    got = []
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(
        lambda env, name, status, category, msg: got.append((status, msg.decode())))
    if missing != "allocateMemory":
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    if missing != "freeMemory":
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    f = _dll().fmi2Instantiate
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
