"""Why the thesis's velocity filter (``estimator = "ukf"``, which the `full` files ran before
issue 22 switched them to ``ukf_adaptive``) is overconfident (mean NIS far above 6),
checked rather than asserted: its encoder noise leaves out the QUKF's body-rate
uncertainty, and its acceleration random walk is far below what the balancing ball does;
with both put in (``encoder_var``, ``acc_process_var``) the filter is consistent.  Every
run here names the thesis's filter explicitly (:data:`THESIS_ESTIMATOR`)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import load_params
from ballbot_casadi.estimation import DEFAULT_TUNING, initial_state, make_qukf
from ballbot_casadi.model.dynamics import make_wheel_speeds
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.estimators import THESIS_ESTIMATOR
from ballbot_casadi.studies.registry import shipped_scenarios

#: The noise model that follows from the robot (the two tests below derive it).
CONSISTENT = {"encoder_var": 3.0, "acc_process_var": 1e-2}


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop()


def _scenario(name: str):
    """The shipped file ``name`` with the thesis's filters."""
    return load_scenario_file(shipped_scenarios()[name]).scenario.replace(estimator=THESIS_ESTIMATOR)


def test_the_body_rate_uncertainty_dominates_the_encoder_noise():
    p = load_params()
    tuning = _scenario("full_sine").estimator_tuning
    # ticks per period per rad/s of body rate at upright (the encoder model, thesis 5.17)
    w = ca.SX.sym("w", 3)
    q = ca.DM([1.0, 0.0, 0.0, 0.0])
    x = ca.vertcat(0, 0, q, 0, 0, 0.5 * Q.mul(q, ca.vertcat(0, w)))
    ticks = p.n_ticks / (2 * np.pi) * 0.005 * make_wheel_speeds()(x, p.to_vector())
    J = np.asarray(ca.Function("J", [w], [ca.jacobian(ticks, w)])(np.zeros(3)))
    # the QUKF's steady-state body-rate covariance with the file's rate process noise
    f, tun = make_qukf(), DEFAULT_TUNING["qukf"]
    Qa = np.array(tun.Q)
    Qa[3:, 3:] = np.eye(3) * tuning["rate_process_var"]
    xa, P = initial_state("qukf")
    for _ in range(3000):
        out = f(xhat=xa, P=P, z=[0.0, 0.0, p.g, 0.0, 0.0, 0.0], Q=Qa, R=tun.R, dt=0.005, p=p.to_vector())
        xa, P = np.asarray(out["xhat_next"]).ravel(), np.asarray(out["P_next"])
    rate_term = np.diag(J @ P[3:, 3:] @ J.T)
    assert np.all(rate_term > 20 * DEFAULT_TUNING["vukf"].R[0, 0])  # thesis I/9 is quantisation only
    assert 1 / 9 + np.mean(rate_term) == pytest.approx(CONSISTENT["encoder_var"], rel=0.2)


def test_the_balancing_ball_changes_its_acceleration_far_more_than_the_filter_assumes(sim):
    sc = _scenario("full_velocity")
    log = run_scenario(sc, sim)
    a = np.diff(log["state"][:, 6:8], axis=0) / sc.Ts
    change = np.var(np.diff(a, axis=0), axis=0)
    assert np.all(change > 100 * DEFAULT_TUNING["vukf"].Q[2, 2])
    np.testing.assert_allclose(change, CONSISTENT["acc_process_var"], rtol=0.5)


@pytest.mark.parametrize("name", ("full_sine", "full_velocity"))
def test_with_both_the_velocity_filter_is_consistent(sim, name):
    sc = _scenario(name)
    shipped = run_metrics(run_scenario(sc, sim))
    tuned = run_metrics(run_scenario(sc.replace(estimator_tuning={**sc.estimator_tuning, **CONSISTENT}), sim))
    assert shipped["nis_velocity_mean"] > 100  # 6 measurements: 6 expected
    assert 3.0 < tuned["nis_velocity_mean"] < 12.0
    assert 2.0 < tuned["nis_attitude_mean"] < 8.0


@pytest.mark.parametrize("name", ("full_sine", "com_observer"))
def test_the_matched_velocity_filter_is_consistent_and_more_accurate(sim, name):
    """estimator = "ukf_consistent" (encoders' rate term from the gyro, the period's
    acceleration noise on the velocity, the attitude error as an accelerometer offset) with
    the acceleration random walk (x, y) measured from the thesis-model run's truth: mean NIS
    at 6 (measured 6.22 / 6.21; 5.99 / 6.05 with the random walk of its own closed loop,
    ``ballbot study consistency``) and a smaller velocity error than the thesis-model filter
    (measured 1.4 vs 2.2 and 1.1 vs 6.5 mm/s)."""
    sc = _scenario(name)
    shipped_log = run_scenario(sc, sim)
    shipped = run_metrics(shipped_log)
    a = np.diff(shipped_log["state"][:, 6:8], axis=0) / sc.Ts
    qx, qy = np.var(np.diff(a, axis=0), axis=0)
    matched = run_metrics(run_scenario(sc.replace(
        estimator="ukf_consistent",
        estimator_tuning={**sc.estimator_tuning, "acc_process_var_x": float(qx),
                          "acc_process_var_y": float(qy)}), sim))
    assert 5.8 < matched["nis_velocity_mean"] < 6.3
    assert matched["estimator_velocity_rms_mps"] < 0.8 * shipped["estimator_velocity_rms_mps"]
