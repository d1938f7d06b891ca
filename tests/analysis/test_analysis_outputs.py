"""``ballbot analyze`` outputs appear together: a fresh folder replaces the old one.

A run that fails midway leaves the previous analysis untouched (no mix of new plots and
an old report); a complete run leaves no stale file of an earlier run behind.
"""

from __future__ import annotations

import json

import pytest

from ballbot_casadi.studies import analyze as study_analyze


def _names(folder):
    return sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))


def test_outputs_replace_the_previous_run_as_a_whole(tmp_path, monkeypatch):
    out = tmp_path / "analysis"
    first = study_analyze.run_analysis(out, plots=True)
    assert first["closed_loop"]["status"] == "ok"
    assert _names(out) == ["analysis.json", "analysis.md", "closed_loop.png", "pole_zero.png",
                           "singular_values.png"]
    assert sorted(first["files"]) == sorted(str(out / n) for n in _names(out))

    # a run that fails after writing its plots: the old folder is untouched
    def fail(*_a, **_k):
        raise RuntimeError("disk full while writing the report")

    before = {n: (out / n).read_bytes() for n in _names(out)}
    monkeypatch.setattr(study_analyze, "write_markdown", fail)
    pfile = tmp_path / "g0.toml"
    pfile.write_text("[environment]\ng = 0.0\n")
    with pytest.raises(RuntimeError, match="disk full"):
        study_analyze.run_analysis(out, str(pfile), plots=True)
    assert {n: (out / n).read_bytes() for n in _names(out)} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["analysis", "g0.toml"]
    monkeypatch.undo()

    # a complete run without a closed loop: no stale closed_loop.png beside the new report
    second = study_analyze.run_analysis(out, str(pfile), plots=True)
    assert second["closed_loop"]["status"] == "skipped"
    assert "closed_loop.png" not in _names(out)
    assert json.loads((out / "analysis.json").read_text())["parameters"]["g"] == 0.0
