"""``ballbot firmware --guidance``: bad combinations refused with one line, exit 2, before
anything is generated or compiled."""

from __future__ import annotations

import pytest

from ballbot_casadi import cli
from ballbot_casadi.firmware import build as fw_build


def test_guidance_needs_the_flc_cascade(capsys, monkeypatch):
    monkeypatch.setattr(fw_build, "generate_sources",
                        lambda *a, **k: pytest.fail("generated before refusing"))
    assert cli.main(["firmware", "--controller", "smc", "--guidance", "mpc"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("ballbot firmware: error:"), err
    assert "controller 'smc'" in err and "flc" in err


def test_unknown_guidance_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["firmware", "--guidance", "lqr"])
    assert exc.value.code == 2
    assert "invalid choice: 'lqr'" in capsys.readouterr().err


@pytest.mark.parametrize("args, message", [
    (["--latency", "5"], "--latency 5 needs --guidance mpc"),
    (["--latency", "5", "--guidance", "pursuit"], "--latency 5 needs --guidance mpc"),
    (["--latency", "20", "--guidance", "mpc"], "latency must be an int in 0..19"),
])
def test_bad_latency_refused_before_generating(capsys, monkeypatch, args, message):
    monkeypatch.setattr(fw_build, "generate_sources",
                        lambda *a, **k: pytest.fail("generated before refusing"))
    assert cli.main(["firmware", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("ballbot firmware: error:"), err
    assert message in err
