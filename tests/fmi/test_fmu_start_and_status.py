"""FMU bug classes: start values against the scenario they come from, the status an
importer reads after a discarded step, and a step tolerance relative to the period."""

from __future__ import annotations

from ctypes import byref, c_double, c_int

import numpy as np
import pytest
from _controller_support import Controller, compiled_embedded, default_values
from _fmu_support import STATES, Plant

from ballbot_casadi.fmi.controller.controller import (
    READING_NAMES,
    REFERENCE_NAMES,
    STEP_TOL,
    X0_NAMES,
    controller_spec,
    controller_values,
    default_scenario,
)
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, initial_controller_state, software_layout

pytestmark = pytest.mark.needs_cc

TS = 0.005
FMI2_DO_STEP_STATUS, FMI2_LAST_SUCCESSFUL_TIME = 0, 2
FMI2_OK, FMI2_DISCARD, FMI2_ERROR = 0, 2, 3


def test_controller_start_values_are_the_default_scenarios():
    sc = default_scenario()
    values = controller_values(sc)
    spec = {v.name: v for v in controller_spec().variables}
    for name, value in values.items():
        assert spec[name].start == value, name
    # the references an importer leaves unset: the scenario's at t = 0 (upright, at rest)
    q, dq, ddq = sc.attitude_reference()
    want = np.concatenate([q[0], dq[0], ddq[0], sc.velocity_reference()[0]])
    assert [spec[n].start for n in REFERENCE_NAMES] == pytest.approx(want, abs=0)
    assert [spec[n].start for n in REFERENCE_NAMES[:4]] == [1.0, 0.0, 0.0, 0.0]
    np.testing.assert_array_equal([values[n] for n in X0_NAMES], np.array(sc.x0))


def test_the_built_controller_reports_its_start_values_and_runs_from_them_like_the_mission():
    fmu = Controller()
    fmu.slave.setup(0.0)
    spec = [v for v in controller_spec().variables if v.type == "Real" and v.start is not None]
    got = fmu.fmu.getReal([v.vr for v in spec])
    assert list(got) == [v.start for v in spec]
    fmu.slave.exit_initialization()
    # balance-only mode on the start references: the mission's step with q_ref = (1, 0, 0, 0)
    fmu.set(balance_only=True)
    f = compiled_embedded()
    vals = default_values()
    names = [n for n in fmu.vars if n.startswith("c_")]
    c = initial_controller_state(DEFAULT_ESTIMATOR, np.array([vals[n] for n in X0_NAMES]),
                                 np.array([v for k, v in vals.items() if k.startswith("ctrl_")]),
                                 observer=True,
                                 n_bal=(lambda L: L.size_of("bal") if "bal" in L.fields else 0)(
                                     software_layout(f, DEFAULT_ESTIMATOR)))
    np.testing.assert_array_equal(fmu.get(*names), c)
    meas = np.array([0.4, -0.3, 9.8, 0.01, -0.02, 0.005, np.nan, np.nan, np.nan])
    fmu.set_many(READING_NAMES, meas)
    fmu.step()

    def vec(prefix):
        return np.array([v for k, v in vals.items() if k.startswith(prefix)], float)
    out = f(c=c, meas=meas, q_ref=np.array([1.0, 0, 0, 0]), dq_ref=np.zeros(4), ddq_ref=np.zeros(4),
            v_ref=np.zeros(3), p_ctrl=vec("ctrl_"), p_est=vec("est_"), k_bal=vec("k_bal_"),
            k_vel=vec("k_vel_"), Ts=vals["Ts"], cascade=0.0, feedforward=float(vals["feedforward"]),
            Qa=vec("Qa_"), Ra=vec("Ra_"), Qv=vec("Qv_"), Rv=vec("Rv_"),
            com_observer=float(vals["com_observer"]), k_obs=vec("k_obs_"))
    np.testing.assert_allclose(fmu.get("tau_cmd0", "tau_cmd1", "tau_cmd2"),
                               np.asarray(out["tau_cmd"]).ravel(), rtol=0, atol=1e-12)
    assert np.max(np.abs(np.asarray(out["tau_cmd"]))) > 1e-3
    assert fmu.errors() == []
    fmu.free()


