"""``ballbot codegen`` verifies the cached libraries and rebuilds damaged ones."""

from __future__ import annotations

import casadi as ca
import pytest

from ballbot_casadi import cli
from ballbot_casadi.codegen import libraries

pytestmark = pytest.mark.needs_cc


def _tiny() -> list[ca.Function]:
    x = ca.SX.sym("x")
    return [ca.Function("ballbot_reverify", [x], [x + 1], ["x"], ["y"])]


def test_codegen_reports_and_repairs_a_truncated_library(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BALLBOT_BUILD_DIR", str(tmp_path))
    monkeypatch.setattr(libraries, "CODEGEN_LIBRARIES", {"reverify": _tiny})
    assert cli.main(["codegen"]) == 0
    assert "reverify (built)" in capsys.readouterr().out
    assert cli.main(["codegen"]) == 0
    assert "reverify (cached)" in capsys.readouterr().out
    so = next(tmp_path.glob("codegen/*/libreverify.so"))
    size = so.stat().st_size
    with open(so, "r+b") as f:
        f.truncate(size // 2)
    assert cli.main(["codegen"]) == 0  # once: "success" with the broken file left in place
    out = capsys.readouterr().out
    assert "reverify (rebuilt:" in out and f"{size // 2} bytes" in out
    assert so.stat().st_size == size
