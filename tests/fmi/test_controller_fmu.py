"""BallbotController.fmu: the embedded software as an FMU, against the compiled mission's
embedded step (the same Function compiled into the mission library), its timing rules,
missing readings, FMU states, interleaved instances and a C fuzz of its API."""

from __future__ import annotations

import json
import math
import subprocess
from ctypes import c_double, c_uint

import numpy as np
import pytest
from _controller_support import Controller, compiled_embedded, controller_build, default_values
from _fmu_support import fuzz_counts
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import ATTITUDE_FILTER_STATE, STATE
from ballbot_casadi.core.params import PARAM_INFO, PARAM_NAMES
from ballbot_casadi.core.validation import QUAT_TOL
from ballbot_casadi.fmi.controller.controller import (
    HEADING_READING_NAME,
    READING_NAMES,
    REFERENCE_NAMES,
    REJECTION_NAMES,
    X0_NAMES,
    XHAT_NAMES,
    controller_spec,
    controller_state_layout,
    controller_values,
    embedded_function,
    model_identifier,
    reading_names,
)
from ballbot_casadi.fmi.package import build_tool, fmu_source_dir
from ballbot_casadi.fmi.plant.plant import SENSOR_OUTPUT_NAMES
from ballbot_casadi.fmi.spec import value_range
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.embedded import (
    DEFAULT_ESTIMATOR,
    MATCHED_VELOCITY,
    initial_controller_state,
    software_layout,
)
from ballbot_casadi.sim.scenario import Scenario
from ballbot_casadi.sim.scenario.scenario import initial_state

pytestmark = pytest.mark.needs_cc

TS = 0.005
VREF = np.array([0.2, -0.1, 0.3])


def _readings(rng: np.random.Generator) -> np.ndarray:
    """Plausible readings: gravity with a wobble, small rates, encoder rates in ticks/s."""
    return np.concatenate([[0.3, -0.2, 9.81] + 0.05 * rng.standard_normal(3),
                           0.02 * rng.standard_normal(3), 80.0 * rng.standard_normal(3)])


def _function_args(values: dict, cascade: float = 1.0) -> dict:
    """The embedded Function's parameter inputs from the FMU's parameter values."""
    def vec(prefix: str) -> np.ndarray:
        return np.array([v for k, v in values.items() if k.startswith(prefix)], float)
    return {"p_ctrl": vec("ctrl_"), "p_est": vec("est_"), "k_bal": vec("k_bal_"),
            "k_vel": vec("k_vel_"), "Ts": values["Ts"], "cascade": cascade,
            "feedforward": float(values["feedforward"]), "Qa": vec("Qa_"), "Ra": vec("Ra_"),
            "Qv": vec("Qv_"), "Rv": vec("Rv_"),
            **({"com_observer": float(values["com_observer"]), "k_obs": vec("k_obs_")}
               if "com_observer" in values else {})}


class _Reference:
    """The compiled embedded step run period by period (the mission's controller)."""

    def __init__(self, controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR):
        self.f = compiled_embedded(controller, estimator)
        self.values = default_values(controller, estimator)
        x0 = np.array([self.values[n] for n in X0_NAMES])
        layout = software_layout(self.f, estimator)  # the balance controller's own state too
        self.c = initial_controller_state(estimator, x0, _function_args(self.values)["p_ctrl"],
                                          observer="com_observer" in self.values,
                                          n_bal=layout.size_of("bal") if "bal" in layout.fields else 0)
        self.args = _function_args(self.values)
        self.k = 0

    def period(self, meas: np.ndarray, v_ref=VREF, q_ref=(1.0, 0, 0, 0), cascade=1.0) -> dict:
        m = np.array(meas, float)
        if self.k == 0:
            m[6:9] = np.nan
        out = self.f(c=self.c, meas=m, q_ref=np.asarray(q_ref, float), dq_ref=np.zeros(4),
                     ddq_ref=np.zeros(4), v_ref=np.asarray(v_ref, float),
                     **{**self.args, "cascade": cascade})
        out = {k: np.asarray(v, float).ravel() for k, v in out.items()}
        self.c = out["c_next"]
        self.k += 1
        return out


