"""The SIL system: SSP 1.0 archive, libcosim run, the Gauss-Seidel master, the container FMU,
against the compiled missions of the same scenario files (noise and estimators on)."""

from __future__ import annotations

import functools
import json
import shutil
import time
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from _controller_support import controller_build
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu
from lxml import etree

from ballbot_casadi.cli import main
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.fmi.build import build_fmu
from ballbot_casadi.fmi.controller.controller import model_identifier
from ballbot_casadi.fmi.system.container import build_container
from ballbot_casadi.fmi.masters.ssp_run import run_ssp
from ballbot_casadi.fmi.system.sil import read_scenario, write_sil_ssp
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.fmi.system.ssp import NS, SSD_NAME, read_ssp
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario

pytestmark = [pytest.mark.needs_cc, pytest.mark.fmi_extra]

SINE_S = 4.0      # roll sine (full_sine: noise, QUKF + VUKF, thesis feed-forward mode)
VELOCITY_S = 6.0  # velocity profile (full_velocity: the first ramps start at 1 s)
BOUND = 1e-9


@functools.lru_cache(maxsize=None)
def _scenario(name: str, duration: float):
    # the thesis's filters, named (the shipped files run ukf_adaptive since issue 22, whose
    # controller FMU the SSP packages under its own name)
    source = load_scenario_file(resolve_scenario(name))
    return source.scenario.replace(duration=duration, estimator="ukf"), source.specs


@functools.lru_cache(maxsize=None)
def _ssp(name: str, duration: float, tmp: str) -> Path:
    sc, specs = _scenario(name, duration)
    return write_sil_ssp(sc, Path(tmp) / f"{name}.ssp", specs=specs)


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> str:
    return str(tmp_path_factory.mktemp("sil"))


def _jacobi(sc):
    """The compiled mission with the one-period actuation delay of a Jacobi master."""
    return run_scenario(sc, ClosedLoop(), actuation_delay=True).arrays


def _max_diff(log, ref) -> tuple[float, float]:
    a = log.arrays
    return (float(np.max(np.abs(a["state"] - ref["state"]))),
            float(np.max(np.abs(a["tau"] - ref["tau"]))))


def test_the_ssp_is_valid_ssp_1_0_and_carries_the_system(work):
    ssp = _ssp("full_sine", SINE_S, work)
    schema_dir = Path(fmpy.__file__).parent / "ssp" / "schema"
    with zipfile.ZipFile(ssp) as zf:
        names = set(zf.namelist())
        ssd = etree.fromstring(zf.read(SSD_NAME))
        ssv = {n: etree.fromstring(zf.read(n)) for n in names if n.endswith(".ssv")}
    etree.XMLSchema(etree.parse(str(schema_dir / "SystemStructureDescription.xsd"))).assertValid(ssd)
    ssv_schema = etree.XMLSchema(etree.parse(str(schema_dir / "SystemStructureParameterValues.xsd")))
    for doc in ssv.values():
        ssv_schema.assertValid(doc)
    sc, _ = _scenario("full_sine", SINE_S)
    ctrl = f"resources/{model_identifier(sc.controller, sc.estimator)}.fmu"
    assert {"resources/BallbotPlant.fmu", ctrl, "resources/BallbotReference.fmu",
            "resources/scenario.json"} <= names
    system = read_ssp(ssp)
    assert list(system.components) == ["plant", "controller", "reference"]
    assert system.step == 0.005 and system.stop_time == pytest.approx(SINE_S)
    sc, _ = _scenario("full_sine", SINE_S)
    plant = system.parameters["plant"]
    assert plant["seed"] == sc.seed and plant["noise_on"] is True
    assert plant["h_internal"] == pytest.approx(sc.Ts / sc.n_sub) and plant["x0_dq1"] == sc.x0[9]
    assert system.parameters["controller"]["feedforward"] is False  # thesis mode
    ends = {(c.end_element, c.end_connector) for c in system.connections}
    assert ("plant", "tau0") in ends and ("controller", "sensor_enc2") in ends
    assert ("controller", "balance_only") in ends and ("plant", "tau_dist2") in ends
    back, specs = read_scenario(ssp)
    assert back == sc and len(specs) > 0
    assert ssd.find("ssd:DefaultExperiment", NS) is not None


