"""A user's plant FMU is verified before the Python masters extract it or load its binary."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from ballbot_casadi.errors import FileFormatError
from ballbot_casadi.fmi.masters import plant_loop
from ballbot_casadi.studies.registry import study_scenarios


def _not_an_fmu(tmp_path):
    bad = tmp_path / "Plant.fmu"
    with zipfile.ZipFile(bad, "w") as zf:
        zf.writestr("modelDescription.xml", "<fmiModelDescription/>")  # no binary
    return bad


@pytest.fixture
def no_extract(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the FMU was extracted before it was verified")
    monkeypatch.setattr(plant_loop, "extract", refuse)
    monkeypatch.setattr(plant_loop, "simulate_fmu", refuse)


def test_closed_loop_cosim_refuses_an_incomplete_fmu_before_extracting_it(tmp_path, no_extract):
    sc = study_scenarios("zero")[0].replace(duration=0.05)
    with pytest.raises(FileFormatError, match=r"^plant FMU .*Plant\.fmu"):
        plant_loop.closed_loop_cosim(sc, fmu=_not_an_fmu(tmp_path))


def test_open_loop_refuses_an_incomplete_fmu_before_fmpy_loads_it(tmp_path, no_extract):
    with pytest.raises(FileFormatError, match=r"^plant FMU .*Plant\.fmu"):
        plant_loop.cosim_open_loop(_not_an_fmu(tmp_path), np.zeros(3), 0.01)
