"""The model description's indices against the variable table, read back with fmpy:
every ``der(v)`` points at ``v`` (FMI 2.0 indices start at 1), and the initial unknowns
are exactly the outputs not fixed at start plus the derivatives (issue 23, test strength)."""

from __future__ import annotations

import pytest
from fmpy import read_model_description

from ballbot_casadi.fmi.model_description import model_description_xml, xml_number
from ballbot_casadi.fmi.plant.plant import plant_spec

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    spec = plant_spec()
    p = tmp_path_factory.mktemp("md") / "plant.xml"
    p.write_text(model_description_xml(spec, "{00000000-0000-0000-0000-000000000000}", ["a.c"]))
    return spec, read_model_description(str(p), validate=True)


def test_every_derivative_points_at_its_own_state(plant):
    spec, md = plant
    ders = [v for v in md.modelVariables if v.name.startswith("der(")]
    assert ders and len(ders) == len(md.derivatives)
    for v in ders:
        assert v.derivative is not None and v.derivative.name == v.name[4:-1], v.name


def test_initial_unknowns_are_the_free_outputs_and_the_derivatives(plant):
    spec, md = plant
    want = [v.name for v in md.modelVariables
            if (v.causality == "output" and v.initial != "exact") or v.name.startswith("der(")]
    assert [u.variable.name for u in md.initialUnknowns] == want
    assert all(v.initial == "exact" for v in md.modelVariables
               if v.causality == "output" and v.name not in want)


def test_numbers_round_trip_in_the_xml():
    assert float(xml_number(0.1 + 0.2)) == 0.1 + 0.2
    assert xml_number(1e-300) == "1e-300"
