"""``modelDescription.xml`` (FMI 3.0) of an :class:`~ballbot_casadi.fmi.spec.FmuSpec`.

Written from the same variable table as the FMI 2.0 description
(:mod:`~ballbot_casadi.fmi.model_description`): the same names, value references,
causalities, variabilities, start values, ranges and units, with the FMI 3.0 types
(Real -> ``Float64``, Integer -> ``Int32``, Boolean -> ``Boolean``), the independent
variable ``time`` (value reference one past the table; FMI 3.0 requires it), and
``ModelStructure`` with ``Output``, ``ContinuousStateDerivative`` and ``InitialUnknown``
elements whose ``dependencies`` are value references (FMI 3.0) derived from the same
CasADi sparsity (:func:`~ballbot_casadi.fmi.spec.output_dependencies`).

Every variable stays a scalar (no ``<Dimension>``): the FMI 2.0 and 3.0 FMUs then have
the same variable names and value references, so one SSP, one parameter set, one
connection list and the same result columns serve both, and SSP 1.0 connectors
(``ssc:Real``, ``ssc:Integer``, ``ssc:Boolean``) have no arrays to bind to.  No clocks:
the controller's 5 ms period stays a fixed communication step (``fmi3DoStep``).
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

from ballbot_casadi.fmi.model_description import common_elements, range_attributes
from ballbot_casadi.fmi.spec import FmuSpec, FmuVar, output_dependencies

__all__ = ["model_description3_xml", "FMI3_TYPES", "time_value_reference"]

#: FMI 3.0 element of each type of the variable table.
FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}


def time_value_reference(spec: FmuSpec) -> int:
    """Value reference of the independent variable ``time`` (one past the table)."""
    return len(spec.variables)


def _variable(v: FmuVar) -> list[str]:
    attrs = (f"name={quoteattr(v.name)} valueReference=\"{v.vr}\" "
             f'causality="{v.causality}" variability="{v.variability}"')
    if v.initial is not None:
        attrs += f' initial="{v.initial}"'
    attrs += f" description={quoteattr(v.description)}"
    if v.type == "Real" and v.unit:
        attrs += f' unit="{v.unit}"'
    if v.kind == "derivative":
        attrs += f' derivative="{v.derivative_of}"'
    attrs += range_attributes(v)
    return [f"    <{FMI3_TYPES[v.type]} {attrs}/>"]


def model_description3_xml(spec: FmuSpec, token: str) -> str:
    """FMI 3.0 ``modelDescription.xml`` for ``spec`` with instantiation token ``token``."""
    rows = spec.variables
    units = sorted({"s", *(v.unit for v in rows if v.unit and v.type == "Real")})
    caps = ('canGetAndSetFMUState="true" canSerializeFMUState="true" '
            f'providesDirectionalDerivatives="{str(spec.directional_derivatives).lower()}" '
            f'providesAdjointDerivatives="{str(spec.directional_derivatives).lower()}"')
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="3.0" modelName="{spec.model_name}"',
        f'  instantiationToken="{token}"',
        f"  description={quoteattr(spec.description)}",
        '  generationTool="ballbot-casadi">',
    ]
    if "me" in spec.interfaces:
        out += [f'  <ModelExchange modelIdentifier="{spec.model_identifier}" {caps}/>']
    if "cs" in spec.interfaces:
        out += [f'  <CoSimulation modelIdentifier="{spec.model_identifier}" {caps}',
                '    canHandleVariableCommunicationStepSize="true" hasEventMode="false"',
                '    providesIntermediateUpdate="false" canReturnEarlyAfterIntermediateUpdate='
                '"false"/>']
    out += [*common_elements(spec, units),
            "  <ModelVariables>",
            f'    <Float64 name="time" valueReference="{time_value_reference(spec)}" '
            'causality="independent" variability="continuous" description="simulation time" '
            'unit="s"/>']
    for v in rows:
        out += _variable(v)
    out += ["  </ModelVariables>", "  <ModelStructure>"]
    deps = output_dependencies(rows, dict(spec.dependencies) if spec.dependencies else None)
    vr = {v.name: v.vr for v in rows}

    def unknown(v: FmuVar, tag: str) -> str:
        if tag == "InitialUnknown" or deps is None:
            return f'    <{tag} valueReference="{v.vr}"/>'
        known = " ".join(str(i) for i in sorted(vr[n] for n in deps[v.name]))
        return f'    <{tag} valueReference="{v.vr}" dependencies="{known}"/>'

    out += [unknown(v, "Output") for v in rows if v.causality == "output"]
    out += [unknown(v, "ContinuousStateDerivative") for v in rows if v.kind == "derivative"]
    out += [unknown(v, "InitialUnknown") for v in rows
            if v.causality == "output" and v.initial != "exact" or v.kind == "derivative"]
    out += ["  </ModelStructure>", "</fmiModelDescription>"]
    return "\n".join(out) + "\n"
