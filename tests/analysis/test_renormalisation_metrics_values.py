"""The renormalisation study's metrics by hand (the study's own tests replace them): each
variant started at the logged attitude and body rate, replayed on the logged readings with
the run's attitude tuning, its tilt and heading errors against the true attitude reduced to
rms / max / max |.|, its norm probe, and its tilt rms as a ratio to the QUKF's; the probe
metric of a run's own attitude filter.  The filters are recording stand-ins whose estimates
are built to known errors (a roll error on some samples, a signed yaw error on others)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import ballbot_casadi.analysis.renormalisation as R
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.estimation import DEFAULT_TUNING
from ballbot_casadi.sim.scenario import Scenario

TS = 0.005
N = 6


def _rot(axis: int, ang: float) -> np.ndarray:
    q = np.zeros(4)
    q[0], q[axis] = np.cos(ang / 2), np.sin(ang / 2)
    return q


#: per variant: (roll error on even samples, yaw error on odd samples), radians
ERRORS = {"qukf": (0.02, -0.05), "qukf_renorm": (0.04, 0.03), "qukf_additive": (-0.03, 0.07),
          "qekf": (0.01, -0.01)}
PROBE = {"qukf": 1e-6, "qukf_renorm": 2e-16, "qukf_additive": 3e-16, "qekf": 0.0}


def _log(estimator: str):
    sc = Scenario(name="renorm", controller="flc", estimator=estimator, duration=N * TS)
    roll = 0.3 + 0.1 * np.arange(N + 1)                 # the true attitude: a roll ramp
    state = np.zeros((N + 1, 12))
    state[:, STATE["q"]] = [_rot(1, r) for r in roll]
    w0 = np.array([0.3, -0.2, 0.5])                     # body rate at k = 0
    state[0, STATE["dq"]] = 0.5 * Q.mul(state[0, STATE["q"]], np.r_[0.0, w0])
    state[N, STATE["q"]] = _rot(3, 2.0)                 # past the readings: must not be used
    meas = np.arange(N * 9.0).reshape(N, 9) + 0.5
    return sc, SimpleNamespace(scenario=sc.to_dict(), arrays={"state": state, "meas": meas}), w0


def _stand_ins(monkeypatch, calls):
    def variant(name, q0, omega0):
        calls.setdefault("variant", []).append((name, np.array(q0), np.array(omega0)))
        return f"f_{name}", np.full(7, len(name), float), np.eye(6) * len(name)

    def replay(f, meas, x0, P0, Qn, Rn, dt, p):
        name = f[2:]
        calls.setdefault("replay", []).append((name, meas, x0, P0, Qn, Rn, dt, p))
        ex, ez = ERRORS[name]
        q_true = calls["q_true"]
        xh = np.full((meas.shape[0], 7), 9.0)           # rate columns: not part of the attitude
        for k in range(meas.shape[0]):
            e = _rot(1, ex) if k % 2 == 0 else _rot(3, ez)
            xh[k, :4] = Q.mul(q_true[k], e)
        return xh

    def probe(f, P0, Qn, Rn, p, dt):
        calls.setdefault("probe", []).append((f, P0, Qn, Rn, p, dt))
        return PROBE[f[2:]]

    monkeypatch.setattr(R, "attitude_variant", variant)
    monkeypatch.setattr(R, "replay_attitude", replay)
    monkeypatch.setattr(R, "norm_probe_dev", probe)


def test_renormalisation_metrics_reduce_each_variants_errors_by_hand(monkeypatch):
    sc, log, w0 = _log("ukf")
    calls = {"q_true": log.arrays["state"][:, STATE["q"]]}
    _stand_ins(monkeypatch, calls)
    out = R.renormalisation_metrics(log)
    est = sc.estimation_inputs()
    np.testing.assert_allclose(est["Qa"], np.array(DEFAULT_TUNING["qukf"].Q), rtol=0, atol=0)
    assert [c[0] for c in calls["variant"]] == list(R.ATTITUDE_VARIANTS)
    for name, q0, omega0 in calls["variant"]:
        np.testing.assert_allclose(q0, log.arrays["state"][0, STATE["q"]], rtol=0, atol=0)
        np.testing.assert_allclose(omega0, w0, rtol=0, atol=1e-15)
    for name, meas, x0, P0, Qn, Rn, dt, p in calls["replay"]:
        np.testing.assert_array_equal(meas, log.arrays["meas"])
        np.testing.assert_array_equal(x0, np.full(7, len(name), float))
        np.testing.assert_array_equal(P0, np.eye(6) * len(name))
        np.testing.assert_array_equal(Qn, est["Qa"])
        np.testing.assert_array_equal(Rn, est["Ra"])
        np.testing.assert_array_equal(p, est["p_est"])
        assert dt == TS
    for f, P0, Qn, Rn, p, dt in calls["probe"]:
        np.testing.assert_array_equal(P0, np.eye(6) * len(f[2:]))
        np.testing.assert_array_equal(Qn, est["Qa"])
        np.testing.assert_array_equal(Rn, est["Ra"])
        np.testing.assert_array_equal(p, est["p_est"])
        assert dt == TS
    rms = {}
    for name, (ex, ez) in ERRORS.items():
        tilt = np.degrees([abs(ex) if k % 2 == 0 else 0.0 for k in range(N)])
        rms[name] = np.sqrt(np.sum(tilt ** 2) / N)
        assert out[f"{name}_tilt_rms_deg"] == pytest.approx(rms[name], rel=1e-9)
        assert out[f"{name}_tilt_max_deg"] == pytest.approx(np.degrees(abs(ex)), rel=1e-9)
        assert out[f"{name}_heading_max_deg"] == pytest.approx(np.degrees(abs(ez)), rel=1e-9)
        assert out[f"{name}_norm_probe_dev"] == PROBE[name]
    for name in ERRORS:
        assert out[f"{name}_vs_qukf_tilt_rms_ratio"] == pytest.approx(rms[name] / rms["qukf"], rel=1e-9)
    assert out["qukf_renorm_vs_qukf_tilt_rms_ratio"] == pytest.approx(2.0, rel=1e-9)
    assert len(out) == 5 * len(ERRORS)


def test_without_the_qukf_there_is_no_ratio(monkeypatch):
    _, log, _ = _log("ukf")
    calls = {"q_true": log.arrays["state"][:, STATE["q"]]}
    _stand_ins(monkeypatch, calls)
    out = R.renormalisation_metrics(log, variants=("qekf", "qukf_additive"))
    assert sorted(out) == sorted(f"{v}_{m}" for v in ("qekf", "qukf_additive") for m in
                                 ("tilt_rms_deg", "tilt_max_deg", "heading_max_deg", "norm_probe_dev"))


@pytest.mark.parametrize("estimator,filt", [("ukf", "qukf"), ("ekf", "qekf")])
def test_norm_probe_metric_probes_the_runs_own_attitude_filter(monkeypatch, estimator, filt):
    sc, log, _ = _log(estimator)
    calls = {"q_true": log.arrays["state"][:, STATE["q"]]}
    _stand_ins(monkeypatch, calls)
    out = R.norm_probe_metrics(log)
    assert out == {"attitude_norm_probe_dev": PROBE[filt]}
    (name, q0, omega0), = calls["variant"]
    assert name == filt
    np.testing.assert_array_equal(q0, [1.0, 0, 0, 0])
    np.testing.assert_array_equal(omega0, np.zeros(3))
    (f, P0, Qn, Rn, p, dt), = calls["probe"]
    assert f == f"f_{filt}" and dt == TS
    np.testing.assert_array_equal(P0, np.eye(6) * len(filt))
    np.testing.assert_array_equal(Qn, np.array(DEFAULT_TUNING[filt].Q))
    np.testing.assert_array_equal(Rn, np.array(DEFAULT_TUNING[filt].R))
    np.testing.assert_array_equal(p, sc.estimation_inputs()["p_est"])
