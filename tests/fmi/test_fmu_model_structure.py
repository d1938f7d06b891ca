"""ModelStructure dependencies (issue 19): derived from the CasADi Functions' sparsity, so
an engine sees no algebraic loop where there is none (FMI 2.0: no list = "depends on every
input")."""

from __future__ import annotations

import math
from xml.etree import ElementTree

import numpy as np
import pytest
from fmpy import read_model_description

from ballbot_casadi.core.params import load_params
from ballbot_casadi.fmi.controller.controller import REJECTION_NAMES, controller_spec
from ballbot_casadi.fmi.model_description import model_description_xml
from ballbot_casadi.fmi.model_description3 import model_description3_xml
from ballbot_casadi.fmi.plant.plant import plant_functions, plant_spec
from ballbot_casadi.fmi.spec import sparsity_dependencies, value_range

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def _md(spec, tmp_path):
    p = tmp_path / f"{spec.prefix}.xml"
    p.write_text(model_description_xml(spec, "{00000000-0000-0000-0000-000000000000}", ["a.c"]))
    return read_model_description(str(p), validate=True)


def _feedthrough(md) -> dict[str, list[str]]:
    """Output name -> the inputs it depends on directly."""
    return {u.variable.name: [d.name for d in u.dependencies if d.causality == "input"]
            for u in md.outputs}


def test_only_the_accelerometer_feeds_the_torques_through(tmp_path):
    md = _md(plant_spec(), tmp_path)
    through = _feedthrough(md)
    assert all(u.dependencies is not None for u in md.outputs + md.derivatives)
    fed = {n: d for n, d in through.items() if d}
    assert sorted(fed) == ["acc_x", "acc_y", "acc_z"]
    assert all(set(d) == {"tau0", "tau1", "tau2", "tau_dist0", "tau_dist1", "tau_dist2"}
               for d in fed.values())
    # the states, angles, speeds, gyro, encoders, readings (with the heading reading)
    assert len(through) - len(fed) == 37
    deps = {u.variable.name: [d.name for d in u.dependencies] for u in md.outputs + md.derivatives}
    assert deps["q0"] == ["q0"] and deps["sensor_acc_x"] == []
    assert deps["der(x)"] == ["dx"]  # dx/dt = dx only
    assert "tau0" in deps["der(dq0)"] and "x" not in deps["der(dq0)"]


def test_dependencies_match_the_numeric_jacobian():
    """Independent reference: a finite perturbation of every state and torque changes
    exactly the outputs the declared sparsity names (a zero in the pattern stays zero)."""
    out = {f.name(): f for f in plant_functions()}["bbp_out"]
    rows = [f"y{i}" for i in range(15)]
    deps = sparsity_dependencies(out, "y", rows, {"x": [(f"x{i}",) for i in range(12)],
                                                  "tau": [(f"t{i}",) for i in range(3)]})
    rng = np.random.default_rng(0)
    x = np.array([0.1, -0.2, 0.99, 0.05, -0.08, 0.03, 0.2, -0.1, 0.01, 0.02, -0.03, 0.04])
    tau, p = rng.normal(size=3) * 0.1, load_params().to_vector()
    y0 = np.array(out(x, tau, p)).ravel()
    for j in range(15):
        xj, tj = x.copy(), tau.copy()
        if j < 12:
            xj[j] += 1e-6
        else:
            tj[j - 12] += 1e-6
        moved = np.abs(np.array(out(xj, tj, p)).ravel() - y0) > 0
        name = f"x{j}" if j < 12 else f"t{j - 12}"
        for i, r in enumerate(rows):
            if moved[i]:
                assert name in deps[r], (r, name)


def test_no_controller_output_depends_on_an_input(tmp_path):
    md = _md(controller_spec(), tmp_path)
    assert len(md.outputs) == 53 + len(REJECTION_NAMES)  # + the innovation-gate rejections
    assert all(u.dependencies == [] for u in md.outputs)


def _range_and_start(root, fmi3: bool) -> dict[str, dict[str, str]]:
    """Variable name -> its min, max and start attributes (FMI 2.0: on the type element)."""
    keys = ("min", "max", "start")
    rows = root.find("ModelVariables")
    if fmi3:
        return {e.get("name"): {k: e.get(k) for k in keys} for e in rows}
    return {e.get("name"): {k: e[0].get(k) for k in keys} for e in rows}


@pytest.mark.parametrize("make_spec", [plant_spec, controller_spec])
def test_fmi3_description_carries_the_fmi2_ranges_and_starts(make_spec):
    """Both writers take min/max/start from one place (range_attributes): the same values,
    the finite bounds of PARAM_RULES (value_range) on the settable variables only; and the
    same default experiment, log categories and units (common_elements)."""
    spec = make_spec()
    root2 = ElementTree.fromstring(model_description_xml(spec, "{0}", ["a.c"]))
    root3 = ElementTree.fromstring(model_description3_xml(spec, "{0}"))
    md2, md3 = _range_and_start(root2, fmi3=False), _range_and_start(root3, fmi3=True)
    md3.pop("time")
    assert md3 == md2
    # the shared elements (common_elements): the same experiment, log categories and units
    start, stop, step = spec.default_experiment
    for root in (root2, root3):
        assert {k: float(v) for k, v in root.find("DefaultExperiment").items()} == {
            "startTime": start, "stopTime": stop, "stepSize": step}
        assert [c.get("name") for c in root.find("LogCategories")] == [
            "logStatusError", "logStatusWarning", "logCalls"]
    units = {u.get("name") for u in root2.find("UnitDefinitions")}
    assert units == {v.unit for v in spec.variables if v.unit and v.type == "Real"}
    assert {u.get("name") for u in root3.find("UnitDefinitions")} == units | {"s"}  # time
    n_ranged = 0
    for v in spec.variables:
        lo, hi, _, _, _ = value_range(v)
        settable = v.type != "Boolean" and v.kind in ("parameter", "discrete_input", "input")
        got = md2[v.name]
        assert (got["min"] is not None) == (settable and math.isfinite(lo)), v.name
        assert (got["max"] is not None) == (settable and math.isfinite(hi)), v.name
        if got["min"] is not None:
            n_ranged += 1
            assert float(got["min"]) == lo
        if got["max"] is not None:
            assert float(got["max"]) == hi
        if v.start is not None and v.type == "Real" and v.kind != "derivative":
            assert float(got["start"]) == float(v.start), v.name
    assert n_ranged > 0
