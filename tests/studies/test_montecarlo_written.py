"""``ballbot montecarlo``'s written outputs read back against hand-computed values on stand-in
results (issue 23, test strength): the worst runs' order and files, the report's rows (the
closest spec and its share of the allowance, each spec's worst run, the statistics' columns
in order: mean, std, min, max, p95), the partial run's missing indices and the JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ballbot_casadi.core.specs import spec_ok
from ballbot_casadi.errors import ClusterError
from ballbot_casadi.studies import montecarlo_report as mc

LAG = [0.001, 0.019, 0.03, -0.015, 0.0, 0.004, 0.008]      # roll_lag_s abs<= 0.02: run 2 fails
TV = [1.0, 1.2, 1.4, 0.5, 0.1, 0.15, 0.45]                 # torque_tv_ratio <= 1.5
TILT = [1.0, 2.0, 3.0, 4.0, 0.5, 0.5, 0.5]


def _results(source, runs):
    specs = [(s["metric"], s["op"], s["threshold"]) for s in source.specs]
    out = []
    for r in runs:
        k = r["index"]
        m = {"finite": True, "roll_lag_s": LAG[k], "torque_tv_ratio": TV[k], "peak_tilt_deg": TILT[k]}
        oks = [spec_ok(m.get(a), op, t) for a, op, t in specs]
        out.append({"ok": all(oks), "spec_ok": oks, "metrics": m, "error": None, "failure": None})
    return out


@pytest.fixture(autouse=True)
def no_drawing(monkeypatch):
    # the plots are drawn by the other Monte Carlo tests; here only their names are read
    monkeypatch.setattr(mc, "_plots", lambda summary, runs, results, out: ["histograms.png", "scatter.png"])


@pytest.fixture()
def written(monkeypatch, tmp_path):
    monkeypatch.setattr(mc, "execute", lambda source, runs, *a, **k: _results(source, runs))
    doc = mc.run_montecarlo("sine", 4, tmp_path / "mc", workers=0, quiet=True, seed=5)
    return doc, tmp_path / "mc"


def test_the_worst_runs_and_their_files(written):
    doc, out = written
    # run 2 misses a spec; then by the largest share of an allowance: run 1 (0.019 / 0.02),
    # run 3 (0.015 / 0.02), run 0 (1.0 / 1.5)
    assert [w["index"] for w in doc["worst"]] == [2, 1, 3, 0]
    assert [w["file"] for w in doc["worst"]] == [f"worst/sine_mc000{i}.toml" for i in (2, 1, 3, 0)]
    assert sorted(p.name for p in (out / "worst").iterdir()) == [f"sine_mc000{i}.toml" for i in range(4)]
    assert "worst #1" in (out / "worst" / "sine_mc0002.toml").read_text()
    assert doc["success_rate"] == 0.75 and doc["n_failed"] == 1 and doc["partial"] is False
    saved = json.loads((out / "montecarlo.json").read_text())
    assert [r["ok"] for r in saved["runs"]] == [True, True, False, True]
    assert [r["metrics"]["roll_lag_s"] for r in saved["runs"]] == LAG[:4]
    assert [s["pass_rate"] for s in saved["specs"]] == [1.0, 0.75, 1.0]


def test_only_the_five_worst_runs_are_kept(monkeypatch, tmp_path):
    # 7 runs: run 2 fails, then the shares 0.95 (1), 0.75 (3), 0.667 (0), 0.4 (6), 0.2 (5), 0.067 (4);
    # N_WORST = 5 keeps the first five and writes only their files
    monkeypatch.setattr(mc, "execute", lambda source, runs, *a, **k: _results(source, runs))
    doc = mc.run_montecarlo("sine", 7, tmp_path / "mc", workers=0, quiet=True, seed=5)
    assert mc.N_WORST == 5
    assert [w["index"] for w in doc["worst"]] == [2, 1, 3, 0, 6]
    assert sorted(p.name for p in (tmp_path / "mc" / "worst").iterdir()) == [
        f"sine_mc000{i}.toml" for i in (0, 1, 2, 3, 6)]


def test_the_report_rows(written):
    doc, out = written
    lines = (out / "report.md").read_text().splitlines()
    assert lines[0] == "# Monte Carlo: `sine` (4 runs)"
    assert "- **success rate: 75.0 %** (3/4 runs meet every spec)" in lines
    assert any(ln.startswith("| `roll_lag_s` | abs<= 0.02 | 75.0 % | < 0.1 s |") for ln in lines)
    assert "| `plant.Mb` | normal, sd 0.05 (relative) |" in lines and "| `plant.Bvk` | uniform [0, 0.5] |" in lines
    w = {w["index"]: w for w in doc["worst"]}
    assert (f"| 2 | {w[2]['seed']} | roll_lag_s | `roll_lag_s` 0.03 (150 %) | 3 | "
            f"[{w[2]['file']}]({w[2]['file']}) |") in lines
    assert (f"| 1 | {w[1]['seed']} | none | `roll_lag_s` 0.019 (95 %) | 2 | "
            f"[{w[1]['file']}]({w[1]['file']}) |") in lines
    assert f"| `roll_lag_s` | abs<= 0.02 | 0.03 | 150 % | 2 | {w[2]['seed']} |" in lines
    assert f"| `torque_tv_ratio` | <= 1.5 | 1.4 | 93 % | 2 | {w[2]['seed']} |" in lines
    tv = np.array(TV[:4])
    p95 = np.sort(tv)[2] + 0.85 * (np.sort(tv)[3] - np.sort(tv)[2])    # linear, position 0.95 * 3
    assert p95 == pytest.approx(1.37, rel=1e-12)
    cells = [f"{v:.4g}" for v in (tv.mean(), tv.std(), tv.min(), tv.max(), p95)]
    assert "| `torque_tv_ratio` | " + " | ".join(cells) + " |" in lines
    assert lines[-2:] == ["![histograms.png](histograms.png)", "![scatter.png](scatter.png)"]


def test_a_partial_set_names_its_missing_runs(monkeypatch, tmp_path):
    def lose(source, runs, *a, **k):
        res = _results(source, runs)
        raise ClusterError("the cluster lost its workers", finished={0: res[0], 2: res[2], 3: res[3]})

    monkeypatch.setattr(mc, "execute", lose)
    with pytest.raises(ClusterError, match=r"the 3 finished runs of 5 are in .*missing runs 1, 4\)"):
        mc.run_montecarlo("sine", 5, tmp_path / "mc", workers=0, quiet=True, seed=5)
    saved = json.loads((tmp_path / "mc" / "montecarlo.json").read_text())
    assert (saved["partial"], saved["missing"], saved["n"], saved["n_planned"]) == (True, [1, 4], 3, 5)
    assert [r["index"] for r in saved["runs"]] == [0, 2, 3]
    report = (tmp_path / "mc" / "report.md").read_text()
    assert "- **partial**: the Dask cluster lost its workers; 3 of 5 runs finished, missing runs 1, 4" in report
    # resume: only the missing ones run, and the set is complete
    ran = []
    monkeypatch.setattr(mc, "execute", lambda source, runs, *a, **k: ran.extend(r["index"] for r in runs)
                        or _results(source, runs))
    doc = mc.run_montecarlo("sine", 5, tmp_path / "mc", workers=0, quiet=True, seed=5, resume=True)
    assert ran == [1, 4] and doc["partial"] is False and doc["n"] == 5
