"""The demo's study steps (``make demo``) on stand-ins: each runs its study with the FLC into
``<out>/study_<name>``, prints the study's summary and exits 0 on a pass, 1 on a miss; the
Monte Carlo step runs 16 runs of the centred COM-observer scenario on 2 workers, quietly,
into ``<out>/montecarlo`` and exits 0 whatever the success rate; the report step writes
the report and names it."""

from __future__ import annotations

from pathlib import Path

import pytest

from ballbot_casadi.studies import montecarlo_report as MC
from ballbot_casadi.studies import report as R
from ballbot_casadi.studies import study as ST


@pytest.mark.parametrize("name", ["sine", "com", "full", "chirp"])
@pytest.mark.parametrize("passed, code", [(True, 0), (False, 1)])
def test_a_study_step(monkeypatch, capsys, tmp_path, name, passed, code):
    seen = []

    def run_study(n, controller, out, sim):
        seen.append((n, controller, out, sim))
        return {"passed": passed, "study": n}

    monkeypatch.setattr(ST, "run_study", run_study)
    monkeypatch.setattr(ST, "format_summary", lambda r: f"SUMMARY {r['study']} {r['passed']}")
    assert getattr(ST, f"demo_{name}")(tmp_path) == code
    assert seen == [(name, "flc", tmp_path / f"study_{name}", None)]
    assert capsys.readouterr().out == f"SUMMARY {name} {passed}\n"


@pytest.mark.parametrize("rate", [1.0, 0.25])
def test_the_monte_carlo_step(monkeypatch, capsys, tmp_path, rate):
    seen = []

    def run(scenario, n, out, workers, quiet):
        seen.append((scenario, n, out, workers, quiet))
        return {"n": n, "success_rate": rate}

    monkeypatch.setattr(MC, "run_montecarlo", lambda scenario, n, out, workers=None, quiet=False:
                        run(scenario, n, out, workers, quiet))
    assert MC.demo_step(tmp_path) == 0  # the rate is reported, not a failure of the demo
    assert seen == [("com_observer_centred", 16, tmp_path / "montecarlo", 2, True)]
    assert capsys.readouterr().out == (f"montecarlo com_observer_centred: 16 runs, success rate "
                                       f"{100 * rate:.1f} %; report: {tmp_path / 'montecarlo' / 'report.md'}\n")


def test_the_report_step(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(R, "write_report", lambda out: Path(out) / "report.md")
    assert R.demo_step(tmp_path) == 0
    assert capsys.readouterr().out == f"report: {tmp_path / 'report.md'}\n"