def test_both_variants_validate_and_share_the_plant_reading_names():
    for ctrl, est in (("flc", "ukf"), ("smc", "ekf")):
        b = controller_build(ctrl, est)
        assert validate_fmu(str(b.fmu)) == [], (ctrl, est)
        md = read_model_description(str(b.fmu))
        assert md.modelExchange is None and md.coSimulation is not None
        v = {x.name: x for x in md.modelVariables}
        assert tuple(READING_NAMES) == tuple(SENSOR_OUTPUT_NAMES)
        for n in READING_NAMES:
            assert (v[n].causality, v[n].variability, v[n].type) == ("input", "discrete", "Real")
        for n in (*REFERENCE_NAMES, "balance_only"):
            assert v[n].causality == "input"
        for i in range(3):
            assert v[f"tau{i}"].causality == "output"
        # the controllers' and the filters' models under the load_params names, with the
        # parameter rules of the plant (the same range checks)
        for p in PARAM_NAMES:
            for prefix in ("ctrl_", "est_"):
                var = v[prefix + p]
                assert var.causality == "parameter" and var.unit == (PARAM_INFO[p][0] or None)
    # the FLC with the default estimator is BallbotController, the others carry their names
    assert model_identifier("flc", DEFAULT_ESTIMATOR) == "BallbotController"
    assert read_model_description(str(controller_build("flc", "ukf").fmu)) \
        .coSimulation.modelIdentifier == model_identifier("flc", "ukf")
    assert read_model_description(str(controller_build("smc", "ekf").fmu)) \
        .coSimulation.modelIdentifier == "BallbotController_smc_ekf"


def test_the_per_model_file_is_small():
    lines = (fmu_source_dir() / "controller" / "controller_model.c").read_text().splitlines()
    assert len(lines) < 220  # the second FMU costs a small per-model file, not a copy


@pytest.mark.parametrize("ctrl,est", [("flc", "ukf"), ("smc", "ekf"), ("sta", "ukf"), ("flc_dob", "ukf"),
                                      ("flc", "ukf_adaptive"), ("flc", "ukf_consistent")])
def test_fmu_equals_the_compiled_embedded_step(ctrl, est):
    rng = np.random.default_rng(11)
    fmu, ref = Controller(ctrl, est), _Reference(ctrl, est)
    fmu.init()
    fmu.set(v_ref_x=VREF[0], v_ref_y=VREF[1], yaw_rate_ref=VREF[2])
    L = software_layout(ref.f, est)
    worst, rejected = 0.0, []
    for k in range(60):
        meas = _readings(rng)
        if k == 30:
            meas[3] = np.nan  # a gyroscope dropout
        if k == 40:
            meas[4] += 1000.0  # a gyroscope glitch: the attitude filter's gate rejects it
        fmu.set_many(READING_NAMES, meas)
        fmu.step()
        out = ref.period(meas)
        c_fmu = fmu.get(*[n for n in fmu.vars if n.startswith("c_")])
        rejected.append(fmu.get(*REJECTION_NAMES))
        for got, want in ((fmu.get("tau0", "tau1", "tau2"), out["tau_lim"]),
                          (fmu.get("tau_cmd0", "tau_cmd1", "tau_cmd2"), out["tau_cmd"]),
                          (fmu.get(*XHAT_NAMES), out["x_hat"]), (c_fmu, out["c_next"]),
                          (fmu.get("nis_attitude", "nis_velocity"), out["nis"]),
                          (fmu.get("repairs"), out["repairs"]),
                          (rejected[-1], out["rejections"]),
                          # the decoded outputs: the estimate's attitude angles, the filter's rate
                          (fmu.get("roll_hat", "pitch_hat", "yaw_hat"),
                           np.asarray(Q.to_rpy(out["x_hat"][STATE["q"]]), float).ravel()),
                          (fmu.get("omega_hat_x", "omega_hat_y", "omega_hat_z"),
                           out["c_next"][L["xa"]][ATTITUDE_FILTER_STATE["omega"]])):
            worst = max(worst, float(np.max(np.abs(got - want))))
    assert worst <= 1e-12
    expected = np.zeros((60, len(REJECTION_NAMES)))
    expected[40, REJECTION_NAMES.index("rejected_attitude_gyro")] = 1.0
    if est in MATCHED_VELOCITY:  # its encoder prediction reads the gyro (the body-rate term)
        expected[40, REJECTION_NAMES.index("rejected_velocity_enc")] = 1.0
    np.testing.assert_array_equal(np.array(rejected), expected)
    assert np.all(np.isfinite(fmu.get("tau0", "tau1", "tau2")))
    assert fmu.errors() == []
    fmu.free()


