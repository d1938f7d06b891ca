"""The wheel must contain every subpackage, so studies work from an installed package."""

from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parent.parent


def test_every_subpackage_is_listed_in_pyproject():
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(cfg["packages"])
    found = {
        ".".join(init.parent.relative_to(ROOT).parts)
        for init in (ROOT / "ballbot_casadi").rglob("__init__.py")
        if "__pycache__" not in init.parts
    }
    assert found <= listed, f"subpackages missing from pyproject packages: {found - listed}"
    for pkg, folder in cfg["package-dir"].items():
        assert pkg in listed and (ROOT / folder / "__init__.py").is_file()
