"""``modelDescription.xml`` (FMI 2.0) of an :class:`~ballbot_casadi.fmi.spec.FmuSpec`.

Written from the variable table only: every variable with its value reference, type,
causality, variability, initial, start value, range and unit; ``ModelStructure`` with
the outputs, the state derivatives and the initial unknowns (all in ascending index
order; outputs and derivatives with their ``dependencies``, derived from the CasADi
Functions' sparsity, :func:`~ballbot_casadi.fmi.spec.output_dependencies`); Model Exchange and/or Co-Simulation elements listing the C sources, so
``fmpy compile`` can rebuild the binary.
"""

from __future__ import annotations

import math
from typing import Sequence
from xml.sax.saxutils import quoteattr

from ballbot_casadi.fmi.spec import FmuSpec, FmuVar, output_dependencies, value_range

__all__ = ["model_description_xml", "LOG_CATEGORIES", "xml_number", "xml_start",
           "range_attributes", "common_elements"]

#: The log categories of the shared layer (``fmu/layer/fmi2_common.c``).
LOG_CATEGORIES = (
    ("logStatusError", "errors (on by default)"),
    ("logStatusWarning", "warnings (on by default)"),
    ("logCalls", "trace of FMI calls (off by default)"),
)


def xml_number(v: float) -> str:
    """A Real in a model description (shortest round-trip repr), FMI 2.0 and 3.0."""
    return repr(float(v))


def xml_start(v: FmuVar) -> str:
    """A variable's start attribute value (Boolean, Integer or Real), FMI 2.0 and 3.0."""
    if v.type == "Boolean":
        return "true" if v.start else "false"
    if v.type == "Integer":
        return str(int(v.start))
    return xml_number(v.start)


def range_attributes(v: FmuVar) -> str:
    """A variable's ``min``/``max`` (settable non-Boolean variables, finite bounds only) and
    ``start`` attributes, each with a leading space; FMI 2.0 and 3.0."""
    attrs = ""
    if v.type != "Boolean" and v.kind in ("parameter", "discrete_input", "input"):
        lo, hi, _, _, _ = value_range(v)
        if v.type == "Integer":
            attrs += f' min="{int(lo)}" max="{int(hi)}"'
        else:
            attrs += (f' min="{xml_number(lo)}"' if math.isfinite(lo) else "") + (
                f' max="{xml_number(hi)}"' if math.isfinite(hi) else "")
    if v.start is not None:
        attrs += f' start="{xml_start(v)}"'
    return attrs


def _type_element(v: FmuVar) -> str:
    if v.kind == "derivative":
        return f'<Real derivative="{v.derivative_of + 1}"/>'
    unit = f' unit="{v.unit}"' if v.type == "Real" and v.unit else ""
    return f"<{v.type}{unit}{range_attributes(v)}/>"


def common_elements(spec: FmuSpec, units: Sequence[str]) -> list[str]:
    """The ``UnitDefinitions`` (of ``units``, none when empty), ``LogCategories``
    (:data:`LOG_CATEGORIES`) and ``DefaultExperiment`` elements, FMI 2.0 and 3.0."""
    start, stop, step = spec.default_experiment
    out = []
    if units:
        out += ["  <UnitDefinitions>", *[f'    <Unit name="{u}"/>' for u in units],
                "  </UnitDefinitions>"]
    return out + ["  <LogCategories>",
                  *[f'    <Category name="{n}" description="{d}"/>' for n, d in LOG_CATEGORIES],
                  "  </LogCategories>",
                  f'  <DefaultExperiment startTime="{start:g}" stopTime="{stop:g}" '
                  f'stepSize="{step:g}"/>']


def _interface(tag: str, spec: FmuSpec, src: str, extra: str) -> list[str]:
    caps = ('canGetAndSetFMUstate="true" canSerializeFMUstate="true" '
            f'providesDirectionalDerivative="{str(spec.directional_derivatives).lower()}" '
            'canNotUseMemoryManagementFunctions="false"')
    return [f'  <{tag} modelIdentifier="{spec.model_identifier}" {caps}{extra}>',
            "    <SourceFiles>", src, "    </SourceFiles>", f"  </{tag}>"]


def model_description_xml(spec: FmuSpec, guid: str, sources: Sequence[str]) -> str:
    """``modelDescription.xml`` for ``spec`` with ``guid``, listing the C ``sources``."""
    rows = spec.variables
    units = sorted({v.unit for v in rows if v.unit and v.type == "Real"})
    src = "\n".join(f'      <File name="{s}"/>' for s in sources)
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName="{spec.model_name}"',
        f'  guid="{guid}"',
        f"  description={quoteattr(spec.description)}",
        '  generationTool="ballbot-casadi" numberOfEventIndicators="0">',
    ]
    if "me" in spec.interfaces:
        out += _interface("ModelExchange", spec, src, "")
    if "cs" in spec.interfaces:
        out += _interface("CoSimulation", spec, src,
                          '\n    canHandleVariableCommunicationStepSize="true" '
                          'canInterpolateInputs="false"\n    maxOutputDerivativeOrder="0" '
                          'canRunAsynchronuously="false"')
    out += common_elements(spec, units) + ["  <ModelVariables>"]
    for v in rows:
        head = (f"name={quoteattr(v.name)} valueReference=\"{v.vr}\" "
                f'causality="{v.causality}" variability="{v.variability}"')
        if v.initial is not None:
            head += f' initial="{v.initial}"'
        out += [f"    <!-- index {v.vr + 1} -->",
                f"    <ScalarVariable {head} description={quoteattr(v.description)}>",
                f"      {_type_element(v)}",
                "    </ScalarVariable>"]
    out += ["  </ModelVariables>", "  <ModelStructure>"]
    sections = (
        ("Outputs", [v for v in rows if v.causality == "output"]),
        ("Derivatives", [v for v in rows if v.kind == "derivative"]),
        ("InitialUnknowns", [v for v in rows if v.causality == "output" and v.initial !=
                             "exact" or v.kind == "derivative"]),
    )
    deps = output_dependencies(rows, dict(spec.dependencies) if spec.dependencies else None)
    index = {v.name: v.vr + 1 for v in rows}

    def unknown(v: FmuVar, tag: str) -> str:
        if tag == "InitialUnknowns" or deps is None:
            return f'      <Unknown index="{v.vr + 1}"/>'
        known = " ".join(str(i) for i in sorted(index[n] for n in deps[v.name]))
        return f'      <Unknown index="{v.vr + 1}" dependencies="{known}"/>'

    for tag, chosen in sections:
        if chosen:
            out += [f"    <{tag}>", *[unknown(v, tag) for v in chosen], f"    </{tag}>"]
    out += ["  </ModelStructure>", "</fmiModelDescription>"]
    return "\n".join(out) + "\n"