def test_adaptive_variant_carries_the_walk_estimate_in_its_state():
    """``ukf_adaptive``: the filter's adapted acceleration walk ``[q_x, q_y, n]`` is part of
    the embedded software's state, so the FMU has it as ``c_walk_0..2`` (locals: saved with
    the FMU state); it starts at 0 (the configured Qv is the prior) and is the mission's."""
    layout = controller_state_layout(embedded_function("flc", "ukf_adaptive"), "ukf_adaptive")
    assert layout.size_of("walk") == 3
    assert "walk" not in controller_state_layout(embedded_function("flc", "ukf_consistent"),
                                                 "ukf_consistent").fields
    rng = np.random.default_rng(5)
    fmu, ref = Controller("flc", "ukf_adaptive"), _Reference("flc", "ukf_adaptive")
    walk = ["c_walk_0", "c_walk_1", "c_walk_2"]
    assert all(fmu.vars[n].causality == "local" for n in walk)
    fmu.init()
    np.testing.assert_array_equal(fmu.get(*walk), 0.0)
    for _ in range(40):
        meas = _readings(rng)
        meas[6:9] = 5.0 * rng.standard_normal(3)  # encoder rates the gate accepts
        fmu.set_many(READING_NAMES, meas)
        fmu.step()
        out = ref.period(meas)
    got = fmu.get(*walk)
    np.testing.assert_allclose(got, out["c_next"][layout["walk"]], rtol=0, atol=1e-12)
    assert got[2] >= 30 and np.all(got[:2] > 0.0)  # samples counted, the walk estimated
    assert fmu.errors() == []
    fmu.free()


def test_heading_variant_reads_the_heading_and_equals_the_compiled_embedded_step():
    """``ukf_heading``: one more reading input, ``sensor_heading`` (NaN between the heading
    sensor's samples), the 7 x 7 attitude covariances; the FMU equals the mission's
    embedded step and its heading reading moves the heading estimate."""
    assert reading_names("ukf_heading") == (*READING_NAMES, HEADING_READING_NAME)
    assert reading_names("ukf") == READING_NAMES
    b = controller_build("flc", "ukf_heading")
    assert validate_fmu(str(b.fmu)) == []
    rng = np.random.default_rng(12)
    fmu, ref = Controller("flc", "ukf_heading"), _Reference("flc", "ukf_heading")
    fmu.init()
    fmu.set(v_ref_x=VREF[0], v_ref_y=VREF[1], yaw_rate_ref=VREF[2])
    names = reading_names("ukf_heading")
    worst = 0.0
    for k in range(60):
        # a heading reading every 20th period, 5 deg off the power-on estimate
        meas = np.concatenate([_readings(rng), [np.radians(5.0) if k % 20 == 0 else np.nan]])
        fmu.set_many(names, meas)
        fmu.step()
        out = ref.period(meas)
        c_fmu = fmu.get(*[n for n in fmu.vars if n.startswith("c_")])
        for got, want in ((fmu.get("tau0", "tau1", "tau2"), out["tau_lim"]),
                          (fmu.get(*XHAT_NAMES), out["x_hat"]), (c_fmu, out["c_next"])):
            worst = max(worst, float(np.max(np.abs(got - want))))
    assert worst <= 1e-12
    assert float(fmu.get("yaw_hat")[0]) > np.radians(0.5)  # pulled towards the reading
    assert fmu.errors() == []
    fmu.free()


def test_a_step_of_n_periods_runs_n_periods_the_later_ones_predict_only():
    rng = np.random.default_rng(3)
    fmu, ref = Controller(), _Reference()
    fmu.init()
    fmu.set(v_ref_x=VREF[0], v_ref_y=VREF[1], yaw_rate_ref=VREF[2])
    meas = _readings(rng)
    fmu.set_many(READING_NAMES, meas)
    fmu.step(3 * TS)
    ref.period(meas)
    ref.period(np.full(9, np.nan))
    out = ref.period(np.full(9, np.nan))
    np.testing.assert_allclose(fmu.get("tau0", "tau1", "tau2"), out["tau_lim"], rtol=0, atol=1e-12)
    assert fmu.fmu.getInteger(fmu.vr("period")) == [3]
    fmu.free()


