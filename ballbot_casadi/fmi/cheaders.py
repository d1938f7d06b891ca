"""C headers generated from an FMU's variable table (the same table as its XML).

* ``<prefix>_vr.h`` - for the per-model C file and for C hosts: model identifier, GUID,
  numbers of variables, value references ``<PREFIX>_VR_<name>`` and value indices
  ``<PREFIX>_IX_<name>`` (position in the value array of the variable's type), the work
  sizes of the generated CasADi code, the spec's extra defines and the names of every
  packed vector and Function argument (:func:`named_defines`, the one generator of them).
* ``<prefix>_vars.h`` - included once, by the per-model C file: the variable
  descriptors (name, kind, start value, range and its text) and the ``fmu_variables``
  table ``<prefix>_variables`` that the model passes to the shared layer.
* ``fmu_model_info.h`` - the same sizes under neutral names (``FMU_INFO_*``), so generic
  C tools (``fmu/tools/fuzz.c``) compile against any FMU of the package.
"""

from __future__ import annotations

import math
from typing import Sequence

import casadi as ca

from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi.spec import (
    TYPES,
    FmuBlock,
    FmuSpec,
    FmuVar,
    block_start,
    c_ident,
    value_range,
)

__all__ = ["vr_header", "vars_header", "info_header", "work_sizes", "named_defines",
           "function_alias"]

_KIND_C = {"state": "FMU_KIND_STATE", "derivative": "FMU_KIND_DERIVATIVE",
           "input": "FMU_KIND_INPUT", "discrete_input": "FMU_KIND_DISCRETE_INPUT",
           "output": "FMU_KIND_OUTPUT", "discrete_output": "FMU_KIND_DISCRETE_OUTPUT",
           "parameter": "FMU_KIND_PARAMETER", "local": "FMU_KIND_LOCAL"}
_TYPE_WORD = {"Real": "REALS", "Integer": "INTEGERS", "Boolean": "BOOLEANS"}


def _c_double(v: float) -> str:
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "-HUGE_VAL"
    return repr(float(v))


def _c_str(s: str | None) -> str:
    if s is None:
        return "NULL"
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _of_type(rows: Sequence[FmuVar], t: str) -> list[FmuVar]:
    return [v for v in rows if v.type == t]


def _vr0(rows: Sequence[FmuVar], t: str) -> int:
    vrs = [v.vr for v in rows if v.type == t]
    return vrs[0] if vrs else sum(v.type in TYPES[:TYPES.index(t)] for v in rows)


def work_sizes(functions: Sequence[ca.Function]) -> dict[str, int]:
    """Largest ``sz_arg``, ``sz_res``, ``sz_iw``, ``sz_w`` of the generated Functions."""
    return {k: max([int(getattr(f, f"sz_{k}")()) for f in functions] + [1])
            for k in ("arg", "res", "iw", "w")}


def function_alias(spec: FmuSpec, f: ca.Function) -> str:
    """C name of ``f`` in the generated names: the spec's alias, else the Function's name
    upper-cased without a leading ``ballbot_``."""
    alias = dict(spec.function_aliases).get(f.name())
    return alias if alias is not None else c_ident(f.name()).upper().removeprefix("BALLBOT_")


def _upper(name: str) -> str:
    return c_ident(name).upper()


def _block_defines(spec: FmuSpec, block: FmuBlock) -> list[tuple[str, int]]:
    B = _upper(block.name)
    out: list[tuple[str, int]] = []
    if block.variables:
        if len(block.variables) != block.size:
            raise BuildError(f"{spec.model_identifier}: block {block.name} has "
                             f"{len(block.variables)} variables, its layout {block.size} entries")
        out.append((f"{B}_IX", block_start(spec.variables, block.variables)))
    out.append((f"{B}_N", block.size))
    if block.layout is not None:
        for f in block.layout.fields:
            sl = block.layout[f]
            out += [(f"{B}_{_upper(f)}", sl.start), (f"{B}_{_upper(f)}_N", sl.stop - sl.start)]
    return out


