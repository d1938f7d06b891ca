"""The SSP writer and reader, value by value, on two hand-written FMU archives (a
``modelDescription.xml`` only: no binary is built, no engine runs).

Each rule of the writer (connections output -> input of one type, one connection per
input, parameter values of the variable's type, Real accepting an integer, finite values,
unique components and FMU file names, a sane experiment, no resource clash) is checked
with the first offending item named, and a written system is read back entry by entry:
components in order, each parameter with its value and Python type, the connections in
order, the experiment and the resources.
"""

from __future__ import annotations

import math
import zipfile
import xml.etree.ElementTree as ET

import pytest

from ballbot_casadi.errors import BuildError, FileFormatError
from ballbot_casadi.fmi.system.ssp import (
    SspComponent,
    SspConnection,
    check_connections,
    check_parameters,
    read_ssp,
    ssv_xml,
    write_ssp,
)

_MD = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="{mi}" guid="{{{mi}}}">
  <CoSimulation modelIdentifier="{mi}"/>
  <ModelVariables>
    <ScalarVariable name="y" valueReference="0" causality="output" variability="discrete" initial="calculated"><Real/></ScalarVariable>
    <ScalarVariable name="u" valueReference="1" causality="input" variability="discrete"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="u2" valueReference="2" causality="input" variability="discrete"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="3" causality="parameter" variability="fixed" initial="exact"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="n" valueReference="0" causality="parameter" variability="fixed" initial="exact"><Integer start="1"/></ScalarVariable>
    <ScalarVariable name="iy" valueReference="1" causality="output" variability="discrete" initial="calculated"><Integer/></ScalarVariable>
    <ScalarVariable name="b" valueReference="0" causality="parameter" variability="fixed" initial="exact"><Boolean start="false"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="1"/><Unknown index="6"/></Outputs>
  </ModelStructure>