def test_refused_step_sizes_are_logged_and_change_nothing():
    fmu = Controller()
    fmu.init()
    fmu.set_many(READING_NAMES, _readings(np.random.default_rng(0)))
    before = fmu.get(*[n for n in fmu.vars if n.startswith("c_")])
    for h in (0.004, 0.0075, 0.005 + 1e-5, 0.0025):
        n = len(fmu.logs)
        assert fmu.raw_step(h) == 3  # fmi2Error
        assert len(fmu.logs) == n + 1
        assert "not a whole number of controller periods" in fmu.logs[-1][1]
        np.testing.assert_array_equal(fmu.get(*[n for n in fmu.vars if n.startswith("c_")]), before)
        assert fmu.fmu.getInteger(fmu.vr("period")) == [0]
    fmu.step(TS)  # the instance is still usable
    assert fmu.fmu.getInteger(fmu.vr("period")) == [1]
    fmu.free()


def test_a_step_within_the_tolerance_of_whole_periods_counts_as_them_zero_included():
    """Issue 19: an importer whose clock is a running sum ends with a step of 1e-17 ..
    1e-13 s (OMSimulator at stop times 0.05, 2, 5 s); that is zero periods, not an error."""
    rng = np.random.default_rng(4)
    fmu, ref = Controller(), _Reference()
    fmu.init()
    fmu.set(v_ref_x=VREF[0], v_ref_y=VREF[1], yaw_rate_ref=VREF[2])
    meas = _readings(rng)
    fmu.set_many(READING_NAMES, meas)
    fmu.step(TS)
    out = ref.period(meas)
    c_names = [n for n in fmu.vars if n.startswith("c_")]
    before = fmu.get(*c_names, "tau0", "tau1", "tau2")
    for h in (1e-17, 1e-15, 1e-13):
        assert fmu.raw_step(h) == 0  # fmi2OK, no period run
        fmu.t += h
        np.testing.assert_array_equal(fmu.get(*c_names, "tau0", "tau1", "tau2"), before)
        assert fmu.fmu.getInteger(fmu.vr("period")) == [1]
    np.testing.assert_allclose(fmu.get("tau0", "tau1", "tau2"), out["tau_lim"], rtol=0, atol=1e-12)
    # a period plus such a remainder is one period
    fmu.set_many(READING_NAMES, meas)
    assert fmu.raw_step(TS + 3e-15) == 0
    fmu.t += TS + 3e-15
    out = ref.period(meas)
    np.testing.assert_allclose(fmu.get("tau0", "tau1", "tau2"), out["tau_lim"], rtol=0, atol=1e-12)
    assert fmu.fmu.getInteger(fmu.vr("period")) == [2]
    assert fmu.errors() == []
    fmu.free()


def test_missing_readings_take_the_predict_only_path_not_a_nan_torque():
    rng = np.random.default_rng(5)
    seq = [_readings(rng) for _ in range(20)]
    taus = {}
    for label, drop in (("all", None), ("gyro", slice(3, 6)), ("everything", slice(0, 9))):
        fmu, ref = Controller(name=label), _Reference()
        fmu.init()
        fmu.set(v_ref_x=VREF[0], v_ref_y=VREF[1], yaw_rate_ref=VREF[2])
        for k, m in enumerate(seq):
            m = m.copy()
            if drop is not None and 5 <= k < 15:
                m[drop] = np.nan
            fmu.set_many(READING_NAMES, m)
            fmu.step()
            out = ref.period(m)
            tau = fmu.get("tau0", "tau1", "tau2")
            assert np.all(np.isfinite(tau))
            np.testing.assert_allclose(tau, out["tau_lim"], rtol=0, atol=1e-12)
        assert fmu.errors() == []
        taus[label] = tau
        fmu.free()
    # the dropouts did change the estimate (the readings were not used)
    assert not np.allclose(taus["all"], taus["gyro"], rtol=0, atol=1e-9)
    assert not np.allclose(taus["all"], taus["everything"], rtol=0, atol=1e-9)


def test_inf_readings_are_refused_and_the_first_encoder_reading_is_ignored():
    fmu = Controller()
    fmu.init()
    vr = (c_uint * 1)(*fmu.vr("sensor_gyro_x"))
    n = len(fmu.logs)
    assert fmu.raw("fmi2SetReal", vr, 1, (c_double * 1)(float("inf"))) == 3
    assert len(fmu.logs) == n + 1 and "sensor_gyro_x" in fmu.logs[-1][1]
    # period 0: no previous count, so the encoder reading cannot matter
    outs = []
    for enc in (0.0, 500.0):
        c = Controller(name=f"enc{enc}")
        c.init()
        m = _readings(np.random.default_rng(9))
        m[6:9] = enc
        c.set_many(READING_NAMES, m)
        c.step()
        outs.append(c.get("tau0", "tau1", "tau2", *XHAT_NAMES))
        c.free()
    np.testing.assert_array_equal(outs[0], outs[1])
    fmu.free()


