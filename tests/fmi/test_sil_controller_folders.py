"""Where the SIL system's controller FMU is built: the FMI version's own build folder (FMI
2.0 ``<build>/fmu``, FMI 3.0 ``<build>/fmu3``), a path-following scenario's per scenario
under ``path/<name>``, or the folder given.  The builds and the functions they compile are
replaced by recorders here: only the folders are checked."""

from __future__ import annotations

import pytest

from ballbot_casadi.fmi.system import sil
from ballbot_casadi.sim.scenario.file import parse_scenario

PATH = {"name": "folders_path", "duration_s": 1.0, "guidance": "mpc", "cascade": True,
        "path": {"type": "figure_eight", "length": 4.0, "width": 2.0, "speed": 0.5}}


@pytest.fixture
def built(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(sil, "build_root", lambda: tmp_path / "b")
    monkeypatch.setattr(sil, "path_law", lambda sc: ("law", sc.name))
    monkeypatch.setattr(sil, "path_embedded_function", lambda law, est: ("path_fn", law, est))
    monkeypatch.setattr(sil, "embedded_function", lambda c, e: ("fn", c, e))
    monkeypatch.setattr(sil, "controller_spec", lambda *a, **k: ("spec", a, tuple(k)))
    monkeypatch.setattr(sil, "controller_values", lambda sc, *a: {"n": len(a)})
    monkeypatch.setattr(sil, "build_fmu_from_spec",
                        lambda spec, out, fmi_version=2: calls.append((spec, out, fmi_version))
                        or f"fmu{len(calls)}")
    return calls, tmp_path / "b"


@pytest.mark.parametrize("version, folder", [(2, "fmu"), (3, "fmu3")])
def test_a_path_scenarios_controller_is_built_per_scenario_in_its_versions_folder(
        built, version, folder):
    calls, root = built
    sc = parse_scenario(PATH).scenario
    fmu, values = sil.sil_controller(sc, fmi_version=version)
    assert fmu == "fmu1" and values == {"n": 2}  # the path variant's values: function and law
    ((spec, out, v),) = calls
    assert out == root / folder / "path" / "folders_path" and v == version
    assert spec == ("spec", (), ("path",))


def test_a_path_scenarios_controller_goes_under_the_folder_given(built, tmp_path):
    calls, _ = built
    sil.sil_controller(parse_scenario(PATH).scenario, out=tmp_path / "mine", fmi_version=3)
    assert calls[0][1] == tmp_path / "mine" / "path" / "folders_path"


@pytest.mark.parametrize("version", [2, 3])
def test_a_plain_scenarios_controller_is_built_in_the_folder_given_or_the_default(built, version):
    calls, _ = built
    sc = parse_scenario({"name": "plain", "duration_s": 1.0}).scenario
    fmu, values = sil.sil_controller(sc, fmi_version=version)
    assert fmu == "fmu1" and values == {"n": 1}
    ((spec, out, v),) = calls
    assert out is None and v == version  # build_fmu_from_spec's default folder
    assert spec == ("spec", (sc.controller, sc.estimator), ())
