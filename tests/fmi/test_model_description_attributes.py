"""Each variable's attributes in the model description (FMI 2.0 and 3.0), read back by fmpy,
against the variable table: unit (Reals only), start, and min/max of the settable variables
(the allowed range), for the plant and the controller."""

from __future__ import annotations

import functools
import math

import pytest
from fmpy import read_model_description

from ballbot_casadi.fmi.controller.controller import controller_spec
from ballbot_casadi.fmi.model_description import model_description_xml
from ballbot_casadi.fmi.model_description3 import model_description3_xml
from ballbot_casadi.fmi.plant.plant import plant_spec
from ballbot_casadi.fmi.spec import value_range

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

@functools.lru_cache(maxsize=None)
def _spec(which: str):
    return plant_spec() if which == "plant" else controller_spec()


def _read(tmp_path, spec, version: int):
    p = tmp_path / f"md{version}.xml"
    guid = "{00000000-0000-0000-0000-000000000000}"
    p.write_text(model_description_xml(spec, guid, ["a.c"]) if version == 2
                 else model_description3_xml(spec, guid))
    return {v.name: v for v in read_model_description(str(p), validate=False).modelVariables}


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("which", ["plant", "controller"])
def test_unit_start_and_range_of_every_variable(tmp_path, which, version):
    spec = _spec(which)
    md = _read(tmp_path, spec, version)
    settable = ("parameter", "discrete_input", "input")
    n_unit = n_range = 0
    for v in spec.variables:
        got = md[v.name]
        if v.kind == "derivative":
            continue
        want_unit = v.unit if v.type == "Real" else None
        assert (got.unit or None) == want_unit, v.name
        n_unit += want_unit is not None
        if v.start is not None:
            want = v.start if v.type != "Boolean" else bool(v.start)
            have = got.start
            if v.type == "Real":
                assert float(have) == float(want), v.name
            elif v.type == "Integer":
                assert int(have) == int(want), v.name
            else:
                assert str(have).lower() in ("true" if want else "false", str(int(want))), v.name
        if v.type != "Boolean" and v.kind in settable:
            lo, hi, _, _, _ = value_range(v)
            for attr, bound in (("min", lo), ("max", hi)):
                have = getattr(got, attr)
                if math.isfinite(bound):
                    assert have is not None and float(have) == bound, (v.name, attr)
                    n_range += 1
                else:
                    assert have is None, (v.name, attr)
    assert n_unit > 10 and n_range > 10