def _function_defines(spec: FmuSpec, f: ca.Function) -> list[tuple[str, int | str]]:
    A = function_alias(spec, f)
    out: list[tuple[str, int | str]] = [(f"{A}_FN", f.name()), (f"{A}_N_ARG", f.n_in()),
                                        (f"{A}_N_RES", f.n_out())]
    for kind, names, numel in (("ARG", f.name_in(), f.numel_in), ("RES", f.name_out(),
                                                                    f.numel_out)):
        for i, n in enumerate(names):
            out += [(f"{A}_{kind}_{_upper(n)}", i), (f"{A}_{kind}_{_upper(n)}_N", int(numel(i)))]
    return out


def named_defines(spec: FmuSpec) -> list[str]:
    """``#define`` lines naming every packed vector and Function argument of ``spec``.

    For each :class:`~ballbot_casadi.fmi.spec.FmuBlock` ``B`` (upper-cased name):
    ``<PREFIX>_<B>_IX`` (value index of its first element, if stored in variables),
    ``<PREFIX>_<B>_N`` (size) and, per layout field ``F``, ``<PREFIX>_<B>_<F>`` (offset)
    and ``<PREFIX>_<B>_<F>_N`` (size).  For each Function with C name ``A``
    (:func:`function_alias`): ``<PREFIX>_<A>_FN`` (its C symbol), ``<PREFIX>_<A>_N_ARG``,
    ``<PREFIX>_<A>_N_RES`` and, per input ``I`` and output ``O`` (from ``name_in()``,
    ``name_out()``), ``<PREFIX>_<A>_ARG_<I>``, ``<PREFIX>_<A>_RES_<O>`` (positions) with
    ``_N`` (number of entries).

    Raises
    ------
    BuildError
        Two generated names coincide (e.g. fields differing only in case), or a block's
        variables are missing, not consecutive or not as many as its layout's entries.
    """
    P = spec.prefix.upper()
    pairs: list[tuple[str, int | str]] = []
    for block in spec.blocks:
        pairs += _block_defines(spec, block)
    for f in spec.functions:
        pairs += _function_defines(spec, f)
    taken = {n for n, _ in spec.defines}
    seen: set[str] = set()
    for n, _ in pairs:
        if n in seen or n in taken:
            raise BuildError(f"{spec.model_identifier}: the generated C name {P}_{n} is "
                             "defined twice (rename a block, field or Function argument)")
        seen.add(n)
    return [f"#define {P}_{n} {v}" for n, v in pairs]


def vr_header(spec: FmuSpec, guid: str) -> str:
    """``<prefix>_vr.h``: identifier, GUID, sizes, VRs, value indices, extra defines."""
    P, rows = spec.prefix.upper(), spec.variables
    lines = [
        f"/* {spec.prefix}_vr.h - GENERATED by ballbot_casadi/fmi from the variable table;",
        f" * do not edit.  Value references and sizes of {spec.model_identifier}. */",
        f"#ifndef {P}_VR_H",
        f"#define {P}_VR_H",
        f'#define {P}_MODEL_IDENTIFIER "{spec.model_identifier}"',
        f'#define {P}_GUID "{guid}"',
        *[f"#define {P}_N_{_TYPE_WORD[t]} {len(_of_type(rows, t))}" for t in TYPES],
        *[f"#define {P}_VR0_{_TYPE_WORD[t]} {_vr0(rows, t)}" for t in TYPES],
        f"#define {P}_N_STATES {sum(v.kind == 'state' for v in rows)}",
        *[f"#define {P}_SZ_{k.upper()} {n}" for k, n in work_sizes(spec.functions).items()],
        *[f"#define {P}_{name} {value}" for name, value in spec.defines],
        "/* packed vectors and Function arguments by name */",
        *named_defines(spec),
        "",
        "/* value references */",
        *[f"#define {P}_VR_{c_ident(v.name)} {v.vr}" for v in rows],
        "/* value indices: position in the value array of the variable's type */",
        *[f"#define {P}_IX_{c_ident(v.name)} {v.vr - _vr0(rows, v.type)}" for v in rows],
        f"#endif /* {P}_VR_H */",
    ]
    return "\n".join(lines) + "\n"


def _descriptor(v: FmuVar) -> str:
    lo, hi, lo_open, hi_open, text = value_range(v)
    start = 0.0 if v.start is None else float(v.start)
    return (f"    {{{_c_str(v.name)}, {_KIND_C[v.kind]}, {v.index}, {_c_double(start)}, "
            f"{_c_double(lo)}, {_c_double(hi)}, {int(lo_open)}, {int(hi_open)}, "
            f"{_c_str(text)}, {int(v.missing)}, "
            f"{0 if v.start_from is None else v.start_from + 1}}}, /* vr {v.vr} */")