def test_libcosim_runs_the_ssp_like_the_compiled_mission_with_the_jacobi_delay(work):
    for name, dur in (("full_sine", SINE_S), ("full_velocity", VELOCITY_S)):
        sc, _ = _scenario(name, dur)
        ssp = _ssp(name, dur, work)
        t0 = time.perf_counter()
        run = run_ssp(ssp)
        assert 0.0 < run.wall_s <= time.perf_counter() - t0
        assert run.master == "libcosim" and run.time.size == sc.n_periods + 1
        log = sil_log(run)
        ds, dt = _max_diff(log, _jacobi(sc))
        assert ds <= BOUND and dt <= BOUND, (name, ds, dt)
        # and that loop is not the zero-delay mission (the comparison can fail)
        ds0, dt0 = _max_diff(log, run_scenario(sc, ClosedLoop()).arrays)
        assert ds0 > 1e-6 and dt0 > 1e-3, (name, ds0, dt0)
        assert np.all(np.isfinite(log.arrays["tau"]))
        # the torque of period 0 under the Jacobi master is the controller's start value
        np.testing.assert_array_equal(log.arrays["tau"][0], 0.0)


def test_gauss_seidel_master_equals_the_compiled_mission(work):
    for name, dur in (("full_sine", SINE_S), ("full_velocity", VELOCITY_S)):
        sc, _ = _scenario(name, dur)
        ssp = _ssp(name, dur, work)
        t0 = time.perf_counter()
        run = run_ssp(ssp, master="gauss-seidel")
        # the co-simulation's wall time: positive, within the call's
        assert 0.0 < run.wall_s <= time.perf_counter() - t0
        ref = run_scenario(sc, ClosedLoop()).arrays
        log = sil_log(run)
        ds, dt = _max_diff(log, ref)
        assert ds <= BOUND and dt <= BOUND, (name, ds, dt)
        for key in ("x_hat", "tau_cmd"):
            assert np.max(np.abs(log.arrays[key] - ref[key])) <= BOUND
        # the readings the plant FMU gave are the mission's (noise from the same seed)
        np.testing.assert_allclose(log.arrays["meas"], ref["meas"], rtol=0, atol=BOUND)


def test_container_fmu_runs_in_fmpy_with_the_libcosim_result(work, tmp_path):
    ssp = _ssp("full_sine", SINE_S, work)
    fmu = build_container(ssp, tmp_path / "out" / "new" / "BallbotSILContainer.fmu")  # made
    assert validate_fmu(str(fmu)) == []
    names = [f"plant.{n}" for n in STATE.names] + [f"controller.tau{i}" for i in range(3)]
    res = simulate_fmu(str(fmu), stop_time=SINE_S, output_interval=0.005, output=names)
    run = run_ssp(ssp)
    x = np.column_stack([res[f"plant.{n}"] for n in STATE.names])
    assert x.shape == (run.time.size, 12)
    x_l = np.column_stack([run.signals[f"plant.{n}"] for n in STATE.names])
    tau = np.column_stack([res[f"controller.tau{i}"] for i in range(3)])
    tau_l = np.column_stack([run.signals[f"controller.tau{i}"] for i in range(3)])
    assert np.max(np.abs(x - x_l)) <= BOUND and np.max(np.abs(tau - tau_l)) <= BOUND
    sc, _ = _scenario("full_sine", SINE_S)
    np.testing.assert_allclose(x, _jacobi(sc)["state"], rtol=0, atol=BOUND)
    # start values change the run: another seed gives other noise
    other = simulate_fmu(str(fmu), stop_time=0.1, output_interval=0.005,
                         start_values={"plant.seed": 7}, output=["plant.sensor_gyro_x"])
    assert not np.allclose(other["plant.sensor_gyro_x"][1:],
                           run.signals["plant.sensor_gyro_x"][1:21], rtol=0, atol=1e-12)


