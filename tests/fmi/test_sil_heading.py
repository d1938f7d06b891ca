"""The heading sensor in the SIL system: the plant FMU's ``sensor_heading`` (the yaw reading
of thesis (4.30) at its own low rate, with noise, NaN between samples) against an independent
evaluation of the sensor model, and a heading-aided scenario (``ukf_heading``) run by
``ballbot fmu ssp|cosim`` against the compiled mission."""

from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
from fmpy import simulate_fmu

from ballbot_casadi.cli import main
from ballbot_casadi.core.rng import NoiseStream
from ballbot_casadi.core.sensor_params import load_sensor_params
from ballbot_casadi.fmi.build import build_fmu
from ballbot_casadi.fmi.masters.ssp_run import run_ssp
from ballbot_casadi.fmi.system.sil import read_scenario, write_sil_ssp
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario

pytestmark = [pytest.mark.needs_cc, pytest.mark.fmi_extra]

#: The SIL tests' bound (tests/fmi/test_sil.py): Gauss-Seidel and libcosim measured 0.
BOUND = 1e-9
YAW0 = 0.3  # rad: a heading the reading must report
SEED = 7


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.pi - np.mod(np.pi - a, 2 * np.pi)  # (-pi, pi]


def _plant_run(heading_sensor: bool, rate: float = 10.0):
    start = {"x0_q0": math.cos(YAW0 / 2), "x0_q3": math.sin(YAW0 / 2), "x0_dq0":
             -0.5 * math.sin(YAW0 / 2) * 0.2, "x0_dq3": 0.5 * math.cos(YAW0 / 2) * 0.2,
             "noise_on": True, "seed": SEED, "heading_sensor": heading_sensor,
             "heading_rate_yaw": rate, "heading_bias_yaw": 0.01, "heading_noise_var_yaw": 1e-4}
    return simulate_fmu(str(build_fmu().fmu), fmi_type="CoSimulation", stop_time=0.5,
                        output_interval=0.005, start_values=start,
                        output=["q0", "q1", "q2", "q3", "sensor_heading"])


def test_the_plant_fmus_heading_reading_is_the_sensor_model_at_its_rate():
    """Reference: ZYX yaw of the recorded attitude + bias + sqrt(var) * the Philox normal of
    stream 4 (heading), row k, every 20th sample at 10 Hz from t = 0, wrapped."""
    r = _plant_run(True)
    q = np.column_stack([r[f"q{i}"] for i in range(4)])
    yaw = np.arctan2(2 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]),
                     1 - 2 * (q[:, 2] ** 2 + q[:, 3] ** 2))
    rng = NoiseStream(SEED)
    k = np.arange(r.size)
    n = np.array([rng.normal_at(4, int(i), 0) for i in k])
    want = np.where(k % 20 == 0, _wrap(yaw + 0.01 + 1e-2 * n), np.nan)
    np.testing.assert_allclose(r["sensor_heading"], want, rtol=0, atol=1e-12)
    assert np.sum(np.isfinite(r["sensor_heading"])) == 6  # t = 0, 0.1, ..., 0.5
    assert abs(np.nanmean(r["sensor_heading"]) - YAW0 - 0.05) < 0.05  # yawing at 0.2 rad/s
    # off (the default): no reading at all; the other readings unchanged
    assert np.all(np.isnan(_plant_run(False)["sensor_heading"]))
    assert load_sensor_params().heading_rate[0] == 10.0  # the default the mission uses


@pytest.mark.parametrize("rate, every", [(2.5, 80), (1.0, 200)])
def test_a_slow_heading_sensor_reads_at_its_own_rate(rate, every):
    """At 2.5 Hz a reading every 80th sample (t = 0, 0.4 s); at 1 Hz (and below) only the
    one at t = 0 within the 0.5 s run: a low rate is a rate, not "no sensor"."""
    r = _plant_run(True, rate)
    k = np.arange(r.size)
    assert np.array_equal(np.flatnonzero(np.isfinite(r["sensor_heading"])), k[k % every == 0])


@functools.lru_cache(maxsize=None)
def _heading_scenario():
    """2 s of the velocity profile with noise, the QUKF with the heading reading + VUKF."""
    sc = load_scenario_file(resolve_scenario("full_velocity")).scenario
    return sc.replace(name="sil_heading", duration=2.0, estimator="ukf_heading",
                      heading_sensor=True)


def test_gauss_seidel_heading_sil_equals_the_compiled_mission(tmp_path):
    sc = _heading_scenario()
    log = sil_log(run_ssp(write_sil_ssp(sc, tmp_path / "h.ssp"), master="gauss-seidel")).arrays
    ref = run_scenario(sc, ClosedLoop()).arrays
    for key in ("state", "tau", "x_hat", "meas"):
        np.testing.assert_allclose(log[key], ref[key], rtol=0, atol=BOUND, err_msg=key)
    heading = log["meas"][:, -1]  # the 10th reading: the heading, 10 Hz
    assert np.sum(np.isfinite(heading)) == sc.n_periods // 20


@pytest.mark.slow  # the CLI and libcosim around the Gauss-Seidel test's check (~40 s)
def test_cli_runs_a_heading_aided_scenario_in_libcosim(tmp_path):
    f = tmp_path / "sil_heading.toml"
    f.write_text('name = "sil_heading"\nduration_s = 2.0\ncascade = true\nfeedforward = "none"\n'
                 'estimator = "ukf_heading"\nheading_sensor = true\nseed = 3\n'
                 '[[velocity]]\nt_s = 0.5\nvx_mps = 0.3\nyaw_rate_rps = 0.5\n'
                 'accel_mps2 = 0.25\n')
    ssp = tmp_path / "h.ssp"
    assert main(["fmu", "ssp", "--scenario", str(f), "--out", str(ssp)]) == 0
    sc, _ = read_scenario(ssp)
    assert sc.estimator == "ukf_heading" and sc.heading_sensor
    out = tmp_path / "run"
    main(["fmu", "cosim", str(ssp), "--out", str(out), "--no-plot"])
    doc = json.loads((out / "metrics.json").read_text())
    v = doc["sil"]["vs_mission"]
    assert "actuation delay" in v["reference"]
    assert v["state_max"] <= BOUND and v["tau_max"] <= BOUND
    header = (out / "connections.csv").read_text().splitlines()[0].split(",")
    assert "plant.sensor_heading" in header and "controller.sensor_heading" in header
