"""The Gauss-Seidel master's order and sampling on two scripted components (no FMU: the
adapter is replaced by a small Python model whose outputs are known by hand).

``A`` (stepped first): ``a_out = a_in + p`` at initialisation, ``a_in + 100 (t + h)``
after a step from ``t``; ``B``: ``b_out = 2 b_in`` at initialisation, ``2 b_in + 1``
after a step.  Connections ``A.a_out -> B.b_in`` and ``B.b_out -> A.a_in``; start 1.0,
steps of 0.5.  Written out by hand below: the outputs at each ``t_k``, the inputs held
on ``[t_k, t_k+1)`` (NaN at ``t_n``), the step calls in order with their times, the
parameters set, and every component freed even when a step fails.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.fmi.masters import gauss_seidel
from ballbot_casadi.fmi.system.ssp import SspConnection, SspSystem

CALLS: list = []


class _Fake:
    def __init__(self, unzipped, name):
        self.name, self.v, self.p = name, {"a_in": 0.0, "a_out": 0.0, "b_in": 0.0,
                                           "b_out": 0.0}, {}
        CALLS.append(("new", name, str(unzipped)))

    def setup(self, t, params):
        self.p = dict(params)
        CALLS.append(("setup", self.name, t, tuple(sorted(params.items()))))

    def exit_initialization(self):
        if self.name == "A":
            self.v["a_out"] = self.v["a_in"] + self.p["p"]
        else:
            self.v["b_out"] = 2.0 * self.v["b_in"]

    def get(self, n):
        return self.v[n]

    def set(self, n, x):
        self.v[n] = x

    def do_step(self, t, h):
        CALLS.append(("step", self.name, t, h))
        if self.name == "B" and self.p.get("fail"):
            raise RuntimeError("step failed")
        if self.name == "A":
            self.v["a_out"] = self.v["a_in"] + 100.0 * (t + h)
        else:
            self.v["b_out"] = 2.0 * self.v["b_in"] + 1.0

    def free(self):
        CALLS.append(("free", self.name))


def _system(b_params=None):
    return SspSystem(name="s", components={"B": "b.fmu", "A": "a.fmu"},
                     parameters={"A": {"p": 3.0}, "B": dict(b_params or {})},
                     connections=(SspConnection("A", "a_out", "B", "b_in"),
                                  SspConnection("B", "b_out", "A", "a_in")),
                     start_time=1.0, stop_time=2.0, step=0.5, resources=())


VARIABLES = {"A": {"a_in": SimpleNamespace(causality="input"),
                   "a_out": SimpleNamespace(causality="output")},
             "B": {"b_in": SimpleNamespace(causality="input"),
                   "b_out": SimpleNamespace(causality="output")}}
REC = [("A", "a_out"), ("B", "b_out"), ("A", "a_in"), ("B", "b_in")]


@pytest.fixture(autouse=True)
def fake(monkeypatch):
    CALLS.clear()
    monkeypatch.setattr(gauss_seidel, "FmuSlave", _Fake)


def test_outputs_inputs_and_steps_in_the_order_given():
    out = gauss_seidel.run_gauss_seidel(_system(), {"A": "ua", "B": "ub"}, 2, 0.5, VARIABLES,
                                        REC, first=("A", "nobody"))
    np.testing.assert_array_equal(out["A.a_out"], [3.0, 156.0, 513.0])
    np.testing.assert_array_equal(out["B.b_out"], [6.0, 313.0, 1027.0])
    np.testing.assert_array_equal(out["A.a_in"], [6.0, 313.0, np.nan])
    np.testing.assert_array_equal(out["B.b_in"], [156.0, 513.0, np.nan])
    assert [c for c in CALLS if c[0] == "step"] == [
        ("step", "A", 1.0, 0.5), ("step", "B", 1.0, 0.5),
        ("step", "A", 1.5, 0.5), ("step", "B", 1.5, 0.5)]
    assert [c for c in CALLS if c[0] == "new"] == [("new", "A", "ua"), ("new", "B", "ub")]
    assert ("setup", "A", 1.0, (("p", 3.0),)) in CALLS and ("setup", "B", 1.0, ()) in CALLS
    assert sorted(c for c in CALLS if c[0] == "free") == [("free", "A"), ("free", "B")]


def test_without_first_the_systems_order_is_kept():
    out = gauss_seidel.run_gauss_seidel(_system(), {"A": "ua", "B": "ub"}, 1, 0.5, VARIABLES, REC)
    # B first: b_in = a_out (0 before A's initialisation) -> b_out 0, then a_out = 0 + 3
    np.testing.assert_array_equal(out["B.b_out"][:1], [0.0])
    np.testing.assert_array_equal(out["A.a_out"][:1], [3.0])
    # period 0: B reads a_out = 3 -> 7; A reads b_out = 7 -> 7 + 150
    np.testing.assert_array_equal(out["B.b_in"], [3.0, np.nan])
    np.testing.assert_array_equal(out["B.b_out"], [0.0, 7.0])
    np.testing.assert_array_equal(out["A.a_out"], [3.0, 157.0])
    assert [c[1] for c in CALLS if c[0] == "step"] == ["B", "A"]


def test_a_failing_step_still_frees_every_component():
    with pytest.raises(RuntimeError, match="step failed"):
        gauss_seidel.run_gauss_seidel(_system({"fail": True}), {"A": "ua", "B": "ub"}, 3, 0.5,
                                      VARIABLES, REC, first=("A",))
    assert sorted(c for c in CALLS if c[0] == "free") == [("free", "A"), ("free", "B")]
    assert [c[1] for c in CALLS if c[0] == "step"] == ["A", "B"]