def test_fmu_state_serialisation_reset_and_interleaved_instances():
    rng = np.random.default_rng(21)
    seq = [_readings(rng) for _ in range(30)]
    a = Controller(name="a")
    a.init()
    a.set(v_ref_x=0.1)
    for m in seq[:10]:
        a.set_many(READING_NAMES, m)
        a.step()
    blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
    for m in seq[10:20]:
        a.set_many(READING_NAMES, m)
        a.step()
    want = a.get("tau0", "tau1", "tau2", *XHAT_NAMES)
    b = Controller(name="b")
    state = b.fmu.deSerializeFMUstate(blob)
    b.fmu.setFMUstate(state)
    b.fmu.freeFMUstate(state)
    b.t = 10 * TS
    for m in seq[10:20]:
        b.set_many(READING_NAMES, m)
        b.step()
    np.testing.assert_array_equal(b.get("tau0", "tau1", "tau2", *XHAT_NAMES), want)
    # reset: the same run again from the start values
    a.fmu.reset()
    a.init()
    a.set(v_ref_x=0.1)
    c = Controller(name="c")
    c.init()
    c.set(v_ref_x=0.1)
    for m in seq[:20]:  # interleaved: a and c alternate, each must equal a run alone
        for x in (a, c):
            x.set_many(READING_NAMES, m)
            x.step()
    np.testing.assert_array_equal(a.get("tau0", "tau1", "tau2", *XHAT_NAMES), want)
    np.testing.assert_array_equal(c.get("tau0", "tau1", "tau2", *XHAT_NAMES), want)
    for x in (a, b, c):
        assert x.errors() == []
        x.free()


def test_parameters_are_checked_and_the_initial_estimate_is_readable_in_initialization():
    fmu = Controller()
    fmu.fmu.setupExperiment(startTime=0.0)
    fmu.fmu.enterInitializationMode()
    lo, hi, _, _, text = value_range(next(v for v in _variables() if v.name == "ctrl_Mb"))
    vr = (c_uint * 1)(*fmu.vr("ctrl_Mb"))
    assert fmu.raw("fmi2SetReal", vr, 1, (c_double * 1)(-1.0)) == 3
    assert "non-physical value" in fmu.logs[-1][1] and text in fmu.logs[-1][1]
    # the estimate before the first period is the state at power-on, already in init mode
    vals = default_values()
    q0 = [vals[f"x0_q{i}"] for i in range(4)]
    np.testing.assert_array_equal(fmu.get("q_hat0", "q_hat1", "q_hat2", "q_hat3"), q0)
    # a non-unit initial attitude is refused at the end of initialisation
    fmu.set(x0_q0=0.9, x0_q1=0.2, x0_q2=-0.3, x0_q3=0.5)   # norm 1.1: each component named
    assert fmu.raw("fmi2ExitInitializationMode") == 3
    assert fmu.logs[-1][1].endswith("the initial attitude [0.9, 0.2, -0.3, 0.5] (x0_q0..3) must be a "
                                     f"unit quaternion (norm 1 within {QUAT_TOL:g})"), fmu.logs[-1][1]
    fmu.free()


