"""Each numeric option is refused just beyond each of its bounds, one line, exit 2, before
anything runs (issue 23: a bound moved from 1.0 to 10.0 survived because the tests probed
only far outside it)."""

from __future__ import annotations

import pytest

from ballbot_casadi import cli


@pytest.mark.parametrize("argv, needle", [
    (["--n", "2", "--min-success", "1.01"], "--min-success must be within [0, 1], got 1.01"),
    (["--n", "2", "--min-success", "1.5"], "--min-success"),
    (["--n", "2", "--min-success=-1e-9"], "--min-success"),
    (["--n", "-1"], "--n must be >= 1, got -1"),
])
def test_montecarlo_numbers_just_beyond_their_bounds(tmp_path, capsys, monkeypatch, argv, needle):
    from ballbot_casadi.studies import montecarlo_report

    monkeypatch.setattr(montecarlo_report, "execute", lambda *a, **k: pytest.fail("ran"))
    assert cli.main(["montecarlo", "zero", *argv, "--quiet", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and err.count("\n") == 0, err
    assert not (tmp_path / "o").exists()
