"""C code generation and compilation of CasADi Functions, with a build cache.

Generated sources go to ``<build>/codegen/<name>.c|.h``; compiled libraries to
``<build>/codegen/<hash>/lib<name>.so|.a`` where ``<hash>`` is the SHA-256 of the
generated sources and the compiler command, so an unchanged model is never
recompiled.  The build root is ``$BALLBOT_BUILD_DIR`` if set, else ``build/`` of the
source checkout the package runs from, else ``~/.cache/ballbot-casadi``.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import casadi as ca

from ballbot_casadi.errors import BuildError

__all__ = [
    "CFLAGS",
    "build_root",
    "generate_sources",
    "build_library",
    "load_library",
    "Library",
    "run_tool",
]

#: Strict C99 flags every generated file must compile with.
CFLAGS = ("-std=c99", "-O3", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-fPIC")

_CG_OPTIONS = {
    "with_header": True,
    "casadi_real": "double",
    "casadi_int": "long long int",
    "with_export": True,
    "verbose": False,
}


def build_root() -> Path:
    """Root directory for generated and compiled files (see module docstring)."""
    env = os.environ.get("BALLBOT_BUILD_DIR")
    if env:
        return Path(env).resolve()
    src_root = Path(__file__).resolve().parents[2]
    if (src_root / "pyproject.toml").is_file() and (src_root / "ballbot_casadi").is_dir():
        return src_root / "build"
    cache = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(cache) / "ballbot-casadi"


def _strict_c(src: str) -> str:
    """Make CasADi output pass ``-Wextra -Werror``: mark unused parameters as used.

    CasADi emits entry points whose work-vector and memory arguments are sometimes
    unused; a ``(void)`` cast documents that without suppressing any diagnostic.
    """
    src = re.sub(
        r"(static int casadi_f\d+\(const casadi_real\*\* arg, casadi_real\*\* res, "
        r"casadi_int\* iw, casadi_real\* w, int mem\) \{\n)",
        r"\1  (void)arg; (void)res; (void)iw; (void)w; (void)mem;\n",
        src,
    )
    src = re.sub(r"(CASADI_SYMBOL_EXPORT void \w+_(?:release|incref|decref)\(int mem\) \{\n)",
                 r"\1  (void)mem;\n", src)
    return src


def generate_sources(name: str, functions: Iterable[ca.Function]) -> tuple[str, str]:
    """Generate C99 source and header text for ``functions`` (deterministic)."""
    funcs = list(functions)
    if not funcs:
        raise BuildError(f"library {name!r}: no functions to generate")
    cg = ca.CodeGenerator(f"{name}.c", dict(_CG_OPTIONS))
    for f in funcs:
        cg.add(f)
    with tempfile.TemporaryDirectory() as tmp:
        cg.generate(tmp + os.sep)
        c_src = Path(tmp, f"{name}.c").read_text()
        h_src = Path(tmp, f"{name}.h").read_text()
    return _strict_c(c_src), h_src


def _write_if_changed(path: Path, text: str) -> None:
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)


@dataclass(frozen=True)
class Library:
    """Paths of one generated and compiled library."""

    name: str
    source: Path
    header: Path
    shared: Path
    static: Path
    digest: str


def run_tool(cmd: list[str], what: str) -> None:
    """Run a compiler/archiver command; raise :class:`BuildError` with its stderr on failure."""
    try:
        res = subprocess.run(cmd, capture_output=True, text=True)
    except FileNotFoundError:
        raise BuildError(f"{what}: compiler {cmd[0]!r} not found; install gcc") from None
    if res.returncode != 0:
        raise BuildError(f"{what} failed ({' '.join(cmd)}):\n{res.stderr[-4000:]}")


def build_library(
    name: str,
    functions: Iterable[ca.Function],
    root: Path | None = None,
    cc: str | None = None,
) -> Library:
    """Generate, write and compile a shared and a static library (cached by hash).

    Parameters
    ----------
    name
        Library base name (``lib<name>.so``); also the C file name.
    functions
        CasADi Functions to export under their own names.
    root
        Build root, default :func:`build_root`.
    cc
        C compiler, default ``$CC`` or ``gcc``.
    """
    root = build_root() if root is None else Path(root)
    cc = cc or os.environ.get("CC", "gcc")
    c_src, h_src = generate_sources(name, functions)
    digest = hashlib.sha256(
        "\0".join([c_src, h_src, cc, *CFLAGS, ca.__version__]).encode()
    ).hexdigest()[:16]
    out = root / "codegen"
    out.mkdir(parents=True, exist_ok=True)
    source, header = out / f"{name}.c", out / f"{name}.h"
    _write_if_changed(source, c_src)
    _write_if_changed(header, h_src)
    cache = out / digest
    shared, static = cache / f"lib{name}.so", cache / f"lib{name}.a"
    if not (shared.is_file() and static.is_file()):
        tmp = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=out))
        try:
            tsrc = tmp / f"{name}.c"
            tsrc.write_text(c_src)
            (tmp / f"{name}.h").write_text(h_src)
            run_tool([cc, *CFLAGS, "-shared", "-o", str(tmp / shared.name), str(tsrc), "-lm"],
                 f"compiling {name} (shared)")
            run_tool([cc, *CFLAGS, "-c", "-o", str(tmp / f"{name}.o"), str(tsrc)],
                 f"compiling {name} (object)")
            run_tool(["ar", "rcs", str(tmp / static.name), str(tmp / f"{name}.o")],
                 f"archiving {name}")
            cache.mkdir(exist_ok=True)
            os.replace(tmp / shared.name, shared)
            os.replace(tmp / static.name, static)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return Library(name, source, header, shared, static, digest)


def load_library(lib: Library, names: Iterable[str]) -> dict[str, ca.Function]:
    """Load compiled Functions from a library with ``casadi.external``."""
    return {n: ca.external(n, str(lib.shared)) for n in names}
