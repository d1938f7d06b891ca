"""The controller FMU checks the Functions it compiles against what its per-model C reads:
a Function with one input or one output too few or renamed is refused with one line
giving both lists (the embedded software is replaced by a small wrong Function here; no
FMU is built)."""

from __future__ import annotations

import casadi as ca
import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi.controller import controller as C
from ballbot_casadi.sim.ports import (
    EMBEDDED_INPUTS,
    EMBEDDED_OUTPUTS,
    GUIDANCE_CONSTANTS,
    GUIDANCE_OUTPUTS,
    OBSERVER_CONSTANTS,
    OBSERVER_OUTPUTS,
)


def _fn(name, ins, outs):
    xs = [ca.SX.sym(n) for n in ins]
    return ca.Function(name, xs, [xs[0] for _ in outs], list(ins), list(outs))


@pytest.mark.parametrize("ins, outs", [
    (EMBEDDED_INPUTS[:-1], EMBEDDED_OUTPUTS),
    (EMBEDDED_INPUTS, EMBEDDED_OUTPUTS[:-1]),
    ((*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS), (*EMBEDDED_OUTPUTS, "extra")),
])
def test_embedded_function_with_other_ports_is_refused(monkeypatch, ins, outs):
    monkeypatch.setattr(C, "embedded_software", lambda c, e: _fn("wrong_fn", ins, outs))
    with pytest.raises(BuildError) as exc:
        C.embedded_function("flc", "ukf")
    msg = str(exc.value)
    assert msg.startswith(f"wrong_fn has inputs {tuple(ins)} and outputs {tuple(outs)}; the "
                          "controller FMU reads") and "\n" not in msg


@pytest.mark.parametrize("ins, outs", [
    ((*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS), (*EMBEDDED_OUTPUTS, *OBSERVER_OUTPUTS)),
    ((*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS, *GUIDANCE_CONSTANTS),
     (*EMBEDDED_OUTPUTS, *OBSERVER_OUTPUTS)),
    ((*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS),
     (*EMBEDDED_OUTPUTS, *OBSERVER_OUTPUTS, *GUIDANCE_OUTPUTS)),
])
def test_path_embedded_function_needs_the_guidance_ports(monkeypatch, ins, outs):
    monkeypatch.setattr(C, "guided_software", lambda law, e: _fn("wrong_guided", ins, outs))
    with pytest.raises(BuildError) as exc:
        C.path_embedded_function(object(), "ukf")
    msg = str(exc.value)
    assert msg.startswith(f"wrong_guided has inputs {tuple(ins)} and outputs {tuple(outs)}; "
                          "the path-following controller FMU reads") and "\n" not in msg


def test_both_port_lists_pass_the_plain_check(monkeypatch):
    for ins, outs in ((EMBEDDED_INPUTS, EMBEDDED_OUTPUTS),
                      ((*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS), (*EMBEDDED_OUTPUTS,
                                                                 *OBSERVER_OUTPUTS))):
        f = _fn("ok_fn", ins, outs)
        monkeypatch.setattr(C, "embedded_software", lambda c, e, f=f: f)
        assert C.embedded_function("flc", "ukf") is f
    g = _fn("ok_guided", (*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS, *GUIDANCE_CONSTANTS),
            (*EMBEDDED_OUTPUTS, *OBSERVER_OUTPUTS, *GUIDANCE_OUTPUTS))
    monkeypatch.setattr(C, "guided_software", lambda law, e: g)
    assert C.path_embedded_function(object(), "ukf") is g
