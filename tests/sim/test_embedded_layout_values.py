"""The embedded software's names and layouts (sim.embedded) against the documented table:
the default and thesis estimators, which choices have the matched and the adaptive
velocity filter, the filters of each choice, the readings of each, the estimator and
controller-state layouts field by field with their sizes, and the state a Function's size
implies (issue 23: a swapped default, a wrong set member, a field out of order or a size
off by one must show)."""

from __future__ import annotations

import casadi as ca
import pytest

from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.sim import embedded as E

TABLE = {  # estimator: (attitude filter, velocity filter, xa, Pa, readings)
    "ukf": ("qukf", "vukf", 7, 36, 9),
    "ekf": ("qekf", "vekf", 7, 49, 9),
    "ukf_heading": ("qukf_heading", "vukf", 8, 49, 10),
    "ekf_heading": ("qekf_heading", "vekf", 10, 100, 10),
    "ukf_consistent": ("qukf", "vukf", 7, 36, 9),
    "ukf_adaptive": ("qukf", "vukf", 7, 36, 9),
}


def test_choices_defaults_and_filter_sets():
    assert E.DEFAULT_ESTIMATOR == "ukf_adaptive" and E.THESIS_ESTIMATOR == "ukf"
    assert E.MATCHED_VELOCITY == {"ukf_consistent", "ukf_adaptive"}
    assert E.ADAPTIVE_VELOCITY == {"ukf_adaptive"}
    assert {k: v for k, v in E.ESTIMATOR_FILTERS.items()} == {k: v[:2] for k, v in TABLE.items()}
    assert E.NOISE.fields == ("acc", "gyro", "gyro_rw", "heading") and E.NOISE.size == 10
    assert E.VALID.fields == ("acc", "gyro", "enc", "heading")
    assert E.MEAS.fields == ("acc", "gyro", "enc") and E.MEAS_HEADING.size == 10
    assert E.SENSOR_STATE.fields == ("tau_prev", "bias", "phi_prev") and E.SENSOR_STATE.size == 9
    assert E.GATE_GROUPS.fields == ("attitude_acc", "attitude_gyro", "velocity_enc", "velocity_acc")


@pytest.mark.parametrize("estimator", list(TABLE))
def test_estimator_layout_and_readings(estimator):
    _, _, nxa, npa, nmeas = TABLE[estimator]
    L = E.estimator_layout(estimator)
    walk = estimator == "ukf_adaptive"
    assert L.fields == ("xa", "Pa", "xv", "Pv", "pos", "gate", *(("walk",) if walk else ()))
    assert [L.size_of(f) for f in L.fields] == [nxa, npa, 7, 49, 2, 4, *((3,) if walk else ())]
    assert E.readings_layout(estimator).size == nmeas
    C = E.controller_layout(estimator, 8, 6, 9, 2)
    assert C.fields == ("z", *L.fields, "obs", "guide", "bal")
    assert C.offset("xa") == 8 and C.size_of("obs") == 6 and C.size_of("bal") == 2
    assert C.offset("obs") == 8 + L.size and C.offset("bal") == C.size - 2
    assert E.controller_layout(estimator, 8).fields == ("z", *L.fields)
    assert E.controller_layout(estimator, 8, 0, 3).fields == ("z", *L.fields, "guide")


def test_unknown_estimators_are_refused():
    for call in (E.estimator_layout, E.readings_layout):
        with pytest.raises(ScenarioError, match="unknown estimator 'ukff'; allowed: ukf, ekf"):
            call("ukff")


def _embedded(n_c: int, observer: bool, n_meas: int = 9) -> ca.Function:
    ins = [ca.MX.sym("c", n_c), ca.MX.sym("meas", n_meas)]
    if observer:
        ins.append(ca.MX.sym("com_observer"))
    return ca.Function("ballbot_embedded_toy", ins, [ins[0]],
                       ["c", "meas", *(("com_observer",) if observer else ())], ["c_next"])


def test_software_layout_from_the_state_size():
    base = E.controller_layout("ukf", E.VELOCITY_NZ)
    obs = E.COM_OBSERVER_STATE.size
    L = E.software_layout(_embedded(base.size + obs + 5 + 2, True), "ukf", n_guide=5)
    assert L.fields == (*base.fields, "obs", "guide", "bal")
    assert (L.size_of("obs"), L.size_of("guide"), L.size_of("bal")) == (obs, 5, 2)
    assert E.software_layout(_embedded(base.size, False), "ukf").fields == base.fields
    assert E.software_layout(_embedded(base.size + 1, False), "ukf").size_of("bal") == 1
    with pytest.raises(BuildError, match="does not match the layout"):
        E.software_layout(_embedded(base.size + obs - 1, True), "ukf")
    assert E.embedded_readings(_embedded(base.size, False)) is E.MEAS
    assert E.embedded_readings(_embedded(base.size, False, 10)) is E.MEAS_HEADING
    with pytest.raises(BuildError, match="readings of 8 entries"):
        E.embedded_readings(_embedded(base.size, False, 8))
