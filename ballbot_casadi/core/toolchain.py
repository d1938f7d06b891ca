"""C code generation and compilation of CasADi Functions, with a self-verifying build cache.

Everything of one library lives in ``<build>/codegen/<hash>/``: the generated
``<name>.c|.h``, ``lib<name>.so|.a`` and ``MANIFEST.json``, where ``<hash>`` is the
SHA-256 of the generated sources, the compiler command and the CasADi version, so an
unchanged model is never recompiled.  The build root is ``$BALLBOT_BUILD_DIR`` if set,
else ``build/`` of the source checkout the package runs from, else
``~/.cache/ballbot-casadi``.

The cache heals itself.  ``MANIFEST.json`` records the size and SHA-256 of the four
files and is written last (atomically), after every file was moved into place with
:func:`os.replace`.  Every :func:`build_library` call (and so ``ballbot codegen``)
verifies it; a missing, truncated, emptied or altered file is rebuilt instead of being
loaded (loading a truncated shared library kills the process with SIGBUS).  Builds of the
same library are serialised by a lock file (``codegen/.<hash>.lock``) and compiled in a
private temporary folder, so concurrent processes or Dask workers never see a partial
file, and a process that already loaded the library keeps its mapping (files are
replaced, never rewritten in place).

The compiler is ``cc`` or ``$CC`` (default ``gcc``), split like a shell word list, so
``CC="ccache gcc"`` works; a missing compiler raises :class:`BuildError`.

A library may *link* others (``links``): its generated C calls their Functions by name
(a ``casadi.external`` of a linked library inside the exported Functions, see
:func:`linked_function`) instead of carrying their code, and its shared library holds
their static archives, so a large Function shared by several libraries (the
path-following MPC of every guided mission variant) is generated and compiled once.  The
library's hash covers the hashes of what it links; the linked libraries are verified
before the link.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import resource
import shlex
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterable, Iterator, Sequence

import casadi as ca

from ballbot_casadi.core.files import check_manifest, write_manifest
from ballbot_casadi.errors import BuildError

__all__ = [
    "CFLAGS",
    "MANIFEST",
    "build_root",
    "compiler_command",
    "generate_sources",
    "build_library",
    "linked_function",
    "verify_library",
    "load_library",
    "cached_file",
    "build_lock",
    "Library",
    "run_tool",
    "build_log_summary",
]

#: Strict C99 flags every generated file must compile with.
CFLAGS = ("-std=c99", "-O3", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-fPIC")
#: Name of the manifest (size + SHA-256 of every cached file) in a library's hash folder.
MANIFEST = "MANIFEST.json"

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
    # QP runtime (qrqp): its work-size and print helpers ignore some parameters
    src = re.sub(r"^((?:int|void) casadi_(?:qp_work|qrqp_print_\w+)\(([^)]*)\) \{\n)",
                 _void_params, src, flags=re.M)
    return src


def _void_params(m: re.Match) -> str:
    """The matched C function head followed by a ``(void)`` cast of each parameter."""
    names = [a.strip().split()[-1].lstrip("*") for a in m.group(2).split(",") if a.strip()]
    return m.group(1) + "".join(f"  (void){n};\n" for n in names)


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


def compiler_command(cc: str | Sequence[str] | None = None) -> list[str]:
    """The C compiler as an argument list: ``cc``, else ``$CC``, else ``gcc``.

    A string is split like a shell command (``"ccache gcc"`` -> ``["ccache", "gcc"]``).

    Raises
    ------
    BuildError
        Empty command, or its program is not found on ``PATH``.
    """
    src = "the cc argument"
    if cc is None:
        cc, src = os.environ.get("CC") or "gcc", "$CC" if os.environ.get("CC") else "default"
    try:
        cmd = shlex.split(cc) if isinstance(cc, str) else [str(c) for c in cc]
    except ValueError as exc:
        raise BuildError(f"C compiler {cc!r} ({src}) is not a valid command: {exc}") from None
    if not cmd:
        raise BuildError(f"C compiler ({src}) is empty; set CC to e.g. 'gcc' or 'ccache gcc'")
    if shutil.which(cmd[0]) is None:
        raise BuildError(f"C compiler {cmd[0]!r} ({src}: {cc!r}) not found; install gcc or set "
                         "CC to an installed compiler")
    return cmd


@dataclass(frozen=True)
class Library:
    """Paths of one generated and compiled library (all inside ``<build>/codegen/<digest>/``).

    ``status`` (not part of equality) tells what :func:`build_library` did: ``cached``
    (verified), ``built`` or ``rebuilt: <reason the cached copy was refused>``.
    """

    name: str
    source: Path
    header: Path
    shared: Path
    static: Path
    digest: str
    status: str = field(default="cached", compare=False)
    links: tuple["Library", ...] = field(default=(), compare=False)

    @property
    def folder(self) -> Path:
        """The hash folder holding every file of the library."""
        return self.shared.parent

    @property
    def files(self) -> tuple[Path, ...]:
        """Source, header, shared and static library."""
        return (self.source, self.header, self.shared, self.static)

    @property
    def archives(self) -> tuple[Path, ...]:
        """The static archives a program linking this library needs: its own, then those
        of the libraries it links (:func:`build_library` ``links``), depth first."""
        return (self.static, *(a for lib in self.links for a in lib.archives))


def run_tool(cmd: list[str], what: str) -> None:
    """Run a compiler/archiver command; raise :class:`BuildError` with its stderr on failure.

    With ``$BALLBOT_BUILD_LOG`` set to a file, each call appends one JSON line to it
    (:func:`_log_tool`): what was built, from which sources (their SHA-256), the
    command and the child CPU and wall seconds, so duplicate compiles can be counted.
    """
    log = os.environ.get("BALLBOT_BUILD_LOG")
    cpu0, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    try:
        res = subprocess.run(cmd, capture_output=True, text=True)
    except FileNotFoundError:
        raise BuildError(f"{what}: program {cmd[0]!r} not found; install gcc/binutils or set "
                         "CC") from None
    except OSError as exc:
        raise BuildError(f"{what}: cannot run {cmd[0]!r}: {exc}") from None
    if log:
        _log_tool(Path(log), cmd, what, cpu0, time.perf_counter() - t0)
    if res.returncode != 0:
        raise BuildError(f"{what} failed ({' '.join(cmd)}):\n{res.stderr[-4000:]}")


def _log_tool(log: Path, cmd: list[str], what: str, cpu0: resource.struct_rusage,
              wall: float) -> None:
    """Append one JSON line on a finished tool run to ``log`` (see :func:`run_tool`)."""
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    sources = {}
    for a in cmd:
        if a.endswith(".c") and Path(a).is_file():
            sources[Path(a).name] = hashlib.sha256(Path(a).read_bytes()).hexdigest()[:16]
    flags = [a for a in cmd[1:] if a.startswith("-") and not a.startswith(("-o", "-I"))]
    entry = {"what": what, "tool": Path(cmd[0]).name, "sources": sources, "flags": flags,
             "cpu_s": round(cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime, 3),
             "wall_s": round(wall, 3), "pid": os.getpid()}
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "a") as f:  # one short write per line: safe to share between processes
        f.write(json.dumps(entry) + "\n")


def build_log_summary(log: Path, offset: int = 0) -> dict:
    """Compiles recorded in a ``$BALLBOT_BUILD_LOG`` file (see :func:`run_tool`) from byte
    ``offset`` on.

    Returns
    -------
    dict
        ``compiles`` (tool runs reading a ``.c`` file), ``cpu_s`` (their child CPU
        seconds) and ``repeated``: ``[(what, times, cpu_s)]`` of the same sources compiled
        more than once by the same tool (flags may differ: work a shared build might save).
    """
    with open(log, "rb") as f:
        f.seek(offset)
        lines = f.read().decode(errors="replace").splitlines()
    entries = []
    for line in lines:
        with contextlib.suppress(ValueError):  # a torn line (a killed writer) is skipped
            e = json.loads(line)
            if isinstance(e, dict) and isinstance(e.get("sources"), dict):
                entries.append(e)
    compiles = [e for e in entries if e["sources"]]
    groups: dict[str, list[dict]] = {}
    for e in compiles:
        key = json.dumps([e["tool"], sorted(e["sources"].items())])
        groups.setdefault(key, []).append(e)
    repeated = [(g[0]["what"], len(g), round(sum(e["cpu_s"] for e in g), 3))
                for g in groups.values() if len(g) > 1]
    return {"compiles": len(compiles), "cpu_s": round(sum(e["cpu_s"] for e in compiles), 3),
            "repeated": sorted(repeated, key=lambda r: -r[2])}


@contextlib.contextmanager
def build_lock(path: Path) -> Iterator[None]:
    """Exclusive inter-process lock on the file ``path`` (created) while building."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def verify_library(lib: Library) -> str | None:
    """``None`` if every file of ``lib`` matches its manifest, else the reason it does not."""
    return check_manifest(lib.folder, [p.name for p in lib.files], MANIFEST)


