"""Package architecture: layers import only from lower layers; imports sit at module level."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: Layer rank of each top-level part of the package (``studies`` is the studies/ folder).
LAYERS = {
    "errors": 0,
    "core": 1,
    "model": 2,
    "control": 3,
    "estimation": 3,
    "guidance": 3,
    "sim": 4,
    "analysis": 5,
    "codegen": 5,
    "fmi": 5,
    "studies": 6,
    "bench": 6,
    "cli": 7,
}
#: Optional dependencies that may be imported inside functions (extras, not installed by default).
OPTIONAL = {"libcosimpy", "pythonfmu", "dask", "distributed"}


def _modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted((ROOT / "ballbot_casadi").rglob("*.py")):
        rel = path.relative_to(ROOT / "ballbot_casadi")
        part = rel.parts[0].removesuffix(".py")
        if part == "__init__":
            continue
        out.append((part, path))
    out += [("studies", p) for p in sorted((ROOT / "studies").glob("*.py"))]
    return out


def _package_of(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "ballbot_casadi" or len(parts) < 2:
        return None
    return parts[1]


@pytest.mark.parametrize("part,path", _modules(), ids=lambda v: str(v).split("/work/main/")[-1])
def test_no_upward_or_sideways_imports(part, path):
    rank = LAYERS[part]
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level:
            pytest.fail(f"{path}: relative import (use absolute ballbot_casadi.* imports)")
        names = ([node.module] if isinstance(node, ast.ImportFrom) and node.module
                 else [a.name for a in node.names] if isinstance(node, ast.Import) else [])
        for name in names:
            target = _package_of(name)
            if target is None or target == part:
                continue
            assert target in LAYERS, f"{path}: import of unknown part {name}"
            assert LAYERS[target] < rank, (
                f"{path} ({part}, layer {rank}) imports {name} ({target}, layer {LAYERS[target]})")


@pytest.mark.parametrize("part,path", _modules(), ids=lambda v: str(v).split("/work/main/")[-1])
def test_imports_at_module_level(part, path):
    tree = ast.parse(path.read_text())
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(fn):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                mod = node.module if isinstance(node, ast.ImportFrom) else node.names[0].name
                assert (mod or "").split(".")[0] in OPTIONAL, (
                    f"{path}:{node.lineno}: import of {mod} inside {fn.name}(); only optional "
                    f"dependencies ({', '.join(sorted(OPTIONAL))}) may be imported lazily")


def test_public_api_at_the_top():
    import ballbot_casadi as bc

    for name in ("load_params", "BallbotModel", "make_state", "ClosedLoop", "run_scenario"):
        assert callable(getattr(bc, name)), name
