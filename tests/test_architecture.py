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
    "firmware": 5,
    "studies": 6,
    "bench": 7,  # above studies: it times the Monte Carlo runner of studies/
    "cli": 8,
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


# ------------------------------------------------------------------ one home per concept

#: The modules that define the packed vectors' layouts and the period's ports.
LAYOUT_HOMES = {ROOT / "ballbot_casadi" / "core" / "layout.py",
                ROOT / "ballbot_casadi" / "sim" / "ports.py"}
#: The parts that pack and unpack the period's vectors (control and estimation name their
#: Functions' own inputs and outputs).
PACKING_PARTS = {"sim", "fmi", "bench", "analysis", "studies", "cli"}
#: Names that hold packed vectors (mission state, controller state, estimate, filter
#: states, readings, the filters' initial state): indexed only through their layouts.
PACKED = {"xz", "xz0", "xz_next", "xz_final", "c", "c0", "c_next", "c_final", "cs", "x_hat",
          "xa", "xv", "xa0", "xv0", "xv_prev", "meas", "e0", "zn", "s_state"}


def _port_names() -> set[str]:
    from ballbot_casadi.sim import ports

    return {n for k, v in vars(ports).items() if k.isupper() and isinstance(v, tuple)
            for n in v if isinstance(n, str)}


def _int_literal(node: ast.AST | None) -> bool:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        node = node.operand
    return isinstance(node, ast.Constant) and type(node.value) is int


def _positional(index: ast.AST) -> bool:
    """An index into the vector made of integer literals: ``v[3]``, ``v[2:4]``, ``v[:6]``;
    for a log (one row per period) the last axis: ``v[k, 6:9]``."""
    if isinstance(index, ast.Tuple):
        return bool(index.elts) and _positional(index.elts[-1])
    if isinstance(index, ast.Slice):
        return _int_literal(index.lower) or _int_literal(index.upper)
    return _int_literal(index)


def _packed_indexing(tree: ast.AST) -> list[str]:
    bad = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Subscript):
            continue
        v = node.value
        name = v.id if isinstance(v, ast.Name) else v.attr if isinstance(v, ast.Attribute) else None
        if name in PACKED and _positional(node.slice):
            bad.append(f"line {node.lineno}: {ast.unparse(node)}")
    return bad


def _port_tuples(tree: ast.AST, ports: set[str]) -> list[str]:
    bad = []
    for node in ast.walk(tree):
        if not isinstance(node, (ast.Tuple, ast.List)) or len(node.elts) < 2:
            continue
        if all(isinstance(e, ast.Constant) and isinstance(e.value, str) and e.value in ports
               for e in node.elts):
            bad.append(f"line {node.lineno}: {ast.unparse(node)}")
    return bad


@pytest.mark.parametrize("part,path", _modules(), ids=lambda v: str(v).split("/work/main/")[-1])
def test_packed_vectors_are_indexed_by_name(part, path):
    """A literal index into a packed vector outside its layout's definition is a second
    definition of that layout: slice it by field name (``layout["xa"]``)."""
    if path in LAYOUT_HOMES or part not in PACKING_PARTS:
        return
    bad = _packed_indexing(ast.parse(path.read_text()))
    assert not bad, f"{path}: positional index into a packed vector: {'; '.join(bad)}"


@pytest.mark.parametrize("part,path", _modules(), ids=lambda v: str(v).split("/work/main/")[-1])
def test_port_tuples_live_in_the_port_list(part, path):
    """A tuple of the period's port names outside ``sim/ports.py`` is a second port list:
    use the named tuples of :mod:`ballbot_casadi.sim.ports`."""
    if path in LAYOUT_HOMES or part not in PACKING_PARTS:
        return
    bad = _port_tuples(ast.parse(path.read_text()), _port_names())
    assert not bad, f"{path}: port tuple outside sim/ports.py: {'; '.join(bad)}"


def test_the_checks_catch_what_they_are_for():
    """The two checks above flag the patterns they exist for, and not a named slice."""
    ports = _port_names()
    assert len(_packed_indexing(ast.parse("a = c[3:5] + xz[:12] + x_hat[2] + meas[0, 6:9]"))) == 4
    assert len(_packed_indexing(ast.parse("a = c[C['xa']] + xz[nx:] + q[0:4] + xz[-1, X['c']]"))) == 0
    assert _port_tuples(ast.parse("NAMES = ('q_ref', 'dq_ref', 'w')"), ports)
    assert not _port_tuples(ast.parse("NAMES = ('time', 'state', 'q_ref')"), ports)


#: Dataclasses that are filled in as a run goes (result logs): the only mutable ones.
MUTABLE_DATACLASSES = {"SilRun", "PathRun", "SimulationLog"}


def _dataclasses(tree: ast.AST) -> dict[str, bool | None]:
    """``{class name: frozen}`` of the ``@dataclass`` classes in ``tree`` (``frozen=`` read
    as written; ``None`` when it is not a literal)."""
    out: dict[str, bool | None] = {}
    for node in ast.walk(tree):
        if not isinstance(node, ast.ClassDef):
            continue
        for d in node.decorator_list:
            call = d if isinstance(d, ast.Call) else None
            name = (call.func if call else d)
            if (name.id if isinstance(name, ast.Name) else getattr(name, "attr", None)) != "dataclass":
                continue
            kw = {k.arg: k.value for k in call.keywords} if call else {}
            frozen = kw.get("frozen", ast.Constant(False))
            out[node.name] = frozen.value if isinstance(frozen, ast.Constant) else None
    return out


def test_value_dataclasses_are_frozen():
    """Every dataclass in the package and the studies is frozen (values that are shared
    between runs, caches and Dask workers cannot be changed behind a reader's back), but the
    result logs a run fills in."""
    found = {}
    for _, path in _modules():
        for name, frozen in _dataclasses(ast.parse(path.read_text())).items():
            found[name] = (frozen, path)
    assert len(found) > 40
    mutable = {n for n, (f, _) in found.items() if f is not True}
    assert mutable == MUTABLE_DATACLASSES, {n: str(found[n][1]) for n in mutable ^ MUTABLE_DATACLASSES}
    assert _dataclasses(ast.parse("@dataclass(frozen=False)\nclass A: pass\n@dataclass\nclass B: pass\n"
                                  "@dataclasses.dataclass(frozen=True, eq=False)\nclass C: pass")) == \
        {"A": False, "B": False, "C": True}

