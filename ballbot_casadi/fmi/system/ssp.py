"""System Structure and Parameterization (SSP 1.0) archives: write and read.

An SSP archive is a zip with ``SystemStructure.ssd`` (the system: components, their
connectors, the connections, the default experiment) and ``resources/`` (the FMUs, one
parameter set per component as ``resources/<component>.ssv``, and any further files).
:func:`write_ssp` writes one from :class:`SspComponent` and :class:`SspConnection`
values after checking every connector and parameter against the FMUs'
``modelDescription.xml`` (name, causality, type), so an engine never meets a dangling
name; :func:`read_ssp` reads what the package's runner needs back.

SSP 1.0 has no standard place for a co-simulation step size (``ssd:DefaultExperiment``
has only ``startTime`` and ``stopTime``; the FMUs' own ``DefaultExperiment stepSize``
says 5 ms too), so the file carries the annotations of the engines it is run in: the
default experiment the Open Simulation Platform's ``osp:FixedStepAlgorithm
baseStepSize`` that libcosim reads (``CosimExecution.from_ssp_file``), the system
OMSimulator's ``org.openmodelica`` ``oms:FixedStepMaster stepSize`` (without it
OMSimulator's command line cannot import the file and its API defaults to 1 ms, which
the controller refuses).  Engines ignore annotations of other types.  libcosim applies
a parameter set only to parameters and inputs (it logs a warning and skips anything
else, e.g. start values of outputs); the package's FMUs therefore expose everything a
system sets as parameters (the plant's initial state ``x0_*``).  A user's FMU that
has only state start values gets them through :attr:`SspComponent.initial_values`,
which the libcosim master (:mod:`ballbot_casadi.fmi.masters.libcosim`) applies as
initial values.

The system of the software-in-the-loop run (plant, controller and reference FMUs of a
scenario) is :func:`ballbot_casadi.fmi.system.sil.sil_system`.
"""

from __future__ import annotations

import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence
from xml.etree import ElementTree
from xml.sax.saxutils import quoteattr

from fmpy import read_model_description

from ballbot_casadi.core.files import atomic_write_bytes, zip_bytes
from ballbot_casadi.errors import BuildError, FileFormatError, PathError
from ballbot_casadi.fmi.archive import check_members

__all__ = [
    "SSD_NAME",
    "NS",
    "SspComponent",
    "SspConnection",
    "SspSystem",
    "write_ssp",
    "read_ssp",
    "check_connections",
    "check_parameters",
    "ssd_xml",
    "ssv_xml",
]

SSD_NAME = "SystemStructure.ssd"
#: XML namespaces of SSP 1.0 and the OSP annotations.
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
    "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
}
_OSP_TYPE = "com.opensimulationplatform"
_OMS_TYPE = "org.openmodelica"
_TYPES = ("Real", "Integer", "Boolean")
_KIND = {"input": "input", "output": "output", "parameter": "parameter"}

Value = float | int | bool


@dataclass(frozen=True)
class SspComponent:
    """One FMU of the system.

    Attributes
    ----------
    name
        Instance name in the system (unique).
    fmu
        The ``.fmu`` file (copied to ``resources/<file name>``).
    parameters
        The component's parameter set: variable name -> value (``bool`` for Booleans,
        ``int`` for Integers).  Parameters, inputs and start values of states.
    """

    name: str
    fmu: Path
    parameters: Mapping[str, Value] = field(default_factory=dict)


@dataclass(frozen=True)
class SspConnection:
    """``start_element.start_connector -> end_element.end_connector``."""

    start_element: str
    start_connector: str
    end_element: str
    end_connector: str


@dataclass(frozen=True)
class SspSystem:
    """What :func:`read_ssp` returns.

    Attributes
    ----------
    name
        System name.
    components
        ``{instance name: resource path of its FMU}`` in document order.
    parameters
        ``{instance name: {variable: value}}`` (the first parameter set of each).
    connections
        The connections in document order.
    start_time, stop_time, step
        The default experiment (``stop_time``/``step`` ``None`` if absent).
    resources
        Names of the archive's files under ``resources/``.
    """

    name: str
    components: dict[str, str]
    parameters: dict[str, dict[str, Value]]
    connections: tuple[SspConnection, ...]
    start_time: float
    stop_time: float | None
    step: float | None
    resources: tuple[str, ...]


def _fmt(v: Value) -> tuple[str, str]:
    """``(ssv type, value text)`` of a parameter value."""
    if isinstance(v, bool):
        return "Boolean", "true" if v else "false"
    if isinstance(v, int):
        return "Integer", str(v)
    x = float(v)
    if not math.isfinite(x):
        raise FileFormatError(f"parameter value {v!r} is not finite; SSP values must be finite")
    return "Real", repr(x)