def _library_paths(name: str, folder: Path, digest: str) -> Library:
    return Library(name, folder / f"{name}.c", folder / f"{name}.h", folder / f"lib{name}.so",
                   folder / f"lib{name}.a", digest)


def build_library(
    name: str,
    functions: Iterable[ca.Function],
    root: Path | None = None,
    cc: str | Sequence[str] | None = None,
    links: Sequence[Library] = (),
) -> Library:
    """Generate, write and compile a shared and a static library (cached by hash, verified).

    Parameters
    ----------
    name
        Library base name (``lib<name>.so``); also the C file name.
    functions
        CasADi Functions to export under their own names.
    root
        Build root, default :func:`build_root`.
    cc
        C compiler command, default ``$CC`` or ``gcc`` (see :func:`compiler_command`).
    links
        Libraries whose Functions ``functions`` call as externals (:func:`linked_function`):
        their static archives are linked into the shared library (which then needs
        nothing else), their hashes enter this library's hash.

    Returns
    -------
    Library
        Paths inside ``<root>/codegen/<digest>/``; the files match their manifest.

    Raises
    ------
    BuildError
        No functions, compiler missing, a linked library damaged or compilation failed.
    """
    root = build_root() if root is None else Path(root)
    ccmd = compiler_command(cc)
    links = tuple(links)
    for dep in links:
        problem = verify_library(dep)
        if problem is not None:
            raise BuildError(f"library {name!r} links {dep.name} ({dep.folder}), which is "
                             f"damaged ({problem}); build it again with build_library first")
    c_src, h_src = generate_sources(name, functions)
    digest = hashlib.sha256(
        "\0".join([c_src, h_src, *ccmd, *CFLAGS, ca.__version__,
                   *(f"link:{dep.name}:{dep.digest}" for dep in links)]).encode()
    ).hexdigest()[:16]
    out = root / "codegen"
    lib = replace(_library_paths(name, out / digest, digest), links=links)
    problem = verify_library(lib)
    if problem is None:
        return lib
    with build_lock(out / f".{digest}.lock"):
        problem = verify_library(lib)  # another process may have built it meanwhile
        if problem is None:
            return lib
        first = not lib.folder.exists()
        _compile_library(lib, c_src, h_src, ccmd)
    return replace(lib, status="built" if first else f"rebuilt: {problem}")