def vars_header(spec: FmuSpec) -> str:
    """``<prefix>_vars.h``: variable descriptors and the ``fmu_variables`` table."""
    p, P, rows = spec.prefix, spec.prefix.upper(), spec.variables
    states = [v for v in rows if v.kind == "state"]
    ders = {v.derivative_of: v for v in rows if v.kind == "derivative"}
    lines = [
        f"/* {p}_vars.h - GENERATED by ballbot_casadi/fmi from the variable table;",
        f" * do not edit.  Included once, by the per-model C file of {spec.model_identifier}. */",
        f"#ifndef {P}_VARS_H",
        f"#define {P}_VARS_H",
        "#include <math.h>",
        "#include <stddef.h>",
        '#include "fmi2_common.h"',
        f'#include "{p}_vr.h"',
        "",
    ]
    tables = []
    for t in TYPES:
        of_t = _of_type(rows, t)
        if of_t:
            name = f"{p}_{_TYPE_WORD[t].lower()}"
            lines += [f"static const fmu_var {name}[{len(of_t)}] = {{",
                      *[_descriptor(v) for v in of_t], "};"]
            tables.append(name)
        else:
            tables.append("NULL")
    if states:
        lines += [f"static const size_t {p}_state_ix[{len(states)}] = {{"
                  + ", ".join(str(v.vr) for v in states) + "};",
                  f"static const size_t {p}_der_ix[{len(states)}] = {{"
                  + ", ".join(str(ders[v.vr].vr) for v in states) + "};"]
    n_out = sum(v.kind == "output" for v in rows)
    n_in = sum(v.kind == "input" for v in rows)
    lines += [
        f"static const fmu_variables {p}_variables = {{",
        "    {" + ", ".join(f"{P}_N_{_TYPE_WORD[t]}" for t in TYPES) + "},",
        "    {" + ", ".join(f"{P}_VR0_{_TYPE_WORD[t]}" for t in TYPES) + "},",
        "    {" + ", ".join(tables) + "},",
        f"    {len(states)}, " + (f"{p}_state_ix, {p}_der_ix," if states else "NULL, NULL,"),
        f"    {n_out}, {n_in},",
        "};",
        "",
        f"#endif /* {P}_VARS_H */",
    ]
    return "\n".join(lines) + "\n"


def info_header(spec: FmuSpec) -> str:
    """``fmu_model_info.h``: sizes and input VRs under neutral names for generic C tools."""
    P, rows = spec.prefix.upper(), spec.variables
    inputs = [v.vr for v in rows if v.type == "Real" and v.kind in ("input", "discrete_input")]
    lines = [
        "/* fmu_model_info.h - GENERATED by ballbot_casadi/fmi; do not edit.  This FMU's",
        " * sizes under neutral names, for generic C tools (fmu/tools/fuzz.c). */",
        "#ifndef FMU_MODEL_INFO_H",
        "#define FMU_MODEL_INFO_H",
        f'#include "{spec.prefix}_vr.h"',
        f"#define FMU_INFO_N_REALS {P}_N_REALS",
        f"#define FMU_INFO_N_INTEGERS {P}_N_INTEGERS",
        f"#define FMU_INFO_N_BOOLEANS {P}_N_BOOLEANS",
        f"#define FMU_INFO_VR0_REALS {P}_VR0_REALS",
        f"#define FMU_INFO_VR0_INTEGERS {P}_VR0_INTEGERS",
        f"#define FMU_INFO_VR0_BOOLEANS {P}_VR0_BOOLEANS",
        f"#define FMU_INFO_N_VARS ({P}_N_REALS + {P}_N_INTEGERS + {P}_N_BOOLEANS)",
        f"#define FMU_INFO_N_STATES {P}_N_STATES",
        *[f"#define FMU_INFO_SZ_{k} {P}_SZ_{k}" for k in ("ARG", "RES", "IW", "W")],
        f"#define FMU_INFO_N_REAL_INPUTS {len(inputs)}",
        "#define FMU_INFO_REAL_INPUT_VRS {" + (", ".join(map(str, inputs)) or "0") + "}",
        "#endif /* FMU_MODEL_INFO_H */",
    ]
    return "\n".join(lines) + "\n"