def ssv_xml(name: str, values: Mapping[str, Value]) -> str:
    """A parameter set ``name`` (SSP 1.0 ``.ssv``) with ``values``."""
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<ssv:ParameterSet xmlns:ssv="{NS["ssv"]}" xmlns:ssc="{NS["ssc"]}" version="1.0" '
             f"name={quoteattr(name)}>", "  <ssv:Parameters>"]
    for n, v in values.items():
        t, text = _fmt(v)
        lines += [f"    <ssv:Parameter name={quoteattr(n)}>",
                  f'      <ssv:{t} value="{text}"/>', "    </ssv:Parameter>"]
    lines += ["  </ssv:Parameters>", "</ssv:ParameterSet>"]
    return "\n".join(lines) + "\n"


def _variables(fmu: Path) -> dict[str, tuple[str, str]]:
    """``{name: (type, causality)}`` of an FMU's variables."""
    try:
        md = read_model_description(str(fmu))
    except Exception as exc:  # fmpy raises plain exceptions for unreadable archives
        raise BuildError(f"{fmu}: cannot read modelDescription.xml ({exc})") from None
    if md.coSimulation is None:
        raise BuildError(f"{fmu}: the FMU has no Co-Simulation interface; a co-simulation "
                         "engine needs one")
    return {v.name: (v.type, v.causality) for v in md.modelVariables}


def check_connections(connections: Sequence[SspConnection],
                      variables: Mapping[str, Mapping[str, tuple[str, str]]]) -> None:
    """Every connection joins an existing output to an existing input of the same type,
    and no input has two connections (the writer's and the readers' one rule).

    Raises
    ------
    FileFormatError
        The first connection that breaks a rule, and why.
    """
    ends: set[tuple[str, str]] = set()
    for con in connections:
        for elem, conn, want in ((con.start_element, con.start_connector, "output"),
                                 (con.end_element, con.end_connector, "input")):
            if elem not in variables:
                raise FileFormatError(f"connection {con}: no component {elem!r} (components: "
                                      f"{', '.join(variables)})")
            if conn not in variables[elem]:
                raise FileFormatError(f"connection {con}: {elem} has no variable {conn!r}")
            if variables[elem][conn][1] != want:
                raise FileFormatError(f"connection {con}: {elem}.{conn} is a "
                                      f"{variables[elem][conn][1]}, the connection needs an {want}")
        if variables[con.start_element][con.start_connector][0] != \
                variables[con.end_element][con.end_connector][0]:
            raise FileFormatError(f"connection {con}: the types differ")
        end = (con.end_element, con.end_connector)
        if end in ends:
            raise FileFormatError(f"input {end[0]}.{end[1]} has more than one connection")
        ends.add(end)


def check_parameters(parameters: Mapping[str, Mapping[str, Value]],
                     variables: Mapping[str, Mapping[str, tuple[str, str]]]) -> None:
    """Every parameter-set value names a variable of its component, has its type and is
    finite.

    Raises
    ------
    FileFormatError
        The first offending value, and why.
    """
    for comp, values in parameters.items():
        if comp not in variables:
            raise FileFormatError(f"parameter set of {comp}: no such component")
        for n, v in values.items():
            if n not in variables[comp]:
                raise FileFormatError(f"parameter set of {comp}: the FMU has no variable {n!r}")
            typ = variables[comp][n][0]
            got = _fmt(v)[0]  # refuses NaN and Inf
            if typ != got and not (typ == "Real" and got == "Integer"):
                raise FileFormatError(f"parameter set of {comp}: {n} is a {typ}, got {v!r}")


def _check(components: Sequence[SspComponent], connections: Sequence[SspConnection]
           ) -> dict[str, dict[str, tuple[str, str]]]:
    names = [c.name for c in components]
    if len(set(names)) != len(names) or not all(names):
        raise BuildError(f"component names must be unique and non-empty, got {names}")
    files = [Path(c.fmu).name for c in components]
    if len(set(files)) != len(files):
        raise BuildError(f"the components' FMU files must have distinct names, got {files}")
    variables = {c.name: _variables(Path(c.fmu)) for c in components}
    check_connections(connections, variables)
    check_parameters({c.name: c.parameters for c in components}, variables)
    return variables