def test_your_own_plant_fmu_with_the_same_names(work, tmp_path):
    mine = tmp_path / "MyPlant.fmu"
    shutil.copyfile(build_fmu().fmu, mine)
    sc, _ = _scenario("full_sine", 1.0)
    ssp = write_sil_ssp(sc, tmp_path / "mine.ssp", plant_fmu=mine)
    assert read_ssp(ssp).components["plant"] == "resources/MyPlant.fmu"
    log = sil_log(run_ssp(ssp))
    ds, dt = _max_diff(log, _jacobi(sc))
    assert ds <= BOUND and dt <= BOUND
    # a plant without the robot's readings cannot be wired
    with pytest.raises(BuildError, match=rf"lacks tau0, tau1, tau2, sensor_acc_x, .*; a plant for the SIL of "
                                         rf"estimator '{sc.estimator}' needs the inputs tau0..2 and the outputs "
                                         rf"sensor_acc_x, .*, sensor_enc2 \(Real\)$"):
        write_sil_ssp(sc, tmp_path / "bad.ssp", plant_fmu=controller_build().fmu)


def test_scenarios_the_sil_cannot_run_are_refused(work, tmp_path):
    sc, _ = _scenario("full_sine", 1.0)
    with pytest.raises(ScenarioError, match="estimator"):
        write_sil_ssp(sc.replace(estimator="true"), tmp_path / "x.ssp")
    with pytest.raises(ScenarioError, match="32-bit signed Integer"):
        write_sil_ssp(sc.replace(seed=2**31), tmp_path / "x.ssp")
    # a user's plant without the heading sensor cannot feed a heading-aided estimator
    with pytest.raises(BuildError, match="sensor_heading"):
        write_sil_ssp(sc.replace(estimator="ukf_heading"), tmp_path / "x.ssp",
                      plant_fmu=controller_build().fmu)
    with pytest.raises(ScenarioError, match="pushes"):
        write_sil_ssp(sc.replace(pushes=((0.5, 1.0, 0.0, 0.0),)), tmp_path / "x.ssp")
    with pytest.raises(ScenarioError, match="sensor_glitch"):  # never silently dropped
        write_sil_ssp(sc.replace(sensor_glitches=((0.5, "gyro", "x", 1000.0),)), tmp_path / "x.ssp")
    with pytest.raises(ScenarioError, match="multiple of the step"):
        run_ssp(_ssp("full_sine", SINE_S, work), duration=0.0123)
    with pytest.raises(ScenarioError, match="unknown master"):
        run_ssp(_ssp("full_sine", SINE_S, work), master="jacobi")


def test_cli_make_sil_and_cosim_write_metrics_like_a_study(tmp_path):
    ssp = tmp_path / "BallbotSIL.ssp"
    assert main(["fmu", "ssp", "--scenario", "full_sine", "--duration", "2", "--out", str(ssp)]) == 0
    out = tmp_path / "run"
    code = main(["fmu", "cosim", str(ssp), "--duration", "2", "--out", str(out)])
    doc = json.loads((out / "metrics.json").read_text())
    assert code == (0 if doc["passed"] else 1)
    assert doc["sil"]["master"] == "libcosim" and doc["sil"]["steps"] == 400
    assert doc["sil"]["vs_mission"]["state_max"] <= BOUND
    assert doc["sil"]["vs_mission"]["tau_max"] <= BOUND
    assert {r["metric"] for r in doc["spec"]} >= {"tilt_error_max_deg", "estimator_roll_rms_deg"}
    for f in ("connections.csv", "run.npz", "plot.png", "sil_compare.png", "report.md"):
        assert (out / f).is_file(), f
    header = (out / "connections.csv").read_text().splitlines()[0].split(",")
    assert "controller.tau0" in header and "plant.tau0" in header and "plant.sensor_acc_x" in header
    rows = np.loadtxt(out / "connections.csv", delimiter=",", skiprows=1)
    assert rows.shape == (401, len(header))
    cont = tmp_path / "c.fmu"
    assert main(["fmu", "container", str(ssp), "--out", str(cont)]) == 0 and cont.is_file()
