"""What an FMU is made of: its variable table and its build specification.

An FMU of this package is one :class:`FmuSpec`: a table of :class:`FmuVar` (the single
source of value references, kinds, start values, ranges, units and descriptions, from
which ``modelDescription.xml`` and the C headers are generated), the CasADi Functions
compiled into it, and its small hand-written C file in ``fmu/`` that fills the shared
layer's ``fmu_model_def`` (see ``fmu/layer/fmi2_common.h``).  :class:`VarTable` builds a table
and assigns the value references; :func:`~ballbot_casadi.fmi.package.build_fmu_from_spec`
turns a spec into a cached, verified ``.fmu``.

Variable kinds (``FmuVar.kind``), their FMI causality/variability and types:

=================  ==========================  ================  =====================
kind               causality / variability     types             value written by
=================  ==========================  ================  =====================
state              output / continuous         Real              importer, integrator
derivative         local / continuous          Real              model ``evaluate``
input              input / continuous          Real              importer
discrete_input     input / discrete            Real, Int, Bool   importer
output             output / continuous         Real              model ``evaluate``
discrete_output    output / discrete           Real, Int, Bool   model (held)
parameter          parameter / fixed           Real, Int, Bool   importer (before init)
local              local / discrete            Real, Int, Bool   model (internal state)
=================  ==========================  ================  =====================

Value references are unique over all types: the Reals first (0, 1, ...), then the
Integers, then the Booleans, each in the order they were added, so each type occupies
one contiguous range (what the C layer indexes).

What another FMU supplies (``tests/fmi/test_fmu_second_model.py`` builds a
Co-Simulation-only one with Real, Integer and Boolean variables this way):

1. its variable table (:class:`VarTable`);
2. the CasADi Functions its C calls (generated into ``<cg_name>.c``);
3. a per-model C file that includes the generated ``<prefix>_vars.h`` and defines
   ``const fmu_model_def fmu_model = {<PREFIX>_MODEL_IDENTIFIER, <PREFIX>_GUID, FMU_CS,
   &<prefix>_variables, sizeof(work), check_initial, initialize, evaluate, do_step,
   event_entered, event_update, jacobian}`` (unused callbacks ``NULL``), addressing its
   values as ``v->r[<PREFIX>_IX_<name>]``, ``v->i[...]``, ``v->b[...]``;
4. an :class:`FmuSpec`, built by
   :func:`~ballbot_casadi.fmi.package.build_fmu_from_spec`.  The generic API fuzzer
   ``fmu/tools/fuzz.c`` runs against it (``build_tool(build, "fuzz")``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import casadi as ca

from ballbot_casadi.core.layout import Layout
from ballbot_casadi.core.params import PARAM_RULES
from ballbot_casadi.errors import BuildError

__all__ = [
    "KINDS",
    "TYPES",
    "INT32_MIN",
    "INT32_MAX",
    "FmuVar",
    "FmuBlock",
    "FmuSpec",
    "VarTable",
    "value_range",
    "c_ident",
    "block_start",
    "sparsity_dependencies",
    "output_dependencies",
]

KINDS = ("state", "derivative", "input", "discrete_input", "output", "discrete_output",
         "parameter", "local")
TYPES = ("Real", "Integer", "Boolean")
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1

# kinds that need / must not have a start value (the others are calculated by the model)
_WITH_START = ("state", "input", "discrete_input", "parameter")
_REAL_ONLY = ("state", "derivative", "input", "output")


@dataclass(frozen=True)
class FmuVar:
    """One FMU variable (the single source of its VR, kind, start value and metadata).

    ``rule`` (Real parameters) is a key of
    :data:`~ballbot_casadi.core.params.PARAM_RULES`; ``bounds`` is a closed range
    ``(lo, hi)`` (Integer variables; default the 32-bit range).  ``missing`` (Real inputs
    and held Real outputs) makes NaN an accepted value meaning "no value" (a missing
    sensor reading; a stored NaN output then survives FMU states); Inf is still refused.  ``fixed`` (Real parameters) pins the value to ``start``: the FMU
    refuses any other value (range ``[start, start]``), and the text says why (e.g. a
    build-time constant computed from it).  ``derivative_of`` is the
    VR of the state of a derivative.  ``start_from`` (states) is the VR of the Real
    parameter the state starts from (``x0_<name>``): the state is then ``initial =
    "calculated"`` (no start value of its own), equal to that parameter until
    initialisation ends, so an importer or an SSP parameter set binds a parameter rather
    than the start value of an output.  ``index`` is set by :class:`VarTable`: a state's
    number, a derivative's state number, the Jacobian row of a continuous output or the
    column of a continuous input among its kind, else the position among its kind and
    type.
    """

    name: str
    vr: int
    kind: str
    start: float | int | bool | None
    unit: str | None
    description: str
    rule: str | None = None
    derivative_of: int | None = None
    type: str = "Real"
    bounds: tuple[float, float] | None = None
    index: int = 0
    missing: bool = False
    start_from: int | None = None
    fixed: str | None = None

    @property
    def variability(self) -> str:
        if self.kind == "parameter":
            return "fixed"
        if self.kind in ("state", "derivative", "input", "output"):
            return "continuous"
        return "discrete"

    @property
    def causality(self) -> str:
        return {"state": "output", "derivative": "local", "input": "input",
                "discrete_input": "input", "output": "output", "discrete_output": "output",
                "parameter": "parameter", "local": "local"}[self.kind]

    @property
    def initial(self) -> str | None:
        """``exact`` (start value given), ``calculated`` or ``None`` (inputs: no attribute)."""
        if self.kind in ("input", "discrete_input"):
            return None
        if self.start_from is not None:
            return "calculated"
        return "exact" if self.kind in _WITH_START else "calculated"


def value_range(v: FmuVar) -> tuple[float, float, bool, bool, str | None]:
    """Allowed stored values of ``v``: ``(lo, hi, lo_open, hi_open, text)``.

    Real variables with a ``rule`` use :data:`~ballbot_casadi.core.params.PARAM_RULES`
    (the one definition; FMU values are SI and radians, so an angle's text also gives the
    range in radians); other Reals need only be finite (``text`` None).  Integers are
    within ``bounds`` (default the 32-bit range), Booleans 0 or 1.  A ``fixed`` Real
    allows its start value only.
    """
    if v.type == "Boolean":
        return 0.0, 1.0, False, False, "fmi2True (1) or fmi2False (0)"
    if v.type == "Integer":
        lo, hi = v.bounds if v.bounds is not None else (INT32_MIN, INT32_MAX)
        return float(lo), float(hi), False, False, f"an integer in [{int(lo)}, {int(hi)}]"
    if v.fixed is not None:
        start = float(v.start)
        return start, start, False, False, f"its build value {start!r}: {v.fixed}"
    if v.rule is None:
        return -math.inf, math.inf, False, False, None
    lo, hi, lo_open, hi_open, text = PARAM_RULES[v.rule]
    if v.unit == "rad":
        text = (f"{text}; FMU values are radians: {lo:.6g} {'<' if lo_open else '<='} value "
                f"{'<' if hi_open else '<='} {hi:.6g}")
    return lo, hi, lo_open, hi_open, text


def c_ident(name: str) -> str:
    """C identifier of a variable name (``der(x)`` -> ``der_x``)."""
    ident = name.replace("(", "_").replace(")", "").replace(".", "_")
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", ident):
        raise BuildError(f"variable name {name!r} does not map to a C identifier")
    return ident


def _contains(lo: float, hi: float, lo_open: bool, hi_open: bool, x: float) -> bool:
    return (x > lo if lo_open else x >= lo) and (x < hi if hi_open else x <= hi)


class VarTable:
    """Builds a variable table: add variables in order, then :meth:`rows` assigns VRs.

    Example::

        t = VarTable()
        t.add("x", "state", "position", start=0.0, unit="m")
        t.add("der(x)", "derivative", "velocity", derivative_of="x")
        t.add("seed", "parameter", "noise seed", type="Integer", start=0, bounds=(0, 9))
        rows = t.rows()
    """

    def __init__(self) -> None:
        self._rows: list[dict] = []

    def add(self, name: str, kind: str, description: str, *, type: str = "Real",
            start: float | int | bool | None = None, unit: str | None = None,
            rule: str | None = None, bounds: tuple[float, float] | None = None,
            derivative_of: str | None = None, missing: bool = False,
            start_from: str | None = None, fixed: str | None = None) -> None:
        """Append one variable (see :class:`FmuVar`; ``derivative_of`` is a state's name,
        ``start_from`` a Real parameter's name)."""
        self._rows.append(dict(name=name, kind=kind, description=description, type=type,
                               start=start, unit=unit, rule=rule, bounds=bounds,
                               derivative_of=derivative_of, missing=missing,
                               start_from=start_from, fixed=fixed))

    def rows(self) -> tuple[FmuVar, ...]:
        """The table ordered by value reference (Reals, Integers, Booleans).

        Raises
        ------
        BuildError
            Duplicate names, unknown kind or type, a kind the type cannot have, a
            missing or superfluous start value, a start value outside the range, a
            derivative of an unknown state or a state without exactly one derivative.
        """
        ordered = [r for t in TYPES for r in self._rows if r["type"] == t]
        unknown = [r for r in self._rows if r["type"] not in TYPES or r["kind"] not in KINDS]
        if unknown:
            r = unknown[0]
            raise BuildError(f"variable {r['name']!r}: unknown type {r['type']!r} or kind "
                             f"{r['kind']!r} (types {TYPES}, kinds {KINDS})")
        vr_of = {r["name"]: i for i, r in enumerate(ordered)}
        if len(vr_of) != len(ordered):
            raise BuildError("variable names must be unique")
        counters: dict[tuple[str, str], int] = {}
        state_no: dict[int, int] = {}
        out: list[FmuVar] = []
        for vr, r in enumerate(ordered):
            key = (r["type"], r["kind"])
            index = counters.get(key, 0)
            counters[key] = index + 1
            der = None
            if r["kind"] == "state":
                state_no[vr] = index
            if r["kind"] == "derivative":
                if r["derivative_of"] not in vr_of or ordered[vr_of[r["derivative_of"]]][
                        "kind"] != "state":
                    raise BuildError(f"{r['name']!r} is the derivative of "
                                     f"{r['derivative_of']!r}, which is not a state")
                der = vr_of[r["derivative_of"]]
                index = state_no.get(der, -1)
                if index < 0:
                    raise BuildError(f"{r['name']!r}: add the state before its derivative")
            src = None
            if r["start_from"] is not None:
                p = ordered[vr_of[r["start_from"]]] if r["start_from"] in vr_of else None
                if r["kind"] != "state" or p is None or p["kind"] != "parameter" or \
                        p["type"] != "Real":
                    raise BuildError(f"{r['name']!r}: only a state can start from a Real "
                                     f"parameter, {r['start_from']!r} is none")
                src = vr_of[r["start_from"]]
            v = FmuVar(name=r["name"], vr=vr, kind=r["kind"], start=r["start"], unit=r["unit"],
                       description=r["description"], rule=r["rule"], derivative_of=der,
                       type=r["type"], bounds=r["bounds"], index=index,
                       missing=bool(r["missing"]), start_from=src, fixed=r["fixed"])
            _check_var(v)
            out.append(v)
        ders = sorted(v.derivative_of for v in out if v.kind == "derivative")
        if ders != sorted(state_no):
            raise BuildError("every state needs exactly one derivative")
        return tuple(out)


def _check_var(v: FmuVar) -> None:
    if v.type != "Real" and v.kind in _REAL_ONLY:
        raise BuildError(f"{v.name!r}: a {v.type} variable cannot be of kind {v.kind!r}")
    if v.rule is not None and (v.type != "Real" or v.rule not in PARAM_RULES):
        raise BuildError(f"{v.name!r}: rule {v.rule!r} must be a PARAM_RULES key of a Real")
    if v.bounds is not None and v.type != "Integer":
        raise BuildError(f"{v.name!r}: bounds are for Integer variables")
    if v.fixed is not None and (v.type != "Real" or v.kind != "parameter"
                                or not isinstance(v.start, float) or not math.isfinite(v.start)):
        raise BuildError(f"{v.name!r}: only a Real parameter with a finite start value can be "
                         "fixed")
    if v.missing and (v.type != "Real" or v.kind not in ("input", "discrete_input",
                                                         "discrete_output")):
        raise BuildError(f"{v.name!r}: only Real inputs and held outputs may accept NaN as a "
                         "missing value")
    if v.start_from is not None:
        if v.start is not None:
            raise BuildError(f"{v.name!r}: a state that starts from a parameter has no start "
                             "value of its own")
    elif (v.start is None) == (v.kind in _WITH_START):
        need = "needs" if v.kind in _WITH_START else "must not have"
        raise BuildError(f"{v.name!r}: a variable of kind {v.kind!r} {need} a start value")
    if v.start is not None:
        x = float(v.start)
        if v.type == "Boolean" and not isinstance(v.start, bool):
            raise BuildError(f"{v.name!r}: Boolean start value must be a bool")
        if v.type == "Integer" and (isinstance(v.start, bool) or x != int(x)):
            raise BuildError(f"{v.name!r}: Integer start value must be an int")
        lo, hi, lo_open, hi_open, text = value_range(v)
        if not math.isfinite(x) or not _contains(lo, hi, lo_open, hi_open, x):
            raise BuildError(f"{v.name!r}: start value {v.start!r} is not {text or 'finite'}")


def block_start(rows: Sequence[FmuVar], names: Sequence[str]) -> int:
    """Value index of the first of ``names``, which must have consecutive VRs (one type).

    For the per-model C, which addresses a block (a vector argument of a generated
    Function) by its first element.

    Raises
    ------
    BuildError
        The names are missing or not consecutive.
    """
    by_name = {v.name: v for v in rows}
    try:
        vrs = [by_name[n].vr for n in names]
    except KeyError as exc:
        raise BuildError(f"block variable {exc.args[0]!r} is not in the table") from None
    if vrs != list(range(vrs[0], vrs[0] + len(vrs))):
        raise BuildError(f"variables {names[0]!r}..{names[-1]!r} must have consecutive VRs")
    first = by_name[names[0]]
    return first.vr - min(v.vr for v in rows if v.type == first.type)


def sparsity_dependencies(f: ca.Function, out: str, rows: Sequence[str],
                          knowns: dict[str, Sequence[Sequence[str]]]) -> dict[str, tuple[str, ...]]:
    """Which known variables each element of output ``out`` of ``f`` depends on, from the
    structural sparsity of its Jacobian (``f.sparsity_jac``), not by hand.

    Parameters
    ----------
    f
        The Function that computes the unknowns.
    out
        Name of its output; ``rows`` names the FMU variable of each element.
    knowns
        ``{input name: per element, the FMU variables that feed it}`` (an element may be
        fed by several variables, e.g. a torque and its disturbance; an input not listed,
        such as the parameter vector, is not a known of the model structure).

    Returns
    -------
    dict
        Variable name -> sorted names of the knowns it depends on (FMI-version neutral:
        the 2.0 and 3.0 model descriptions render it with their own indices).
    """
    o = f.index_out(out)
    if len(rows) != f.numel_out(o):
        raise BuildError(f"{f.name()}: output {out} has {f.numel_out(o)} entries, {len(rows)} named")
    deps: dict[str, set[str]] = {r: set() for r in rows}
    for arg, names in knowns.items():
        i = f.index_in(arg)
        if len(names) != f.numel_in(i):
            raise BuildError(f"{f.name()}: input {arg} has {f.numel_in(i)} entries, "
                             f"{len(names)} named")
        sp = f.sparsity_jac(i, o)
        for r, c in zip(*sp.get_triplet()):
            deps[rows[r]].update(names[c])
    return {r: tuple(sorted(d)) for r, d in deps.items()}


def output_dependencies(rows: Sequence[FmuVar], continuous: dict[str, tuple[str, ...]] | None
                        ) -> dict[str, tuple[str, ...]] | None:
    """The dependencies of every output and state derivative (name -> known names).

    A state (an output) depends on itself; a held (discrete) output is written only by the
    model's initialize / do_step / event update, so it depends on no known directly;
    continuous outputs and derivatives take ``continuous`` (from
    :func:`sparsity_dependencies`).  ``None`` if a continuous unknown is not covered (the
    model description then omits the lists: "depends on every known").
    """
    out: dict[str, tuple[str, ...]] = {}
    for v in rows:
        if v.kind == "state":
            out[v.name] = (v.name,)
        elif v.kind == "discrete_output":
            out[v.name] = ()
        elif v.kind in ("output", "derivative"):
            if continuous is None or v.name not in continuous:
                return None
            out[v.name] = continuous[v.name]
    return out


@dataclass(frozen=True)
class FmuBlock:
    """A packed vector the per-model C addresses by name (``<PREFIX>_<NAME>_<FIELD>``).

    Attributes
    ----------
    name
        C name of the block (``"c"``, ``"x_hat"``; upper-cased in the C names).
    layout
        Its fields (:class:`~ballbot_casadi.core.layout.Layout`); ``None`` for a vector
        without named parts (only its position and size are generated).
    variables
        The FMU variables that store it, in element order (consecutive value references
        of one type); empty for a vector that lives only in the model's work memory.
    """

    name: str
    layout: Layout | None
    variables: tuple[str, ...] = ()

    @property
    def size(self) -> int:
        return self.layout.size if self.layout is not None else len(self.variables)


@dataclass(frozen=True, eq=False)
class FmuSpec:
    """Everything that defines one FMU; :func:`~ballbot_casadi.fmi.package.build_fmu_from_spec`
    builds it.

    Attributes
    ----------
    model_identifier
        FMI model identifier (binary and archive name).
    description
        ``description`` attribute of ``modelDescription.xml``.
    prefix
        Lower-case C prefix: generated headers ``<prefix>_vr.h`` (value references
        ``<PREFIX>_VR_<name>``, value indices ``<PREFIX>_IX_<name>``, sizes, GUID; for C
        hosts too) and ``<prefix>_vars.h`` (the ``fmu_variables`` table
        ``<prefix>_variables`` for the per-model C file).
    variables
        The variable table (:meth:`VarTable.rows`).
    functions
        CasADi Functions generated into ``<cg_name>.c`` (called by the per-model C).
    model_source
        The per-model C file (defines ``fmu_model``): a path relative to ``fmu/``
        (``"plant/plant_model.c"``), or a :class:`~pathlib.Path`.
    cg_name
        Basename of the generated CasADi C.
    extra_sources
        Further C sources and headers compiled in (copied into ``sources/``).
    interfaces
        ``("me", "cs")``, ``("cs",)`` or ``("me",)``.
    defines
        Extra ``#define <PREFIX>_<name> <value>`` lines of ``<prefix>_vr.h``.
    blocks
        The packed vectors of the per-model C (:class:`FmuBlock`): their value-array
        positions, sizes and field offsets are generated into ``<prefix>_vr.h``.
    function_aliases
        ``(Function name, C name)`` pairs: the C name of a Function in the generated
        argument positions (``<PREFIX>_<C name>_ARG_<input>``); default the Function's
        name upper-cased without a leading ``ballbot_``.
    dependencies
        Continuous outputs and state derivatives -> the knowns (states, inputs) they
        depend on (:func:`sparsity_dependencies`); with it (or without any continuous
        unknown) ``ModelStructure`` lists every output's and derivative's dependencies
        (:func:`output_dependencies`).
    directional_derivatives
        The per-model C supplies ``jacobian`` (``providesDirectionalDerivative``).
    default_experiment
        ``(startTime, stopTime, stepSize)``.
    """

    model_identifier: str
    description: str
    prefix: str
    variables: tuple[FmuVar, ...]
    functions: tuple[ca.Function, ...]
    model_source: str | Path
    cg_name: str
    extra_sources: tuple[Path, ...] = ()
    interfaces: tuple[str, ...] = ("me", "cs")
    defines: tuple[tuple[str, str], ...] = ()
    blocks: tuple[FmuBlock, ...] = ()
    function_aliases: tuple[tuple[str, str], ...] = ()
    dependencies: tuple[tuple[str, tuple[str, ...]], ...] = ()
    directional_derivatives: bool = False
    default_experiment: tuple[float, float, float] = (0.0, 5.0, 0.005)
    model_name: str = field(default="")

    def __post_init__(self) -> None:
        if not re.fullmatch(r"[a-z][a-z0-9_]*", self.prefix):
            raise BuildError(f"FmuSpec.prefix {self.prefix!r} must be a lower-case C identifier")
        if not self.interfaces or set(self.interfaces) - {"me", "cs"}:
            raise BuildError(f"FmuSpec.interfaces {self.interfaces!r}: 'me' and/or 'cs'")
        if [v.vr for v in self.variables] != list(range(len(self.variables))):
            raise BuildError("variables must be ordered by value reference 0, 1, ...")
        if not self.model_name:
            object.__setattr__(self, "model_name", self.model_identifier)
