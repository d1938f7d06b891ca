"""The variable table and both model descriptions, value by value, on a small hand-made table.

Every value reference, index, causality, variability, initial, range, start attribute,
unit, derivative reference and ModelStructure entry is written out by hand here from the
rules of :mod:`ballbot_casadi.fmi.spec` (no FMU is built): a swapped key, an off-by-one
index or a flipped test in the table or in either description changes one of them.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET

import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi.model_description import (
    model_description_xml,
    range_attributes,
    xml_number,
    xml_start,
)
from ballbot_casadi.fmi.model_description3 import model_description3_xml, time_value_reference
from ballbot_casadi.fmi.spec import (
    INT32_MAX,
    INT32_MIN,
    FmuSpec,
    VarTable,
    block_start,
    output_dependencies,
    value_range,
)


def _table() -> VarTable:
    t = VarTable()
    t.add("p_int", "parameter", "an integer parameter", type="Integer", start=3, bounds=(1, 7))
    t.add("x", "state", "position", unit="m", start_from="x0")
    t.add("der(x)", "derivative", "velocity", derivative_of="x")
    t.add("v", "state", "velocity", start=0.5, unit="m/s")
    t.add("der(v)", "derivative", "acceleration", derivative_of="v")
    t.add("u", "input", "force", start=0.0, unit="N")
    t.add("y", "output", "measured position", unit="m")
    t.add("k", "parameter", "a mass", start=2.0, unit="kg", rule="mass")
    t.add("x0", "parameter", "start position", start=1.0, unit="m")
    t.add("h", "discrete_output", "held reading", missing=True)
    t.add("fx", "parameter", "a build constant", start=4.0, fixed="it is built in")
    t.add("ang", "parameter", "an angle", start=0.5, unit="rad", rule="alpha")
    t.add("cnt", "local", "a counter", type="Integer")
    t.add("flag", "parameter", "a switch", type="Boolean", start=True)
    return t


ROWS = _table().rows()
BY = {v.name: v for v in ROWS}
#: name -> (vr, index, causality, variability, initial)
EXPECTED = {
    "x": (0, 0, "output", "continuous", "calculated"),
    "der(x)": (1, 0, "local", "continuous", "calculated"),
    "v": (2, 1, "output", "continuous", "exact"),
    "der(v)": (3, 1, "local", "continuous", "calculated"),
    "u": (4, 0, "input", "continuous", None),
    "y": (5, 0, "output", "continuous", "calculated"),
    "k": (6, 0, "parameter", "fixed", "exact"),
    "x0": (7, 1, "parameter", "fixed", "exact"),
    "h": (8, 0, "output", "discrete", "calculated"),
    "fx": (9, 2, "parameter", "fixed", "exact"),
    "ang": (10, 3, "parameter", "fixed", "exact"),
    "p_int": (11, 0, "parameter", "fixed", "exact"),
    "cnt": (12, 0, "local", "discrete", "calculated"),
    "flag": (13, 0, "parameter", "fixed", "exact"),
}
DEPS = {"y": ("u",), "der(x)": ("v",), "der(v)": ("u", "x")}


def _spec(deps=DEPS) -> FmuSpec:
    return FmuSpec(model_identifier="Tiny", description="a <tiny> & test", prefix="tiny",
                   variables=ROWS, functions=(), model_source="plant/plant_model.c",
                   cg_name="tiny", dependencies=tuple(deps.items()) if deps else (),
                   default_experiment=(0.0, 2.5, 0.01))


def test_rows_get_value_references_indices_and_fmi_attributes_by_the_rules():
    assert [v.name for v in ROWS] == list(EXPECTED)
    for name, (vr, index, causality, variability, initial) in EXPECTED.items():
        v = BY[name]
        assert (v.vr, v.index, v.causality, v.variability, v.initial) == \
            (vr, index, causality, variability, initial), name
    assert BY["der(x)"].derivative_of == 0 and BY["der(v)"].derivative_of == 2
    assert BY["x"].start_from == 7 and BY["v"].start_from is None
    assert BY["h"].missing and not BY["u"].missing


def test_value_ranges_of_each_kind_of_variable():
    assert value_range(BY["flag"]) == (0.0, 1.0, False, False, "fmi2True (1) or fmi2False (0)")
    assert value_range(BY["p_int"]) == (1.0, 7.0, False, False, "an integer in [1, 7]")
    assert value_range(BY["cnt"])[:4] == (float(INT32_MIN), float(INT32_MAX), False, False)
    assert value_range(BY["fx"]) == (4.0, 4.0, False, False, "its build value 4.0: it is built in")
    assert value_range(BY["x0"]) == (-math.inf, math.inf, False, False, None)
    assert value_range(BY["k"]) == (0.0, 10000.0, True, False, "a mass > 0 and <= 10000 kg")
    lo, hi, lo_open, hi_open, text = value_range(BY["ang"])
    assert (lo, hi, lo_open, hi_open) == (0.0, math.pi / 2, True, True)
    assert text.endswith("FMU values are radians: 0 < value < 1.5708")


def test_block_start_is_the_offset_within_the_type():
    assert block_start(ROWS, ["k", "x0"]) == 6
    assert block_start(ROWS, ["p_int", "cnt"]) == 0
    assert block_start(ROWS, ["cnt"]) == 1
    with pytest.raises(BuildError, match="'x'..'der\\(v\\)' must have consecutive VRs"):
        block_start(ROWS, ["x", "der(v)"])
    with pytest.raises(BuildError, match="'nope' is not in the table"):
        block_start(ROWS, ["k", "nope"])


def test_output_dependencies_states_held_outputs_and_continuous_ones():
    deps = output_dependencies(ROWS, DEPS)
    assert deps == {"x": ("x",), "v": ("v",), "der(x)": ("v",), "der(v)": ("u", "x"),
                    "y": ("u",), "h": ()}
    assert output_dependencies(ROWS, {"der(x)": ("v",), "der(v)": ("u",)}) is None
    assert output_dependencies(ROWS, None) is None


@pytest.mark.parametrize("bad, match", [
    (dict(name="a", kind="output", description="", type="Integer"), "cannot be of kind 'output'"),
    (dict(name="a", kind="parameter", description="", start=1.0, rule="nope"), "rule 'nope'"),
    (dict(name="a", kind="parameter", description="", start=1.0, bounds=(0, 1)), "bounds are"),
    (dict(name="a", kind="parameter", description="", type="Integer", start=1, fixed="w"),
     "only a Real parameter with a finite start"),
    (dict(name="a", kind="input", description="", start=1.0, fixed="w"),
     "only a Real parameter with a finite start"),
    (dict(name="a", kind="output", description="", missing=True), "may accept NaN"),
    (dict(name="a", kind="parameter", description=""), "'parameter' needs a start value"),
    (dict(name="a", kind="output", description="", start=1.0), "'output' must not have"),
    (dict(name="a", kind="parameter", description="", type="Boolean", start=1),
     "Boolean start value must be a bool"),
    (dict(name="a", kind="parameter", description="", type="Integer", start=True),
     "Integer start value must be an int"),
    (dict(name="a", kind="parameter", description="", type="Integer", start=8, bounds=(1, 7)),
     "start value 8 is not an integer in \\[1, 7\\]"),
    (dict(name="a", kind="parameter", description="", start=0.0, rule="mass"),
     "start value 0.0 is not a mass"),
    (dict(name="a", kind="parameter", description="", start=math.inf), "is not finite"),
    (dict(name="a", kind="nonsense", description="", start=1.0), "unknown type"),
])
def test_each_table_refusal_names_what_is_wrong(bad, match):
    t = VarTable()
    t.add(**bad)
    with pytest.raises(BuildError, match=match):
        t.rows()


def test_edges_of_ranges_are_accepted_and_missing_discrete_inputs_allowed():
    t = VarTable()
    t.add("lo", "parameter", "", type="Integer", start=1, bounds=(1, 7))
    t.add("hi", "parameter", "", type="Integer", start=7, bounds=(1, 7))
    t.add("m", "parameter", "", start=10000.0, rule="mass")
    t.add("d", "discrete_input", "", start=0.0, missing=True)
    rows = t.rows()
    assert [v.start for v in rows] == [10000.0, 0.0, 1, 7]
    assert rows[1].initial is None and rows[1].variability == "discrete"


def test_table_structure_refusals():
    t = VarTable()
    t.add("x", "state", "", start=0.0)
    with pytest.raises(BuildError, match="exactly one derivative"):
        t.rows()
    t = VarTable()
    t.add("d", "derivative", "", derivative_of="x")
    t.add("x", "state", "", start=0.0)
    with pytest.raises(BuildError, match="add the state before its derivative"):
        t.rows()
    t = VarTable()
    t.add("x", "state", "", start=0.0)
    t.add("d", "derivative", "", derivative_of="u")
    t.add("u", "input", "", start=0.0)
    with pytest.raises(BuildError, match="'d' is the derivative of 'u', which is not a state"):
        t.rows()
    t = VarTable()
    t.add("x", "state", "", start_from="p")
    t.add("d", "derivative", "", derivative_of="x")
    t.add("p", "parameter", "", type="Integer", start=1)
    with pytest.raises(BuildError, match="only a state can start from a Real parameter"):
        t.rows()
    t = VarTable()
    t.add("a", "local", "")
    t.add("a", "local", "")
    with pytest.raises(BuildError, match="unique"):
        t.rows()


def _vars2(xml: str) -> dict[str, ET.Element]:
    root = ET.fromstring(xml)
    return {e.get("name"): e for e in root.iter("ScalarVariable")}


def test_fmi2_description_writes_every_attribute_as_the_table_says():
    xml = model_description_xml(_spec(), "{guid-1}", ["a.c", "b.c"])
    root = ET.fromstring(xml)
    assert root.get("fmiVersion") == "2.0" and root.get("guid") == "{guid-1}"
    assert root.get("description") == "a <tiny> & test" and root.get("modelName") == "Tiny"
    for tag in ("ModelExchange", "CoSimulation"):
        el = root.find(tag)
        assert el.get("modelIdentifier") == "Tiny"
        assert el.get("providesDirectionalDerivative") == "false"
        assert [f.get("name") for f in el.iter("File")] == ["a.c", "b.c"]
    assert [u.get("name") for u in root.iter("Unit")] == ["N", "kg", "m", "m/s", "rad"]
    exp = root.find("DefaultExperiment")
    assert (exp.get("startTime"), exp.get("stopTime"), exp.get("stepSize")) == ("0", "2.5", "0.01")
    assert [c.get("name") for c in root.iter("Category")] == \
        ["logStatusError", "logStatusWarning", "logCalls"]
    sv = _vars2(xml)
    for name, (vr, _, causality, variability, initial) in EXPECTED.items():
        e = sv[name]
        assert (int(e.get("valueReference")), e.get("causality"), e.get("variability"),
                e.get("initial")) == (vr, causality, variability, initial), name
    typ = {n: e[0] for n, e in sv.items()}
    assert typ["der(x)"].get("derivative") == "1" and typ["der(v)"].get("derivative") == "3"
    assert typ["v"].attrib == {"unit": "m/s", "start": "0.5"}
    assert typ["x"].attrib == {"unit": "m"}
    assert typ["u"].attrib == {"unit": "N", "start": "0.0"}
    assert typ["k"].attrib == {"unit": "kg", "min": "0.0", "max": "10000.0", "start": "2.0"}
    assert typ["x0"].attrib == {"unit": "m", "start": "1.0"}
    assert typ["fx"].attrib == {"min": "4.0", "max": "4.0", "start": "4.0"}
    assert typ["ang"].attrib == {"unit": "rad", "min": "0.0", "max": repr(math.pi / 2),
                                 "start": "0.5"}
    assert typ["h"].attrib == {} and typ["y"].attrib == {"unit": "m"}
    assert typ["p_int"].tag == "Integer" and typ["p_int"].attrib == \
        {"min": "1", "max": "7", "start": "3"}
    assert typ["cnt"].tag == "Integer" and typ["cnt"].attrib == {}
    assert typ["flag"].tag == "Boolean" and typ["flag"].attrib == {"start": "true"}
    ms = root.find("ModelStructure")
    outs = {u.get("index"): u.get("dependencies") for u in ms.find("Outputs")}
    assert outs == {"1": "1", "3": "3", "6": "5", "9": ""}
    ders = {u.get("index"): u.get("dependencies") for u in ms.find("Derivatives")}
    assert ders == {"2": "3", "4": "1 5"}
    assert [u.get("index") for u in ms.find("InitialUnknowns")] == ["1", "2", "4", "6", "9"]
    assert all(u.get("dependencies") is None for u in ms.find("InitialUnknowns"))


def test_fmi2_description_without_dependencies_and_cs_only():
    spec = FmuSpec(model_identifier="Tiny", description="d", prefix="tiny", variables=ROWS,
                   functions=(), model_source="plant/plant_model.c", cg_name="tiny",
                   interfaces=("cs",), directional_derivatives=True)
    root = ET.fromstring(model_description_xml(spec, "g", []))
    assert root.find("ModelExchange") is None
    assert root.find("CoSimulation").get("providesDirectionalDerivative") == "true"
    assert all(u.get("dependencies") is None for u in root.find("ModelStructure").iter("Unknown"))


def test_fmi3_description_uses_value_references_and_fmi3_types():
    spec = _spec()
    root = ET.fromstring(model_description3_xml(spec, "{tok}"))
    assert root.get("fmiVersion") == "3.0" and root.get("instantiationToken") == "{tok}"
    assert time_value_reference(spec) == 14
    mv = root.find("ModelVariables")
    els = {e.get("name"): e for e in mv}
    assert els["time"].get("valueReference") == "14" and els["time"].get("causality") == \
        "independent"
    assert [u.get("name") for u in root.iter("Unit")] == ["N", "kg", "m", "m/s", "rad", "s"]
    for name, (vr, _, causality, variability, initial) in EXPECTED.items():
        e = els[name]
        assert (int(e.get("valueReference")), e.get("causality"), e.get("variability"),
                e.get("initial")) == (vr, causality, variability, initial), name
    assert els["p_int"].tag == "Int32" and els["flag"].tag == "Boolean"
    assert els["k"].tag == "Float64" and els["k"].get("min") == "0.0"
    assert els["der(x)"].get("derivative") == "0" and els["der(v)"].get("derivative") == "2"
    assert els["h"].get("unit") is None and els["v"].get("unit") == "m/s"
    assert els["cnt"].get("unit") is None and els["p_int"].get("max") == "7"
    assert els["flag"].get("start") == "true" and els["v"].get("start") == "0.5"
    ms = root.find("ModelStructure")
    outs = {u.get("valueReference"): u.get("dependencies") for u in ms.findall("Output")}
    assert outs == {"0": "0", "2": "2", "5": "4", "8": ""}
    ders = {u.get("valueReference"): u.get("dependencies")
            for u in ms.findall("ContinuousStateDerivative")}
    assert ders == {"1": "2", "3": "0 4"}
    assert [u.get("valueReference") for u in ms.findall("InitialUnknown")] == \
        ["0", "1", "3", "5", "8"]
    me = root.find("ModelExchange")
    assert me.get("modelIdentifier") == "Tiny" and me.get("providesAdjointDerivatives") == "false"


def test_start_and_range_attribute_helpers():
    assert xml_number(0.1) == "0.1" and xml_number(2) == "2.0"
    assert xml_start(BY["flag"]) == "true" and xml_start(BY["p_int"]) == "3"
    t = VarTable()
    t.add("off", "parameter", "", type="Boolean", start=False)
    t.add("out", "discrete_output", "", type="Integer")
    got = {v.name: v for v in t.rows()}
    off, out = got["off"], got["out"]
    assert xml_start(off) == "false" and range_attributes(off) == ' start="false"'
    assert range_attributes(out) == ""
    assert range_attributes(BY["u"]) == ' start="0.0"'
    assert range_attributes(BY["y"]) == ""


@pytest.mark.parametrize("change, message", [
    ({"prefix": "Tiny"}, r"^FmuSpec\.prefix 'Tiny' must be a lower-case C identifier$"),
    ({"prefix": "9tiny"}, r"^FmuSpec\.prefix '9tiny' must be a lower-case C identifier$"),
    ({"prefix": "tiny-x"}, r"^FmuSpec\.prefix 'tiny-x' must be a lower-case C identifier$"),
    ({"interfaces": ()}, r"^FmuSpec\.interfaces \(\): 'me' and/or 'cs'$"),
    ({"interfaces": ("cs", "se")}, r"^FmuSpec\.interfaces \('cs', 'se'\): 'me' and/or 'cs'$"),
    ({"variables": ROWS[1:]}, r"^variables must be ordered by value reference 0, 1, \.\.\.$"),
])
def test_a_spec_it_cannot_generate_is_refused(change, message):
    with pytest.raises(BuildError, match=message):
        dataclasses.replace(_spec(), **change)


def test_the_model_name_defaults_to_the_identifier():
    assert _spec().model_name == "Tiny"
    assert dataclasses.replace(_spec(), model_name="A tiny model").model_name == "A tiny model"
    assert dataclasses.replace(_spec(), prefix="t_2", interfaces=("me",)).prefix == "t_2"