def ssd_xml(name: str, components: Sequence[SspComponent], connections: Sequence[SspConnection],
            variables: Mapping[str, Mapping[str, tuple[str, str]]], start: float,
            stop: float, step: float, description: str = "") -> str:
    """``SystemStructure.ssd``: every input and output of each component as a connector,
    each component's parameter set bound from ``resources/<component>.ssv``, the
    connections and the default experiment (with the OSP fixed-step annotation)."""
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<ssd:SystemStructureDescription xmlns:ssd="{NS["ssd"]}" xmlns:ssc="{NS["ssc"]}"',
           f'    xmlns:ssv="{NS["ssv"]}" xmlns:osp="{NS["osp"]}" xmlns:oms="{NS["oms"]}"',
           f'    version="1.0" name={quoteattr(name)} generationTool="ballbot-casadi">',
           f"  <ssd:System name={quoteattr(name)} description={quoteattr(description)}>",
           "    <ssd:Elements>"]
    for c in components:
        out += [f'      <ssd:Component name={quoteattr(c.name)} '
                f'source="resources/{Path(c.fmu).name}" type="application/x-fmu-sharedlibrary">',
                "        <ssd:Connectors>"]
        for n, (typ, causality) in variables[c.name].items():
            if causality in ("input", "output") and typ in _TYPES:
                out += [f"          <ssd:Connector name={quoteattr(n)} kind=\"{_KIND[causality]}\">"
                        f"<ssc:{typ}/></ssd:Connector>"]
        out += ["        </ssd:Connectors>"]
        if c.parameters:
            out += ["        <ssd:ParameterBindings>",
                    f'          <ssd:ParameterBinding source="resources/{c.name}.ssv"/>',
                    "        </ssd:ParameterBindings>"]
        out += ["      </ssd:Component>"]
    out += ["    </ssd:Elements>", "    <ssd:Connections>"]
    for con in connections:
        out += [f"      <ssd:Connection startElement={quoteattr(con.start_element)} "
                f"startConnector={quoteattr(con.start_connector)} "
                f"endElement={quoteattr(con.end_element)} "
                f"endConnector={quoteattr(con.end_connector)}/>"]
    out += ["    </ssd:Connections>",
            # OMSimulator's fixed-step master (its own annotation of the system)
            "    <ssd:Annotations>",
            f'      <ssc:Annotation type="{_OMS_TYPE}">',
            "        <oms:Annotations><oms:SimulationInformation>",
            f'          <oms:FixedStepMaster description="oms-ma" stepSize="{step!r}"/>',
            "        </oms:SimulationInformation></oms:Annotations>",
            "      </ssc:Annotation>",
            "    </ssd:Annotations>",
            "  </ssd:System>",
            f'  <ssd:DefaultExperiment startTime="{start!r}" stopTime="{stop!r}">',
            "    <ssd:Annotations>",
            f'      <ssc:Annotation type="{_OSP_TYPE}">',
            f'        <osp:Algorithm><osp:FixedStepAlgorithm baseStepSize="{step!r}"/>'
            "</osp:Algorithm>",
            "      </ssc:Annotation>", "    </ssd:Annotations>", "  </ssd:DefaultExperiment>",
            "</ssd:SystemStructureDescription>"]
    return "\n".join(out) + "\n"


def write_ssp(path: str | Path, components: Sequence[SspComponent],
              connections: Sequence[SspConnection], *, name: str, stop: float, step: float,
              start: float = 0.0, description: str = "", parameter_set: str = "scenario",
              resources: Mapping[str, bytes] | None = None) -> Path:
    """Write an SSP 1.0 archive (deterministic: sorted members, fixed timestamps).

    Parameters
    ----------
    path
        The ``.ssp`` file (written atomically).
    components, connections
        The system (checked against the FMUs, see the module docstring).
    name, description
        System name and description.
    stop, step, start
        Default experiment: stop time, fixed base step and start time (s).
    parameter_set
        Name of every component's parameter set.
    resources
        Further files ``{name: content}`` stored as ``resources/<name>``.

    Raises
    ------
    BuildError
        A connector, connection or parameter that does not match the FMUs, a
        non-finite value, or a bad experiment.
    """
    path = Path(path)
    if not (math.isfinite(start) and math.isfinite(stop) and math.isfinite(step) and step > 0
            and stop > start):
        raise BuildError(f"default experiment start {start}, stop {stop}, step {step}: need "
                         "finite values with step > 0 and stop > start")
    variables = _check(components, connections)
    members = {SSD_NAME: ssd_xml(name, components, connections, variables, start, stop, step,
                                 description).encode()}
    for c in components:
        members[f"resources/{Path(c.fmu).name}"] = Path(c.fmu).read_bytes()
        if c.parameters:
            values = {n: float(v) if variables[c.name][n][0] == "Real" else v  # an int for a Real
                      for n, v in c.parameters.items()}                       # is written as Real
            members[f"resources/{c.name}.ssv"] = ssv_xml(parameter_set, values).encode()
    for n, data in (resources or {}).items():
        if f"resources/{n}" in members:
            raise BuildError(f"resource {n!r} clashes with a file of the system")
        members[f"resources/{n}"] = data
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_bytes(path, zip_bytes(members))


