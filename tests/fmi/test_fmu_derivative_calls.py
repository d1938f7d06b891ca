"""The plant FMU's input/output derivative calls (FMI 2.0 section 4.2.1): the FMU declares
``canInterpolateInputs = false`` and ``maxOutputDerivativeOrder = 0``, so an empty call is
a no-op that succeeds and a call with one value reference is refused with fmi2Error and a
logged reason."""

from __future__ import annotations

from ctypes import c_double, c_int, c_uint

import pytest
from _fmu_support import Plant, vrs

pytestmark = pytest.mark.needs_cc

CALLS = {
    "fmi2SetRealInputDerivatives": ("tau0", "not supported (canInterpolateInputs = false)"),
    "fmi2GetRealOutputDerivatives": ("x", "not supported (maxOutputDerivativeOrder = 0)"),
}


@pytest.mark.parametrize("fname", sorted(CALLS))
def test_derivative_calls_accept_nothing_and_refuse_one_reference(fname):
    var, reason = CALLS[fname]
    p = Plant("cs", name=f"deriv-{fname}")
    try:
        p.fmu.setupExperiment(startTime=0.0)
        p.fmu.enterInitializationMode()
        p.fmu.exitInitializationMode()
        vr, order, value = (c_uint * 1)(*vrs(var)), (c_int * 1)(1), (c_double * 1)(0.25)
        assert p.raw(fname, vr, 0, order, value) == 0  # fmi2OK: nothing asked
        assert p.errors() == []
        assert p.raw(fname, vr, 1, order, value) == 3  # fmi2Error
        assert p.errors() == [f"{fname}: {reason}"]
    finally:
        p.free()
