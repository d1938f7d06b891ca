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


def test_every_data_file_is_package_data():
    import fnmatch

    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    data = cfg["package-data"]
    for path in (ROOT / "ballbot_casadi").rglob("*"):
        if path.is_dir() or path.suffix in (".py", ".pyc") or "__pycache__" in path.parts:
            continue
        rel = path.relative_to(ROOT)
        # the innermost package that holds the file and the pattern relative to it
        for depth in range(len(rel.parts) - 1, 0, -1):
            pkg = ".".join(rel.parts[:depth])
            if pkg in data:
                inner = "/".join(rel.parts[depth:])
                if any(fnmatch.fnmatch(inner, pat) for pat in data[pkg]):
                    break
        else:
            raise AssertionError(f"{rel} is not package data in pyproject.toml")