def _value(el: ElementTree.Element) -> Value:
    tag = el.tag.split("}")[-1]
    text = el.get("value", "")
    if tag == "Boolean":
        return text.strip().lower() in ("true", "1")
    if tag == "Integer":
        return int(text)
    return float(text)


def read_ssp(path: str | Path) -> SspSystem:
    """Read an SSP archive: components, their first parameter sets, connections and the
    default experiment.

    Raises
    ------
    PathError
        The file does not exist.
    FileFormatError
        Not a zip, no ``SystemStructure.ssd``, or malformed XML (a user mistake, exit 2).
    """
    path = Path(path)
    if not path.is_file():
        raise PathError(f"SSP file {path} does not exist")
    try:
        with zipfile.ZipFile(path) as zf:
            names = check_members(zf, path)  # zip slip: refused before anything is extracted
            if SSD_NAME not in names:
                raise FileFormatError(f"{path} has no {SSD_NAME}")
            root = ElementTree.fromstring(zf.read(SSD_NAME))
            ssv = {n: zf.read(n) for n in names if n.endswith(".ssv")}
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError) as exc:
        raise FileFormatError(f"{path} is not a readable SSP archive ({exc})") from None
    except ElementTree.ParseError as exc:
        raise FileFormatError(f"{path}: {SSD_NAME} is not valid XML ({exc})") from None
    try:
        system = _parse_system(root, ssv, names)
    except (ValueError, IndexError, KeyError, TypeError, ElementTree.ParseError) as exc:
        raise FileFormatError(f"{path}: malformed {SSD_NAME} ({type(exc).__name__}: {exc})") from None
    except FileFormatError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
    return system


def _time(text: str | None, what: str, positive: bool = False) -> float | None:
    """A finite time attribute (``None`` if absent)."""
    if text is None or text == "":
        return None
    try:
        x = float(text)
    except ValueError:
        raise FileFormatError(f"{what} must be a number of seconds, got {text!r}") from None
    if not math.isfinite(x) or (positive and x <= 0):
        raise FileFormatError(f"{what} must be a finite{' positive' if positive else ''} "
                              f"number of seconds, got {text!r}")
    return x


def _parse_system(root: ElementTree.Element, ssv: Mapping[str, bytes], names: Sequence[str]) -> SspSystem:
    system = root.find("ssd:System", NS)
    if system is None:
        raise FileFormatError(f"{SSD_NAME} has no ssd:System")
    components: dict[str, str] = {}
    parameters: dict[str, dict[str, Value]] = {}
    for comp in system.iterfind("ssd:Elements/ssd:Component", NS):
        cname = comp.get("name", "")
        components[cname] = comp.get("source", "")
        binding = comp.find("ssd:ParameterBindings/ssd:ParameterBinding", NS)
        values: dict[str, Value] = {}
        if binding is not None:
            src = binding.get("source")
            try:
                pset = (ElementTree.fromstring(ssv[src]) if src is not None
                        else binding.find("ssd:ParameterValues/ssv:ParameterSet", NS))
            except KeyError:
                raise FileFormatError(f"parameter set {src} of {cname} is missing") from None
            for p in pset.iterfind("ssv:Parameters/ssv:Parameter", NS) if pset is not None else ():
                if len(p) != 1:
                    raise FileFormatError(f"parameter {p.get('name', '')!r} of {cname} has "
                                          f"{len(p)} values, expected one")
                values[p.get("name", "")] = _value(p[0])
        parameters[cname] = values
    connections = tuple(
        SspConnection(c.get("startElement", ""), c.get("startConnector", ""),
                      c.get("endElement", ""), c.get("endConnector", ""))
        for c in system.iterfind("ssd:Connections/ssd:Connection", NS))
    exp = root.find("ssd:DefaultExperiment", NS)
    start, stop, step = 0.0, None, None
    if exp is not None:
        start = _time(exp.get("startTime", "0"), "startTime") or 0.0
        stop = _time(exp.get("stopTime"), "stopTime")
        algo = exp.find(".//osp:FixedStepAlgorithm", NS)
        step = _time(algo.get("baseStepSize"), "baseStepSize", positive=True) if algo is not None else None
    return SspSystem(root.get("name", ""), components, parameters, connections, start, stop,
                     step, tuple(n.removeprefix("resources/") for n in names
                                 if n.startswith("resources/")))