def test_the_initial_estimate_carries_the_power_on_rate_through_the_filter_state():
    """A tilted, turned robot turning about all three axes at power-on: the estimate read
    in initialisation is its state, the quaternion rate rebuilt from the attitude filter's
    body rate as dq = 1/2 q o [0, omega] (every product term of it non-zero)."""
    fmu = Controller()
    fmu.fmu.setupExperiment(startTime=0.0)
    fmu.fmu.enterInitializationMode()
    q = np.asarray(Q.from_rpy(0.1, -0.2, 0.7), float).ravel()
    omega = np.array([0.3, -0.5, 0.2])
    dq = 0.5 * np.asarray(Q.mul(q, np.r_[0.0, omega]), float).ravel()
    fmu.set(**{f"x0_q{i}": q[i] for i in range(4)}, **{f"x0_dq{i}": dq[i] for i in range(4)},
            x0_dx=0.15, x0_dy=-0.05)
    np.testing.assert_allclose(fmu.get(*(f"q_hat{i}" for i in range(4))), q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(fmu.get(*(f"dq_hat{i}" for i in range(4))), dq, rtol=0, atol=1e-14)
    fmu.free()


def _variables():
    return controller_spec().variables


def test_c_fuzz_of_the_controller_api():
    s = fuzz_counts(controller_build(), 120000, 17, timeout=300)
    assert s["calls"] >= 100_000, s
    assert s["silent"] == 0, s  # every error logged
    assert s["steps_ok"] > 100 and s["init_ok"] > 100 and s["error"] > 1000, s


def test_c_host_runs_the_controller_without_python():
    b = controller_build()
    host = build_tool(b, "controller_host")
    res = subprocess.run([str(host), str(b.binary), b.guid, "400", "0"], capture_output=True,
                         text=True, check=True)
    out = json.loads(res.stdout)
    assert out["t"] == pytest.approx(400 * TS, rel=1e-12)
    assert all(np.isfinite(out["tau"])) and max(abs(t) for t in out["tau"]) > 0.0
    # the same synthetic readings through the Python master: the same torques
    fmu = Controller()
    fmu.init()
    for k in range(400):
        w = math.sin(0.01 * k)
        fmu.set_many(READING_NAMES, [0.05 * w, -0.04 * w, 9.81, 0.01 * w, -0.01 * w, 0.002,
                                     20.0 * w, -10.0 * w, -10.0 * w])
        fmu.step(TS)
    np.testing.assert_allclose(out["tau"], fmu.get("tau0", "tau1", "tau2"), rtol=1e-9, atol=1e-12)
    fmu.free()
    usage = subprocess.run([str(host), str(b.binary), b.guid, "400"], capture_output=True, text=True)
    assert usage.returncode == 2 and usage.stdout == ""
    assert usage.stderr == f"usage: {host} lib guid n_steps bench_reps\n"   # names the program
    wrong = subprocess.run([str(host), str(b.binary), "{not-the-guid}", "400", "0"],
                           capture_output=True, text=True)
    assert (wrong.returncode, wrong.stdout) == (4, "")   # documented: instantiation refused
    assert "GUID" in wrong.stderr.upper()   # the FMU's own log line says why
    assert wrong.stderr.endswith(f"{host}: fmi2Instantiate refused the FMU\n")


@pytest.mark.parametrize("ctrl,est", [("flc", "ukf"), ("smc", "ekf")])
def test_the_state_at_power_on_is_the_missions(ctrl, est):
    """The FMU computes c at initialisation with the generated C of the Function the
    compiled mission starts from: equal to the Function in Python bit for bit, to the
    mission's initial parts, and after one period to the compiled mission's state."""
    sc = Scenario(name="power_on", controller=ctrl, estimator=est, duration=0.005,
                  x0=initial_state(4.0, -3.0, 20.0), seed=3)
    values = controller_values(sc)
    inp = sc.inputs()
    fmu = Controller(ctrl, est)
    fmu.init(values)
    c_names = [n for n in fmu.vars if n.startswith("c_")]
    c_fmu = fmu.get(*c_names)
    want = initial_controller_state(est, inp["x0"], inp["p_ctrl"], observer=True)
    np.testing.assert_array_equal(c_fmu, want)
    L = controller_state_layout(embedded_function(ctrl, est), est)
    np.testing.assert_allclose(c_fmu[L["z"]], inp["z0"], rtol=0, atol=1e-15)
    e0 = inp["estimation"]["e0"]
    np.testing.assert_array_equal(np.concatenate([c_fmu[L[f]] for f in
                                                  ("xa", "Pa", "xv", "Pv", "pos", "gate")]), e0)
    # one period on the mission's readings: the compiled mission's state after it
    log = run_scenario(sc, ClosedLoop())
    fmu.set(balance_only=True)
    fmu.set_many(READING_NAMES, log.arrays["meas"][0])
    fmu.step()
    np.testing.assert_allclose(fmu.get(*c_names), log.arrays["c_final"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fmu.get("tau_cmd0", "tau_cmd1", "tau_cmd2"),
                               log.arrays["tau_cmd"][0], rtol=0, atol=1e-12)
    assert fmu.errors() == []
    fmu.free()
