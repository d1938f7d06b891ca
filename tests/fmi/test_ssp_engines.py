"""The SSP as other engines read it: the plant's initial state bound as parameters, the
step size in the annotations of libcosim and OMSimulator, stop times that are not a
multiple of the step, and the step order of a Gauss-Seidel master."""

from __future__ import annotations

import csv
import functools
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from lxml import etree

from ballbot_casadi.fmi.masters.ssp_run import run_ssp
from ballbot_casadi.fmi.system.sil import write_sil_ssp
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.fmi.system.ssp import NS, SSD_NAME, read_ssp
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario

pytestmark = [pytest.mark.needs_cc, pytest.mark.fmi_extra]

DURATION = 1.0
BOUND = 1e-9
OMS_MISSING = ("OMSimulator is not installed: its wheels on the package index download a "
               "binary at install time, which fails here")


@functools.lru_cache(maxsize=None)
def _scenario():
    return load_scenario_file(resolve_scenario("full_sine")).scenario.replace(
        duration=DURATION)


@pytest.fixture(scope="module")
def ssp(tmp_path_factory) -> Path:
    return write_sil_ssp(_scenario(), tmp_path_factory.mktemp("ssp") / "full_sine.ssp")


def _plant_variables(ssp: Path, tmp: Path):
    with zipfile.ZipFile(ssp) as zf:
        (tmp / "plant.fmu").write_bytes(zf.read("resources/BallbotPlant.fmu"))
    return {v.name: v for v in read_model_description(str(tmp / "plant.fmu")).modelVariables}


def test_the_plant_parameter_set_binds_parameters_only_the_initial_state_as_x0(ssp, tmp_path):
    variables = _plant_variables(ssp, tmp_path)
    bound = read_ssp(ssp).parameters["plant"]
    assert all(variables[n].causality == "parameter" for n in bound), \
        [n for n in bound if variables[n].causality != "parameter"]
    sc = _scenario()
    x0 = [bound[f"x0_{n}"] for n in ("x", "y", "q0", "q1", "q2", "q3", "dx", "dy", "dq0",
                                     "dq1", "dq2", "dq3")]
    assert x0 == list(sc.x0) and sc.x0[9] != 0.0  # the scenario starts with a nonzero rate


def test_the_ssd_carries_the_step_for_libcosim_and_omsimulator(ssp):
    with zipfile.ZipFile(ssp) as zf:
        ssd = etree.fromstring(zf.read(SSD_NAME))
    ns = {"ssd": NS["ssd"], "ssc": NS["ssc"], "osp": NS["osp"], "oms": NS["oms"]}
    oms = ssd.findall("ssd:System/ssd:Annotations/ssc:Annotation[@type='org.openmodelica']"
                      "/oms:Annotations/oms:SimulationInformation/oms:FixedStepMaster", ns)
    osp = ssd.findall("ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation"
                      "[@type='com.opensimulationplatform']//osp:FixedStepAlgorithm", ns)
    assert [float(e.get("stepSize")) for e in oms] == [0.005]
    assert [float(e.get("baseStepSize")) for e in osp] == [0.005]


def test_libcosim_starts_the_plant_from_the_ssp_alone(ssp):
    """No value applied by the runner: libcosim's own SSP reading sets x0_* (it skips
    start values of outputs, which is how the initial state used to be bound)."""
    libcosim = pytest.importorskip("libcosimpy.CosimExecution")
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ex = libcosim.CosimExecution.from_ssp_file(str(ssp))
    plant = ex.slave_index_from_instance_name("plant")
    refs = {v.name.decode(): v.reference for v in ex.slave_variables(plant)}
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    assert ex.simulate_until(int(round(0.005 * 1e9)))
    names = ("q1", "dq1")
    got = obs.last_real_values(plant, [refs[n] for n in names])
    ref = run_scenario(_scenario(), ClosedLoop(), actuation_delay=True).arrays["state"][1]
    np.testing.assert_allclose(got, [ref[3], ref[9]], rtol=0, atol=BOUND)
    assert abs(got[1]) > 0.05  # not the plant's default (upright, at rest)


def test_reference_first_order_differs_from_the_mission_controller_first_equals_it(ssp):
    """fmu-manipulation-toolbox recommends reference -> controller -> plant; that hands the
    controller the reference row k + 1 at t_k.  Controller -> plant -> reference equals
    the compiled mission."""
    sc = _scenario()
    ref = run_scenario(sc, ClosedLoop()).arrays
    first = sil_log(run_ssp(ssp, master="gauss-seidel")).arrays
    assert np.max(np.abs(first["state"] - ref["state"])) <= BOUND
    rcp = sil_log(run_ssp(ssp, master="gauss-seidel",
                          order=("reference", "controller", "plant"))).arrays
    d_state = float(np.max(np.abs(rcp["state"] - ref["state"])))
    d_tau = float(np.max(np.abs(rcp["tau"] - ref["tau"])))
    print(f"reference-first vs compiled mission over {DURATION} s: state {d_state:.3g}, "
          f"torque {d_tau:.3g}")
    assert d_state > 1e-4 and d_tau > 1e-3  # a real difference, not rounding
    assert np.all(np.isfinite(rcp["state"])) and d_state < 0.1  # still the same manoeuvre


def _omsimulator() -> str | None:
    return shutil.which("OMSimulator")


@pytest.mark.skipif(_omsimulator() is None, reason=OMS_MISSING)
@pytest.mark.parametrize("stop", [0.05, 0.5])  # stop times that used to fail (running sum)
def test_omsimulator_runs_the_ssp_unchanged(ssp, tmp_path, stop):
    res = tmp_path / "res.csv"
    run = subprocess.run([_omsimulator(), f"--stopTime={stop}", f"--resultFile={res}",
                          str(ssp)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "algebraic loop" not in (run.stdout + run.stderr).lower()
    with res.open() as f:
        rows = list(csv.DictReader(f))
    col = next(c for c in rows[0] if c.endswith("plant.dq1"))
    t = np.array([float(r["time"]) for r in rows])
    dq1 = np.array([float(r[col]) for r in rows])
    mission = run_scenario(_scenario(), ClosedLoop(), actuation_delay=True).arrays["state"]
    k = np.round(t / 0.005).astype(int)
    on_grid = np.abs(t - k * 0.005) < 1e-9
    np.testing.assert_allclose(dq1[on_grid], mission[k[on_grid], 9], rtol=0, atol=BOUND)
