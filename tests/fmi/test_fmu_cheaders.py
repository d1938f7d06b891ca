"""The C names of packed vectors and Function arguments (fmi/cheaders.named_defines) and
their use in the per-model C (one argument convention, no raw offsets)."""

from __future__ import annotations

import re

import pytest

from ballbot_casadi.core.layout import Layout
from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi.cheaders import function_alias, named_defines
from ballbot_casadi.fmi.controller.controller import controller_spec
from ballbot_casadi.fmi.package import fmu_source_dir
from ballbot_casadi.fmi.plant.plant import plant_spec
from ballbot_casadi.fmi.spec import FmuBlock, block_start

MODELS = ("plant/plant_model.c", "controller/controller_model.c", "reference/reference_model.c")


def _defines(spec) -> dict[str, str]:
    P = spec.prefix.upper() + "_"
    out = {}
    for line in named_defines(spec):
        _, name, value = line.split(" ", 2)
        out[name.removeprefix(P)] = value
    return out


@pytest.fixture(scope="module")
def ctrl():
    return controller_spec()


def test_blocks_follow_their_layouts_and_variables(ctrl):
    for spec in (plant_spec(), ctrl):
        d = _defines(spec)
        for block in spec.blocks:
            B = block.name.upper()
            assert int(d[f"{B}_N"]) == block.size
            if block.variables:
                assert int(d[f"{B}_IX"]) == block_start(spec.variables, block.variables)
            for f in block.layout.fields if block.layout is not None else ():
                sl = block.layout[f]
                assert int(d[f"{B}_{f.upper()}"]) == sl.start
                assert int(d[f"{B}_{f.upper()}_N"]) == sl.stop - sl.start
    d = _defines(ctrl)
    # the controller state c: the filters' parts where the Layout puts them
    c = next(b.layout for b in ctrl.blocks if b.name == "c")
    assert int(d["C_XA"]) == c["xa"].start and int(d["C_POS"]) == c["pos"].start
    assert int(d["X_HAT_Q"]) == 2 and int(d["XA_OMEGA"]) == 4 and int(d["REF_V_REF"]) == 12


def test_every_function_argument_is_named_by_position(ctrl):
    for spec in (plant_spec(), ctrl):
        d = _defines(spec)
        for f in spec.functions:
            A = function_alias(spec, f)
            assert d[f"{A}_FN"] == f.name()
            for i, n in enumerate(f.name_in()):
                assert int(d[f"{A}_ARG_{n.upper()}"]) == i
                assert int(d[f"{A}_ARG_{n.upper()}_N"]) == f.numel_in(i)
            for i, n in enumerate(f.name_out()):
                assert int(d[f"{A}_RES_{n.upper()}"]) == i
    assert function_alias(ctrl, ctrl.functions[0]) == "EMBEDDED"
    assert _defines(ctrl)["EMBEDDED_ARG_C"] == "0"


def test_a_name_clash_is_refused(ctrl):
    from dataclasses import replace

    twice = Layout("clash", [("a", 1), ("A", 1)])
    with pytest.raises(BuildError, match="defined twice"):
        named_defines(replace(ctrl, blocks=(FmuBlock("w", twice),)))
    with pytest.raises(BuildError, match="block w has 1 variables"):
        named_defines(replace(ctrl, blocks=(FmuBlock("w", Layout("w", [("a", 2)]), ("Ts",)),)))


@pytest.mark.parametrize("rel", MODELS)
def test_per_model_c_marshals_by_name_through_the_layer(rel):
    text = (fmu_source_dir() / rel).read_text()
    code = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    # one argument convention: every slot by its generated name, every call through the layer
    assert not re.search(r"\b(arg|res)\[\s*\d", code)
    assert re.search(r"\b(arg|res)\[[A-Z]+_\w+_(ARG|RES)_\w+\]", code)
    assert "fmu_casadi_call(" in code and not re.search(r"\w+\(\w+->arg, \w+->res", code)
    # no private copies of the CasADi work struct or the finiteness check
    assert "casadi_int iw[" not in code and "static int all_finite" not in code
    # no raw offsets into a packed vector: r + <NAME> + <digit> / c[<NAME> + <digit>] / x[<digit>]
    assert not re.search(r"\+ *_?[A-Z][A-Z0-9_]* *\+ *[1-9]\b", code)
    assert not re.search(r"\b[xc]\[\d+\]", code)
