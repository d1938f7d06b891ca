"""The SSP writer refuses duplicate and empty component names, each alone (issue 23, fresh
mutants: the name check's ``or`` turned into ``and`` -- only a list that was both duplicated
and empty was refused).  The check comes before any FMU is opened, so no FMU is needed."""

from __future__ import annotations

import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.fmi.system.ssp import SspComponent, write_ssp


@pytest.mark.parametrize("names", [("plant", "plant"), ("plant", ""), ("", "controller")])
def test_duplicate_or_empty_component_names_are_refused(tmp_path, names):
    comps = [SspComponent(n, tmp_path / f"f{i}.fmu") for i, n in enumerate(names)]
    with pytest.raises(BuildError, match="unique and non-empty"):
        write_ssp(tmp_path / "s.ssp", comps, [], name="x", stop=1.0, step=0.005)
    assert not (tmp_path / "s.ssp").exists()


@pytest.mark.parametrize("start, stop, step", [(0.0, 1.0, 0.0), (0.0, 0.0, 0.005), (1.0, 0.5, 0.005),
                                               (0.0, float("inf"), 0.005), (float("nan"), 1.0, 0.005)])
def test_a_bad_default_experiment_is_refused(tmp_path, start, stop, step):
    comps = [SspComponent("plant", tmp_path / "p.fmu")]
    with pytest.raises(BuildError, match="default experiment"):
        write_ssp(tmp_path / "s.ssp", comps, [], name="x", stop=stop, step=step, start=start)
