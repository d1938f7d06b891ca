"""Where generated and compiled files go (``build_root``): ``$BALLBOT_BUILD_DIR``, else
``build/`` of a source checkout, else the user cache -- ``$XDG_CACHE_HOME/ballbot-casadi``
or ``~/.cache/ballbot-casadi`` (issue 23, fresh mutants: the cache fallback's ``or`` made
``and`` went unnoticed: no test looked at an installed package's build folder)."""

from __future__ import annotations

from pathlib import Path

from ballbot_casadi.core import toolchain


def test_env_then_checkout_then_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("BALLBOT_BUILD_DIR", str(tmp_path / "b"))
    assert toolchain.build_root() == (tmp_path / "b").resolve()
    monkeypatch.delenv("BALLBOT_BUILD_DIR")
    checkout = Path(toolchain.__file__).resolve().parents[2]
    if (checkout / "pyproject.toml").is_file():
        assert toolchain.build_root() == checkout / "build"
    # an installed package: no pyproject.toml two levels above the module
    monkeypatch.setattr(toolchain, "__file__", str(tmp_path / "site" / "ballbot_casadi" / "core" / "toolchain.py"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert toolchain.build_root() == tmp_path / "xdg" / "ballbot-casadi"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert toolchain.build_root() == tmp_path / "home" / ".cache" / "ballbot-casadi"