def _compile_library(lib: Library, c_src: str, h_src: str, ccmd: list[str]) -> None:
    """Compile into a private folder, move the files into place, write the manifest last."""
    folder = lib.folder
    folder.mkdir(parents=True, exist_ok=True)
    with contextlib.suppress(FileNotFoundError):
        (folder / MANIFEST).unlink()  # "incomplete" until the new manifest is written
    tmp = Path(tempfile.mkdtemp(prefix=f".{lib.name}-", dir=folder))
    try:
        tsrc, thdr = tmp / lib.source.name, tmp / lib.header.name
        tsrc.write_text(c_src)
        thdr.write_text(h_src)
        obj = tmp / f"{lib.name}.o"
        # one compile (CFLAGS has -fPIC): the shared library is linked from the same object
        # the static archive holds, so both carry identical code at half the gcc time
        run_tool([*ccmd, *CFLAGS, "-c", "-o", str(obj), str(tsrc)], f"compiling {lib.name}")
        # linked libraries: their archives after the object; -Bsymbolic binds the calls to
        # the copy inside this library (another loaded library may export the same name)
        deps = [str(a) for dep in lib.links for a in dep.archives]
        bind = ["-Wl,-Bsymbolic"] if deps else []
        run_tool([*ccmd, *CFLAGS, "-shared", *bind, "-o", str(tmp / lib.shared.name), str(obj),
                  *deps, "-lm"], f"linking {lib.name} (shared)")
        run_tool(["ar", "rcs", str(tmp / lib.static.name), str(obj)], f"archiving {lib.name}")
        for p in lib.files:
            os.replace(tmp / p.name, p)  # never rewrite a file in place (mapped copies live on)
        write_manifest(folder, [p.name for p in lib.files], MANIFEST)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def linked_function(f: ca.Function, root: Path | None = None,
                    cc: str | Sequence[str] | None = None) -> tuple[Library, ca.Function]:
    """``f`` compiled alone into the library ``<f's name>`` (cached by hash, verified) and
    a ``casadi.external`` of it with ``f``'s name, inputs and outputs.

    A Function built on the external in place of ``f`` generates C that calls ``f`` by
    name (declared ``extern``) instead of carrying its code; compile it with
    ``build_library(..., links=[library])``.  The external's Python evaluation runs the
    compiled ``f``.
    """
    lib = build_library(f.name(), [f], root, cc)
    ext = load_library(lib, [f.name()])[f.name()]
    if (ext.name_in(), ext.name_out()) != (f.name_in(), f.name_out()):
        raise BuildError(f"linked {f.name()}: the compiled Function's ports {ext.name_in()} -> "
                         f"{ext.name_out()} differ from {f.name_in()} -> {f.name_out()}")
    return lib, ext