def test_the_step_tolerance_scales_with_the_period():
    for Ts in (TS, 0.02):
        fmu = Controller(name=f"ts{Ts}")
        fmu.init({"Ts": Ts})
        fmu.set_many(READING_NAMES, [0.0, 0.0, 9.81, 0, 0, 0, 0, 0, 0])
        # 3 STEP_TOL Ts off a whole number of periods: refused (an absolute tolerance
        # of STEP_TOL s would accept it), nothing run
        for h in (Ts * (1 + 3 * STEP_TOL), 2 * Ts * (1 - 2 * STEP_TOL)):
            assert fmu.raw_step(h) == FMI2_ERROR, (Ts, h)
            assert fmu.fmu.getInteger(fmu.vr("period")) == [0]
        # within 0.4 STEP_TOL Ts of n Ts: n periods
        h = 2 * Ts * (1 + 0.2 * STEP_TOL)
        assert fmu.raw_step(h) == FMI2_OK, (Ts, h)
        assert fmu.fmu.getInteger(fmu.vr("period")) == [2]
        fmu.free()
    # the tolerance itself: tight enough that 10 ns off a 5 ms period is refused, loose
    # enough for a clock summed in doubles (0.1 ns off: 2e-8 Ts)
    assert 1e-12 <= STEP_TOL <= 1e-6
    fmu = Controller(name="abs")
    fmu.init()
    assert fmu.raw_step(TS + 1e-8) == FMI2_ERROR
    assert fmu.raw_step(TS + 1e-10) == FMI2_OK
    fmu.free()


def _status(p, kind: int, fname: str = "fmi2GetStatus", ctype=c_int):
    v = ctype(-1)
    st = p.raw(fname, kind, byref(v))
    return st, v.value


def test_get_status_reports_a_discarded_step_and_the_last_successful_time():
    p = Plant("cs")
    x = make_state(roll=0.3, omega_body=(200.0, 0, 0))
    p.init(**dict(zip(STATES, np.asarray(x).tolist())), tau0=0.0, tau1=0.0, tau2=0.0, h_internal=0.5)
    assert _status(p, FMI2_DO_STEP_STATUS) == (FMI2_OK, FMI2_OK)
    assert p.raw("fmi2DoStep", c_double(0.0), c_double(500.0), 1) == FMI2_DISCARD
    assert _status(p, FMI2_DO_STEP_STATUS) == (FMI2_OK, FMI2_DISCARD)
    assert _status(p, FMI2_LAST_SUCCESSFUL_TIME, "fmi2GetRealStatus", c_double) == (FMI2_OK, 0.0)
    p.free()
    # a step that is refused (an error, not a discard) does not report a discard
    q = Plant("cs", name="refused")
    q.init()
    q.step(0.01)
    assert q.raw("fmi2DoStep", c_double(0.01), c_double(-1.0), 1) == FMI2_ERROR
    assert _status(q, FMI2_DO_STEP_STATUS) == (FMI2_OK, FMI2_OK)
    assert _status(q, FMI2_LAST_SUCCESSFUL_TIME, "fmi2GetRealStatus", c_double) == (FMI2_OK, 0.01)
    q.free()


def test_a_period_giving_nan_is_discarded_and_named_by_its_index_and_time_from_the_start():
    """A started-late controller (start time 2 s) runs two periods, then a gyro reading of
    1e308 makes the third (index 2, t = 2 + 2 Ts) give non-finite numbers: the step is
    discarded and the message names that period and its time."""
    fmu = Controller(name="late")
    fmu.slave.setup(2.0)
    fmu.slave.exit_initialization()
    fmu.t = 2.0
    fmu.step(2 * TS)
    fmu.set(sensor_gyro_x=1e308)
    assert fmu.raw_step(3 * TS) == FMI2_DISCARD
    (msg,) = [m for s, m in fmu.logs if s == FMI2_DISCARD]
    assert "period 2 (t = 2.01) of the embedded software gave NaN or Inf" in msg
    assert msg.startswith("fmi2DoStep: step from t = 2.01 discarded")
    fmu.free()
