"""The velocity filters' Function signatures per option: the defaults are the thesis's
filter (no ``P_rate``, no ``walk``, no ``n_rej``), and each option adds exactly its own
inputs and outputs in the documented order."""

from __future__ import annotations

import pytest

from ballbot_casadi.estimation.adaptive_walk import WalkAdaptation
from ballbot_casadi.estimation.core import GATE_OUTPUT_NAMES, OUTPUT_NAMES
from ballbot_casadi.estimation.velocity import INPUT_NAMES, make_vekf, make_vukf
from ballbot_casadi.model.dynamics import make_model_functions


@pytest.fixture(scope="module")
def ws():
    return make_model_functions()["wheel_speeds"]


@pytest.mark.parametrize("make,name", [(make_vukf, "ballbot_vukf"), (make_vekf, "ballbot_vekf")])
def test_the_default_filter_is_the_thesis_s(ws, make, name):
    f = make(ws)
    assert f.name() == name
    assert f.name_in() == list(INPUT_NAMES)
    assert f.name_out() == list(OUTPUT_NAMES)
    assert [f.size_in(i) for i in range(3)] == [(7, 1), (7, 7), (6, 1)]


@pytest.mark.parametrize("kw,extra_in,extra_out", [
    (dict(matched=True), ["P_rate"], []),
    (dict(gate=True), ["n_rej"], list(GATE_OUTPUT_NAMES)),
    (dict(adaptive=WalkAdaptation()), ["walk"], ["walk_next"]),
    (dict(matched=True, gate=True, adaptive=WalkAdaptation()), ["P_rate", "walk", "n_rej"],
     [*GATE_OUTPUT_NAMES, "walk_next"]),
])
def test_each_option_adds_its_own_ports(ws, kw, extra_in, extra_out):
    f = make_vukf(ws, **kw)
    assert f.name_in() == [*INPUT_NAMES, *extra_in]
    assert f.name_out() == [*OUTPUT_NAMES, *extra_out]
    sizes = {"P_rate": (3, 3), "walk": (3, 1), "n_rej": (2, 1)}
    for n in extra_in:
        assert f.size_in(n) == sizes[n]


@pytest.mark.parametrize("kw,extra_in", [(dict(matched=True), ["P_rate"]),
                                         (dict(gate=True), ["n_rej"])])
def test_the_ekf_takes_the_same_options(ws, kw, extra_in):
    assert make_vekf(ws, **kw).name_in() == [*INPUT_NAMES, *extra_in]
