"""Scenario files: shipped files, round trips, and the documented errors for malformed files."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import (
    ScenarioFileError,
    dump_toml,
    load_scenario_file,
    parse_scenario,
)
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.studies.registry import STUDIES, get_study, shipped_scenarios


def test_every_shipped_file_is_valid_and_used_by_a_study():
    shipped = shipped_scenarios()
    used = {f for s in STUDIES.values() for f in s.files}
    assert used == set(shipped)
    for name, path in shipped.items():
        sf = load_scenario_file(path)
        assert sf.scenario.name == name and sf.specs


def test_files_reproduce_the_thesis_scenarios():
    (zero,) = get_study("zero").scenarios()
    np.testing.assert_allclose(Q.to_rpy(np.array(zero.x0[2:6])), np.radians([5, 5, 0]), rtol=0, atol=1e-15)
    (sine,) = get_study("sine").scenarios("smc")
    assert sine.controller == "smc" and sine.attitude["roll"]["frequency_hz"] == 0.5
    q, dq, _ = sine.attitude_reference()
    np.testing.assert_allclose(sine.x0[2:6], q[0], rtol=0, atol=1e-15)   # on_reference
    np.testing.assert_allclose(sine.x0[8:12], dq[0], rtol=0, atol=1e-15)
    exact, per_wheel, none = get_study("chirp").scenarios()
    assert (exact.feedforward, per_wheel.feedforward, none.feedforward) == ("exact", "none", "none")
    assert (exact.torque_limit, per_wheel.torque_limit, none.torque_limit) == ("direction", "per-wheel",
                                                                              "direction")
    assert none.attitude["roll"] == {"type": "chirp", "amplitude_deg": 3.0, "f0_hz": 0.05, "f1_hz": 5.0,
                                     "duration": 99.0}
    _, com, *_ = get_study("com").scenarios()
    p = com.plant_params()
    assert (p.com_x, p.com_y) == (-0.02, -0.03) and com.controller_params().com_x == 0.0


def test_dump_round_trips():
    for path in shipped_scenarios().values():
        sf = load_scenario_file(path)
        again = parse_scenario(tomllib.loads(dump_toml(sf.table, "header")), "again", sf.scenario.name)
        assert again.scenario == sf.scenario and again.specs == sf.specs and again.montecarlo == sf.montecarlo


BASE = 'duration_s = 1.0\n'


@pytest.mark.parametrize("text,key,reason", [
    (BASE + "colour = 1\n", "colour", "unknown key"),
    ("controller = 'flc'\n", "duration_s", "missing"),
    (BASE.replace("1.0", "'long'"), "duration_s", "expected a number"),
    (BASE.replace("1.0", "-2.0"), "duration_s", "must be >"),
    (BASE + "controller = 'pid'\n", "controller", "allowed: flc, smc"),
    (BASE + "[attitude.roll]\ntype = 'sine'\namplitude_deg = 3\n", "attitude.roll.frequency_hz", "missing"),
    (BASE + "[attitude.roll]\ntype = 'sine'\namplitude_deg = 3\nfrequency_hz = 150\n",
     "attitude.roll.frequency_hz", "Nyquist"),
    (BASE + "[attitude.roll]\ntype = 'sine'\namplitude_deg = 3\nfrequency_hz = 1\nfreq = 2\n",
     "attitude.roll.freq", "unknown key"),
    (BASE + "[plant]\nMb = -3.0\n", "plant.Mb", "Mb"),
    (BASE + "[plant]\nMbody = 3.0\n", "plant.Mbody", "unknown key"),
    (BASE + "[plant]\nMb = { times = 2 }\n", "plant.Mb", "scale"),
    (BASE + "[[push]]\nt_s = 5.0\nroll_deg = 4\n", "push[0].t_s", "before the end"),
    (BASE + "[initial]\npitch_deg = 95\n", "initial.pitch_deg", "(-90, 90)"),
    (BASE + "seed = -1\n", "seed", "integer >= 0"),
    (BASE + "[[spec]]\nmetric = 'x'\nop = '~'\nthreshold = 1\n", "spec[0].op", "allowed"),
    (BASE + "[montecarlo]\n[[montecarlo.dispersion]]\nparam = 'plant.nope'\ndist = 'normal'\nsd = 1\n",
     "montecarlo.dispersion[0].param", "unknown target"),
    (BASE + "[gains]\nk_bal = [1.0, 2.0]\n", "gains.k_bal", "gain"),
    (BASE + "[gains]\nk_obs = [1.0, 2.0]\n", "gains.k_obs", "COM observer gains"),
    (BASE + "[sensors]\ngyro_noise_var = { scale = -1 }\n", "sensors.gyro_noise_var", "gyro_noise_var"),
    (BASE + "[attitude.roll]\ntype = 'chirp'\namplitude_deg = 1\nf0_hz = 0.1\nf1_hz = 1\nsweep_s = 0\n",
     "attitude.roll.sweep_s", "must be > 0"),
    (BASE + "[[velocity]]\nt_s = 0.0\nvx_mps = 5.0\n", "velocity", "exceeds"),
])
def test_malformed_files_name_file_key_and_reason(tmp_path, text, key, reason):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioFileError) as exc:
        load_scenario_file(path)
    msg = str(exc.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: key '{key}'"), msg
    assert reason in msg, msg
    assert isinstance(exc.value, ScenarioError)


def test_toml_syntax_error_names_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("duration_s = = 1\n")
    with pytest.raises(ScenarioFileError, match=f"{path}: not valid TOML"):
        load_scenario_file(path)


def test_scenario_rejects_sine_without_frequency_and_above_nyquist():
    with pytest.raises(ScenarioError, match="missing frequency_hz"):
        Scenario("s", attitude={"roll": {"type": "sine", "amplitude_deg": 1.0}})
    with pytest.raises(ScenarioError, match="Nyquist"):
        Scenario("s", attitude={"roll": {"type": "sine", "amplitude_deg": 1.0, "frequency_hz": 100.0}})
    Scenario("s", attitude={"roll": {"type": "sine", "amplitude_deg": 1.0, "frequency_hz": 99.0}})


def test_set_changes_only_the_perturbed_run_of_the_robustness_study():
    """With --set on every run the nominal run would change too and settling_time_ratio
    would compare the change with itself (issue 20: 0.999 with x20 inertia)."""
    nominal, perturbed = get_study("robustness").scenarios("flc", [("plant.Jbx", {"scale": 20.0}), ("seed", 3)])
    assert perturbed.plant_params().Jbx == pytest.approx(20.0 * nominal.plant_params().Jbx)
    assert nominal.seed == perturbed.seed == 3  # a set-up switch still changes both
    sine_a, sine_b = get_study("full").scenarios("flc", [("duration_s", 2.0)])[:2]
    assert sine_a.duration == sine_b.duration == 2.0  # other studies: every run


def test_sine_through_the_cascade_is_the_velocity_whose_lean_is_the_sine():
    """full_cascade (thesis §9.3.1 with the velocity controller): cascade on, no attitude
    reference, and a lateral velocity whose acceleration g tan(roll) is the 3° sine."""
    (sc,) = get_study("full_cascade").scenarios()
    assert sc.cascade and not sc.attitude and sc.estimator == "ukf_adaptive"  # the file's (issue 22)
    v = sc.velocity_reference()[:, 1]
    t = sc.time()
    acc = np.gradient(v, t)
    lean = np.degrees(np.arctan(acc / 9.81))
    k = (t > 1.0) & (t < sc.duration - 1.0)
    np.testing.assert_allclose(lean[k], 3.0 * np.sin(2 * np.pi * 0.5 * t[k]), atol=0.25)


def test_velocity_study_also_runs_at_the_thesis_acceleration_limit():
    fast, main = get_study("velocity").scenarios()
    assert all(row[4] == 1.0 for row in fast.velocity_keyframes)
    assert all(row[4] == 0.25 for row in main.velocity_keyframes)


def test_yaw_seeds_study_runs_each_seed_once():
    scs = get_study("yaw_seeds").scenarios()
    assert [s.seed for s in scs] == [1, 2, 3, 4, 5, 6] and len({s.name for s in scs}) == 6
