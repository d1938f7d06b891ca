"""Reading a libcosim time series (fmi.masters.libcosim._samples) against a stand-in of
libcosim's C call: the n + 1 samples of steps 0 .. n come back as floats (Reals through the
real call, Integers through the integer one); fewer samples, or samples of other steps, are a
CosimError naming the variable and the steps libcosim gave."""

from __future__ import annotations

import sys
from types import ModuleType, SimpleNamespace

import pytest

from ballbot_casadi.fmi.masters import libcosim as LC
from ballbot_casadi.fmi.masters.libcosim import CosimError


def _fake(monkeypatch, got_n, first_step=0):
    calls = []

    def make(kind):
        def fn(ptr, slave, vr, start, n, vals, steps, times):
            calls.append((kind, ptr, slave, vr, start, n))
            for i in range(min(got_n, n)):
                vals[i] = 0.5 * i if kind == "real" else i * 2
                steps[i] = first_step + i
            return got_n
        return fn

    lib = SimpleNamespace(cosim_observer_slave_get_real_samples=make("real"),
                          cosim_observer_slave_get_integer_samples=make("int"))
    internal = ModuleType("libcosimpy._internal")
    internal.libcosimc = lambda: lib
    monkeypatch.setitem(sys.modules, "libcosimpy", ModuleType("libcosimpy"))
    monkeypatch.setitem(sys.modules, "libcosimpy._internal", internal)
    return calls


OBS = SimpleNamespace(ptr=lambda: "PTR")


def test_all_samples_of_a_real_and_an_integer():
    with pytest.MonkeyPatch.context() as mp:
        calls = _fake(mp, 4)
        x = LC._samples(OBS, 2, SimpleNamespace(type="Real", valueReference=7, name="x"), 3)
        assert x.tolist() == [0.0, 0.5, 1.0, 1.5] and x.dtype == float
        k = LC._samples(OBS, 1, SimpleNamespace(type="Integer", valueReference=3, name="k"), 3)
        assert k.tolist() == [0.0, 2.0, 4.0, 6.0]
        assert calls == [("real", "PTR", 2, 7, 0, 4), ("int", "PTR", 1, 3, 0, 4)]


@pytest.mark.parametrize("got, first, message", [
    (3, 0, r"^libcosim returned 3 samples of x \(steps 0 \.\. 2\), expected steps 0 \.\. 3$"),
    (4, 1, r"^libcosim returned 4 samples of x \(steps 1 \.\. 4\), expected steps 0 \.\. 3$"),
    (0, 0, r"^libcosim returned 0 samples of x \(steps 0 \.\. 0\), expected steps 0 \.\. 3$"),
])
def test_missing_or_shifted_samples_are_an_error(got, first, message):
    with pytest.MonkeyPatch.context() as mp:
        _fake(mp, got, first)
        with pytest.raises(CosimError, match=message):
            LC._samples(OBS, 0, SimpleNamespace(type="Real", valueReference=1, name="x"), 3)
