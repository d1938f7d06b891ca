"""``run_envelope_study``'s wiring read back with stand-in runs (issue 23, test strength): the
undisturbed allowance each row is judged against, the observer judged against the FLC's own
allowance with no heading term, the limits passed through in order, the defaults and the
written metrics (``passed`` and the tolerances)."""

from __future__ import annotations

import inspect
import json

import pytest

from ballbot_casadi.studies import envelope as E

FINAL = {"flc": (1.5, 2.5, 7.0), "flc_dob": (0.25, 0.75, 3.0), "smc": (0.5, 1.0, 2.0)}


@pytest.fixture()
def stubbed(monkeypatch):
    calls = []
    monkeypatch.setattr(E, "run_scenario", lambda sc, sim: {"controller": sc.controller})
    monkeypatch.setattr(E, "final_motion", lambda log: FINAL[log["controller"]])
    monkeypatch.setattr(E, "peak_motion", lambda log: {"peak_of": log["controller"]})

    def row(sim, c, est, k_bal, base, base_peak, *lims):
        calls.append((c, est, base, base_peak, lims))
        return {"push_roll_deg": len(calls)}

    monkeypatch.setattr(E, "_envelope_row", row)
    monkeypatch.setattr(E, "dob_gain_sweep", lambda sim, est: [est])
    monkeypatch.setattr(E, "dob_verdict", lambda rows, pt, tt: {"rows": sorted(rows), "tols": (pt, tt)})
    monkeypatch.setattr(E, "envelope_report_lines", lambda m: ["# envelope"])
    return calls


def test_rows_are_judged_against_their_undisturbed_allowance(stubbed, tmp_path):
    out = tmp_path / "new" / "envelope"  # the study makes its folder and the parents
    m = E.run_envelope_study(out, plot=False, controllers=("flc", "flc_dob"), estimators=("true", "ekf"),
                             push_max=16.0, push_tol=4.0, torque_max=3.0, torque_tol=0.5, sim=object())
    lims = (16.0, 4.0, 3.0, 0.5)
    assert stubbed == [("flc", "true", FINAL["flc"], {"peak_of": "flc"}, lims),
                       ("flc_dob", "true", FINAL["flc_dob"], {"peak_of": "flc_dob"}, lims),
                       ("flc", "ekf", FINAL["flc"], {"peak_of": "flc"}, lims),
                       ("flc_dob", "ekf", FINAL["flc_dob"], {"peak_of": "flc_dob"}, lims),
                       # the observer against the FLC's allowance, heading term zero
                       ("flc_dob", "ekf", (1.5, 2.5, 0.0), {"peak_of": "flc"}, lims)]
    r = m["table"]["ekf"]["flc"]
    assert (r["undisturbed_final_tilt_deg"], r["undisturbed_final_tilt_rate_deg_s"]) == (1.5, 2.5)
    assert r["undisturbed_peak"] == {"peak_of": "flc"} and r["push_roll_deg"] == 3
    assert m["dob_same_allowance"] == {"ekf": {"push_roll_deg": 5}}
    assert m["dob_gain_sweep"] == {"ekf": ["ekf"]}
    assert m["dob"] == {"true": {"rows": ["flc", "flc_dob"], "tols": (4.0, 0.5)},
                        "ekf": {"rows": ["flc", "flc_dob"], "tols": (4.0, 0.5)}}
    assert m["passed"] is True and (m["push_tol_deg"], m["torque_tol_nm"]) == (4.0, 0.5)
    saved = json.loads((out / "metrics.json").read_text())
    assert saved["passed"] is True and saved["dob_same_allowance"]["ekf"]["push_roll_deg"] == 5
    assert (out / "report.md").read_text() == "# envelope\n"
    assert not (out / "envelope.png").exists()


def test_without_the_observer_there_is_no_verdict_and_no_sweep(stubbed, tmp_path):
    m = E.run_envelope_study(tmp_path, plot=False, controllers=("flc", "smc"), estimators=("ekf",), sim=object())
    assert [c[0] for c in stubbed] == ["flc", "smc"]
    assert m["dob"] == {} and m["dob_gain_sweep"] == {} and m["dob_same_allowance"] == {}


def test_the_study_defaults():
    d = {k: p.default for k, p in inspect.signature(E.run_envelope_study).parameters.items()}
    assert (d["push_max"], d["push_tol"], d["torque_max"], d["torque_tol"]) == (30.0, 0.25, 10.0, 0.05)
    assert d["plot"] is True and d["controllers"] == ("flc", "flc_dob", "smc", "sta", "lqr")
    assert d["estimators"] == ("true", E.DEFAULT_ESTIMATOR)