</fmiModelDescription>
"""

VARS = {"y": ("Real", "output"), "u": ("Real", "input"), "u2": ("Real", "input"),
        "k": ("Real", "parameter"), "n": ("Integer", "parameter"),
        "iy": ("Integer", "output"), "b": ("Boolean", "parameter")}
VARIABLES = {"a": VARS, "b": VARS}


def _fmu(tmp_path, mi: str):
    p = tmp_path / f"{mi}.fmu"
    with zipfile.ZipFile(p, "w") as zf:
        zf.writestr("modelDescription.xml", _MD.format(mi=mi))
    return p


@pytest.mark.parametrize("cons, text", [
    ([SspConnection("c", "y", "b", "u")], "no component 'c' (components: a, b)"),
    ([SspConnection("a", "y", "b", "zz")], "b has no variable 'zz'"),
    ([SspConnection("a", "u", "b", "u")], "a.u is a input, the connection needs an output"),
    ([SspConnection("a", "y", "b", "y")], "b.y is a output, the connection needs an input"),
    ([SspConnection("a", "iy", "b", "u")], "the types differ"),
    ([SspConnection("a", "y", "b", "u"), SspConnection("b", "y", "b", "u")],
     "input b.u has more than one connection"),
])
def test_each_connection_rule_names_the_offender(cons, text):
    with pytest.raises(FileFormatError) as exc:
        check_connections(cons, VARIABLES)
    assert text in str(exc.value)


def test_good_connections_pass_and_one_output_may_feed_many_inputs():
    check_connections([SspConnection("a", "y", "b", "u"), SspConnection("a", "y", "b", "u2"),
                       SspConnection("b", "y", "a", "u")], VARIABLES)


@pytest.mark.parametrize("params, text", [
    ({"c": {"k": 1.0}}, "parameter set of c: no such component"),
    ({"a": {"zz": 1.0}}, "parameter set of a: the FMU has no variable 'zz'"),
    ({"a": {"n": 1.5}}, "parameter set of a: n is a Integer, got 1.5"),
    ({"a": {"b": 1}}, "parameter set of a: b is a Boolean, got 1"),
    ({"a": {"k": True}}, "parameter set of a: k is a Real, got True"),
    ({"a": {"k": math.nan}}, "is not finite"),
    ({"b": {"k": -math.inf}}, "is not finite"),
])
def test_each_parameter_rule_names_the_offender(params, text):
    with pytest.raises(FileFormatError) as exc:
        check_parameters(params, VARIABLES)
    assert text in str(exc.value)


def test_a_real_parameter_takes_an_integer_value():
    check_parameters({"a": {"k": 2, "n": 3, "b": False}}, VARIABLES)


def test_ssv_writes_each_type():
    root = ET.fromstring(ssv_xml("set1", {"k": 0.1, "n": 7, "b": True, "c": False}))
    assert root.get("name") == "set1"
    got = [(p.get("name"), p[0].tag.split("}")[1], p[0].get("value"))
           for p in root.iter("{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
                              "Parameter")]
    assert got == [("k", "Real", "0.1"), ("n", "Integer", "7"), ("b", "Boolean", "true"),
                   ("c", "Boolean", "false")]


def test_written_system_reads_back_entry_by_entry(tmp_path):
    fa, fb = _fmu(tmp_path, "Afmu"), _fmu(tmp_path, "Bfmu")
    comps = [SspComponent("a", fa, {"k": 2.5, "n": 4, "b": True}),
             SspComponent("b", fb, {"k": 3})]
    cons = [SspConnection("a", "y", "b", "u"), SspConnection("b", "y", "a", "u2"),
            SspConnection("b", "y", "a", "u")]
    p = write_ssp(tmp_path / "s.ssp", comps, cons, name="sys", stop=1.25, step=0.005,
                  start=0.5, resources={"extra.json": b"{}"})
    s = read_ssp(p)
    assert s.name == "sys"
    assert s.components == {"a": "resources/Afmu.fmu", "b": "resources/Bfmu.fmu"}
    assert s.parameters == {"a": {"k": 2.5, "n": 4, "b": True}, "b": {"k": 3.0}}
    assert type(s.parameters["a"]["n"]) is int and type(s.parameters["a"]["b"]) is bool
    assert type(s.parameters["a"]["k"]) is float
    # an integer given for a Real variable is written as <ssv:Real> (strict importers check the type)
    assert type(s.parameters["b"]["k"]) is float
    with zipfile.ZipFile(p) as zf:
        assert '<ssv:Real value="3.0"/>' in zf.read("resources/b.ssv").decode()
    assert s.connections == tuple(cons)
    assert (s.start_time, s.stop_time, s.step) == (0.5, 1.25, 0.005)
    assert set(s.resources) == {"Afmu.fmu", "Bfmu.fmu", "a.ssv", "b.ssv", "extra.json"}
    with zipfile.ZipFile(p) as zf:
        names = zf.namelist()
        assert names == sorted(names)
        ssd = ET.fromstring(zf.read("SystemStructure.ssd"))
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription"}
    conn = {(c.get("name"), c.get("kind")) for c in
            ssd.find("ssd:System/ssd:Elements/ssd:Component", ns).iter(
                "{http://ssp-standard.org/SSP1/SystemStructureDescription}Connector")}
    assert conn == {("y", "output"), ("u", "input"), ("u2", "input"), ("iy", "output")}


def test_a_component_without_parameters_has_no_binding(tmp_path):
    fa, fb = _fmu(tmp_path, "Afmu"), _fmu(tmp_path, "Bfmu")
    p = write_ssp(tmp_path / "s.ssp", [SspComponent("a", fa, {}), SspComponent("b", fb, {"k": 1.0})],
                  [], name="sys", stop=1.0, step=0.1)
    s = read_ssp(p)
    assert s.parameters == {"a": {}, "b": {"k": 1.0}}
    assert "a.ssv" not in s.resources and "b.ssv" in s.resources
    assert s.start_time == 0.0


@pytest.mark.parametrize("kw, text", [
    (dict(stop=1.0, step=0.0), "need finite values with step > 0 and stop > start"),
    (dict(stop=1.0, step=-0.1), "step -0.1"),
    (dict(stop=0.5, step=0.1, start=0.5), "stop 0.5"),
    (dict(stop=math.inf, step=0.1), "stop inf"),
    (dict(stop=1.0, step=0.1, start=math.nan), "start nan"),
])
def test_a_bad_experiment_is_refused(tmp_path, kw, text):
    fa = _fmu(tmp_path, "Afmu")
    with pytest.raises(BuildError, match=text):
        write_ssp(tmp_path / "s.ssp", [SspComponent("a", fa, {})], [], name="s", **kw)
    assert not (tmp_path / "s.ssp").exists()


def test_component_names_files_and_resources_must_not_clash(tmp_path):
    fa, fb = _fmu(tmp_path, "Afmu"), _fmu(tmp_path, "Bfmu")
    other = tmp_path / "sub"
    other.mkdir()
    fa2 = _fmu(other, "Afmu")
    with pytest.raises(BuildError, match="component names must be unique and non-empty"):
        write_ssp(tmp_path / "s.ssp", [SspComponent("a", fa, {}), SspComponent("a", fb, {})], [],
                  name="s", stop=1.0, step=0.1)
    with pytest.raises(BuildError, match="component names must be unique and non-empty"):
        write_ssp(tmp_path / "s.ssp", [SspComponent("", fa, {})], [], name="s", stop=1.0,
                  step=0.1)
    with pytest.raises(BuildError, match="distinct names, got \\['Afmu.fmu', 'Afmu.fmu'\\]"):
        write_ssp(tmp_path / "s.ssp", [SspComponent("a", fa, {}), SspComponent("b", fa2, {})],
                  [], name="s", stop=1.0, step=0.1)
    with pytest.raises(BuildError, match="resource 'a.ssv' clashes"):
        write_ssp(tmp_path / "s.ssp", [SspComponent("a", fa, {"k": 1.0})], [], name="s",
                  stop=1.0, step=0.1, resources={"a.ssv": b""})
    with pytest.raises(FileFormatError, match="input b.u has more than one connection"):
        write_ssp(tmp_path / "s.ssp", [SspComponent("a", fa, {}), SspComponent("b", fb, {})],
                  [SspConnection("a", "y", "b", "u"), SspConnection("b", "y", "b", "u")],
                  name="s", stop=1.0, step=0.1)
    assert not (tmp_path / "s.ssp").exists()


def _rewrite_ssd(p, old, new):
    with zipfile.ZipFile(p) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    members["SystemStructure.ssd"] = members["SystemStructure.ssd"].replace(old, new)
    with zipfile.ZipFile(p, "w") as zf:
        for n, d in members.items():
            zf.writestr(n, d)


@pytest.mark.parametrize("old, new, text", [
    (b'baseStepSize="0.1"', b'baseStepSize="0"', "baseStepSize must be a finite positive"),
    (b'baseStepSize="0.1"', b'baseStepSize="-0.1"', "baseStepSize must be a finite positive"),
    (b'stopTime="1.0"', b'stopTime="soon"', "stopTime must be a number of seconds, got 'soon'"),
    (b'startTime="0.0"', b'startTime="inf"', "startTime must be a finite number of seconds"),
])
def test_the_reader_refuses_bad_times_with_the_attribute(tmp_path, old, new, text):
    fa = _fmu(tmp_path, "Afmu")
    p = write_ssp(tmp_path / "s.ssp", [SspComponent("a", fa, {})], [], name="s", stop=1.0,
                  step=0.1)
    _rewrite_ssd(p, old, new)
    with pytest.raises(FileFormatError, match=text):
        read_ssp(p)


def test_the_reader_takes_a_negative_start_and_reads_booleans_as_written(tmp_path):
    fa = _fmu(tmp_path, "Afmu")
    p = write_ssp(tmp_path / "new" / "deeper" / "s.ssp", [SspComponent("a", fa, {"b": False})],
                  [], name="s", stop=1.0, step=0.1, start=-0.5)  # its folders are made
    s = read_ssp(p)
    assert s.start_time == -0.5 and s.parameters["a"]["b"] is False