def cached_file(target: Path, make: Callable[[Path], None], key: str = "") -> Path:
    """A verified cached build product: return ``target``, building it first if needed.

    ``target`` is reused when its sidecar manifest ``.<name>.manifest.json`` (size and
    SHA-256, plus ``key``) matches; otherwise ``make(tmp)`` must create the file ``tmp``
    (in a private folder next to ``target``), which is then moved over ``target`` and
    recorded.  Concurrent callers are serialised by ``.<name>.lock``.  Use it for any
    compiled artifact that is loaded with ``dlopen`` (e.g. a mission driver).
    """
    target = Path(target)
    manifest = f".{target.name}.manifest.json"

    def ok() -> bool:
        if check_manifest(target.parent, [target.name], manifest) is not None:
            return False
        return key == "" or _manifest_key(target.parent / manifest) == key

    if ok():
        return target
    with build_lock(target.parent / f".{target.name}.lock"):
        if ok():
            return target
        with contextlib.suppress(FileNotFoundError):
            (target.parent / manifest).unlink()
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}-", dir=target.parent))
        try:
            make(tmp / target.name)
            if not (tmp / target.name).is_file():
                raise BuildError(f"building {target.name} produced no file")
            os.replace(tmp / target.name, target)
            write_manifest(target.parent, [target.name], manifest, extra={"key": key})
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return target


def _manifest_key(path: Path) -> str:
    try:
        return str(json.loads(path.read_text()).get("extra", {}).get("key", ""))
    except (OSError, ValueError, AttributeError):
        return ""


def load_library(lib: Library, names: Iterable[str]) -> dict[str, ca.Function]:
    """Load compiled Functions from a library with ``casadi.external``.

    Raises
    ------
    BuildError
        The library cannot be loaded or lacks one of ``names``.
    """
    try:
        return {n: ca.external(n, str(lib.shared)) for n in names}
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise BuildError(f"loading {lib.shared} failed ({first}); delete {lib.folder} to force "
                         "a rebuild") from None
