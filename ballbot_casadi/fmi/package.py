"""Build any FMU of the package from its :class:`~ballbot_casadi.fmi.spec.FmuSpec`.

:func:`build_fmu_from_spec` generates ``modelDescription.xml``
(:mod:`~ballbot_casadi.fmi.model_description`), the C headers
(:mod:`~ballbot_casadi.fmi.cheaders`) and the CasADi C of the spec's Functions, and
compiles them with the hand-written C in ``fmu/`` (one folder per part: the shared FMI
2.0 layer ``fmu/layer/``, listed in :data:`COMMON_SOURCES`, and the spec's per-model file
in ``fmu/<model>/``) and the spec's extra sources into
``binaries/<platform>/<model_identifier>.so``, zipped with all sources (so
``fmpy compile`` can rebuild the binary elsewhere).

The binary exports only ``fmi2*`` symbols (``-fvisibility=hidden``; the FMI headers mark
the API) and links only libc and libm.  Builds are cached under
``<out>/cache/<hash>/`` keyed by the SHA-256 of every source, the compiler and its
flags, with a ``MANIFEST.json`` (size and SHA-256 of every file) that is verified on every
use: a damaged cache is rebuilt, and an archive is checked (zip CRCs, binary hash) before
it is published.  The FMI 2.0 and 3.0 headers are the ones shipped with fmpy
(``fmpy/c-code``); ``fmi_version=3`` builds the same spec behind the FMI 3.0 entry points.
The GUID is a hash of everything that defines the binary's behaviour.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import tempfile
import uuid
import zipfile
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from xml.etree import ElementTree

import fmpy

from ballbot_casadi.core.files import (
    atomic_write_bytes,
    check_manifest,
    sha256_file,
    write_manifest,
    zip_bytes,
)
from ballbot_casadi.core.toolchain import (
    MANIFEST,
    build_lock,
    build_root,
    cached_file,
    compiler_command,
    generate_sources,
    run_tool,
)
from ballbot_casadi.errors import BuildError, FileFormatError
from ballbot_casadi.fmi.cheaders import info_header, vars_header, vr_header
from ballbot_casadi.fmi.model_description import model_description_xml
from ballbot_casadi.fmi.model_description3 import model_description3_xml
from ballbot_casadi.fmi.spec import FmuSpec

__all__ = [
    "FmuBuild",
    "CFLAGS",
    "LDFLAGS",
    "COMMON_SOURCES",
    "COMMON_C_SOURCES",
    "FMI3_SOURCES",
    "FMI_VERSIONS",
    "TOOLS_DIR",
    "build_fmu_from_spec",
    "build_tool",
    "fmi_headers_dir",
    "fmu_source_dir",
    "platform_dir",
    "binary_member",
    "validate_fmu_archive",
    "verify_cache",
    "generated_files",
    "casadi_sources",
]

#: Hand-written C of the shared FMI layer (``fmu/layer/``), part of every FMU: the core
#: (instance, call table, logging, checks, values), the life cycle, get/set by value
#: reference, FMU states, the mode-specific calls (directional derivatives, Model Exchange,
#: Co-Simulation), the one call of CasADi Functions (``fmu_casadi``); the per-model
#: interface and the layer's internal header.  Paths relative to :func:`fmu_source_dir`;
#: every file lands flat in the FMU's ``sources/``.
COMMON_SOURCES = ("layer/fmi2_common.c", "layer/fmi2_instance.c", "layer/fmi2_values.c",
                  "layer/fmi2_state.c", "layer/fmi2_modes.c", "layer/fmu_casadi.c",
                  "layer/fmi2_common.h", "layer/fmi2_internal.h", "layer/fmu_casadi.h")
#: The C files of :data:`COMMON_SOURCES`, compiled into every FMU (names in ``sources/``).
COMMON_C_SOURCES = tuple(Path(s).name for s in COMMON_SOURCES if s.endswith(".c"))
#: The FMI 3.0 entry points (a thin adapter over the layer), added to an FMI 3.0 build.
FMI3_SOURCES = ("layer/fmi3_functions.c",)
#: FMI versions :func:`build_fmu_from_spec` builds.
FMI_VERSIONS = (2, 3)
#: Linker version script of an FMI 3.0 binary: only the fmi3* entry points are exported
#: (the layer's fmi2* functions stay inside).
FMI3_EXPORTS = "fmi3_exports.map"
_FMI3_EXPORTS_TEXT = "{\n  global: fmi3*;\n  local: *;\n};\n"
#: Folder of the C tools (hosts, fuzzer) under :func:`fmu_source_dir`.
TOOLS_DIR = "tools"
#: What the C host programs (``fmu/tools/host.c``, ``fmu/tools/controller_host.c``) share.
HOST_HEADER = f"{TOOLS_DIR}/fmi2_host.h"
CFLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-fPIC",
          "-fvisibility=hidden")
LDFLAGS = ("-shared", "-static-libgcc", "-Wl,--no-undefined", "-Wl,--as-needed")


@dataclass(frozen=True)
class FmuBuild:
    """Result of :func:`build_fmu_from_spec`."""

    fmu: Path  #: the .fmu archive
    unzipped: Path  #: directory with the unpacked FMU (modelDescription.xml, binaries, sources)
    binary: Path  #: the shared library inside ``unzipped``
    guid: str
    digest: str
    model_identifier: str
    status: str = field(default="cached", compare=False)  #: cached, built or rebuilt: <why>
    fmi_version: int = 2


def fmi_headers_dir() -> Path:
    """Directory of the FMI 2.0 and 3.0 headers shipped with fmpy (``fmpy/c-code``)."""
    d = Path(fmpy.__file__).resolve().parent / "c-code"
    if not all((d / h).is_file() for h in ("fmi2Functions.h", "fmi3Functions.h")):
        raise BuildError(f"the FMI 2.0/3.0 headers are missing from the fmpy installation ({d})")
    return d


def fmu_source_dir() -> Path:
    """Directory of the hand-written FMU C sources.

    The installed package data ``ballbot_casadi.fmu_src`` if it holds every file of
    :data:`COMMON_SOURCES` (``layer/``, ``plant/``, ``controller/``, ``reference/``,
    ``tools/``), else ``fmu/`` of the source checkout.
    """
    try:
        d = Path(str(resources.files("ballbot_casadi.fmu_src")))
        if all((d / name).is_file() for name in COMMON_SOURCES):
            return d
    except (ModuleNotFoundError, TypeError):
        pass
    d = Path(__file__).resolve().parents[2] / "fmu"
    if all((d / name).is_file() for name in COMMON_SOURCES):
        return d
    raise BuildError(f"the FMU C sources ({', '.join(COMMON_SOURCES)} in fmu/) were not found; "
                     "reinstall the package or run from the source checkout")


def platform_dir(fmi_version: int = 2) -> str:
    """Platform directory name of this machine: FMI 2.0 ``linux64``, FMI 3.0
    ``x86_64-linux``."""
    return fmpy.platform if fmi_version == 2 else fmpy.platform_tuple


def binary_member(model_identifier: str, fmi_version: int = 2) -> str:
    """Archive path of an FMU binary, ``binaries/<platform>/<model_identifier>.so``."""
    return f"binaries/{platform_dir(fmi_version)}/{model_identifier}.so"


def _model_identifier(xml: bytes, path: Path) -> tuple[str, int]:
    """The model identifier and the FMI major version (2 or 3) of a model description."""
    try:
        root = ElementTree.fromstring(xml)
    except ElementTree.ParseError as exc:
        raise FileFormatError(f"{path}: modelDescription.xml is not valid XML ({exc})") from None
    version = 3 if root.get("fmiVersion", "").startswith("3") else 2
    for tag in ("CoSimulation", "ModelExchange"):
        el = root.find(tag)
        if el is not None and el.get("modelIdentifier"):
            return el.get("modelIdentifier"), version
    raise FileFormatError(f"{path}: modelDescription.xml names no modelIdentifier")


def validate_fmu_archive(path: str | Path, binary_sha256: str | None = None,
                         require_binary: bool = True) -> None:
    """Check an FMU archive before it is published or used.

    The zip must be readable with every member's CRC intact, hold
    ``modelDescription.xml`` and (``require_binary``) the binary of this platform named
    by the model identifier in that XML, and (when ``binary_sha256`` is given) the
    binary must have that SHA-256.

    Raises
    ------
    BuildError
        Saying what is wrong with the archive.
    """
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as zf:
            bad = zf.testzip()
            if bad is not None:
                raise FileFormatError(f"{path} is corrupt: member {bad} fails its CRC check")
            names = set(zf.namelist())
            if "modelDescription.xml" not in names:
                raise FileFormatError(f"{path} lacks modelDescription.xml")
            if not require_binary and binary_sha256 is None:
                return
            member = binary_member(*_model_identifier(zf.read("modelDescription.xml"), path))
            if member not in names:
                raise FileFormatError(f"{path} lacks {member}")
            if binary_sha256 is not None:
                if hashlib.sha256(zf.read(member)).hexdigest() != binary_sha256:
                    raise FileFormatError(f"{path}: {member} differs from the built binary "
                                     "(SHA-256 mismatch)")
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError, ValueError) as exc:
        raise FileFormatError(f"{path} is not a valid FMU archive ({exc})") from None


def _write_zip(root: Path, target: Path) -> None:
    """The files under ``root`` as a deterministic zip (:func:`zip_bytes`; the shared
    objects executable), written atomically."""
    files = {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}
    atomic_write_bytes(target, zip_bytes(files, executable=[n for n in files if n.endswith(".so")]))


def verify_cache(cache: Path, model_identifier: str, fmi_version: int = 2) -> str | None:
    """``None`` if the cached build in ``cache`` matches its manifest (and the archive is
    sound), else the reason it cannot be used."""
    member = binary_member(model_identifier, fmi_version)
    problem = check_manifest(cache, [f"{model_identifier}.fmu", f"unzipped/{member}",
                                     "unzipped/modelDescription.xml"], MANIFEST)
    if problem is not None:
        return problem
    try:
        validate_fmu_archive(cache / f"{model_identifier}.fmu",
                             sha256_file(cache / "unzipped" / member))
    except BuildError as exc:
        return str(exc)
    return None


def _build_into(tmp: Path, spec: FmuSpec, xml: str, files: dict[str, str], c_sources: list[str],
                ccmd: list[str], fmi_version: int) -> None:
    """Write, compile and zip one FMU into the empty folder ``tmp``; manifest last."""
    troot = tmp / "unzipped"
    member = binary_member(spec.model_identifier, fmi_version)
    (troot / "sources").mkdir(parents=True)
    (troot / member).parent.mkdir(parents=True)
    (troot / "modelDescription.xml").write_text(xml)
    for name, text in files.items():
        (troot / "sources" / name).write_text(text)
    cmd = [*ccmd, *CFLAGS, "-I", str(troot / "sources"), "-I", str(fmi_headers_dir()),
           *[str(troot / "sources" / s) for s in c_sources], *LDFLAGS, "-o",
           str(troot / member), "-lm"]
    if fmi_version == 3:
        cmd.insert(-1, f"-Wl,--version-script={troot / 'sources' / FMI3_EXPORTS}")
    run_tool(cmd, f"compiling {spec.model_identifier}")
    fmu_name = f"{spec.model_identifier}.fmu"
    _write_zip(troot, tmp / fmu_name)
    names = sorted(p.relative_to(tmp).as_posix() for p in troot.rglob("*") if p.is_file())
    write_manifest(tmp, [*names, fmu_name], MANIFEST)


def _publish(cached: Path, final: Path) -> None:
    """Copy the verified cached archive to ``final`` (atomically) unless it is already there."""
    want = sha256_file(cached)
    if final.is_file() and final.stat().st_size == cached.stat().st_size:
        with contextlib.suppress(OSError):
            if sha256_file(final) == want:
                return
    tmp = final.with_name(f".{final.name}.{os.getpid()}.tmp")
    try:
        shutil.copyfile(cached, tmp)
        if sha256_file(tmp) != want:
            raise BuildError(f"copying {cached} to {final} produced a different file")
        validate_fmu_archive(tmp)
        os.replace(tmp, final)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def casadi_sources(spec: FmuSpec) -> tuple[str, str]:
    """The CasADi C source and header of the spec's Functions (``<cg_name>.c|.h``)."""
    cg_c, cg_h = generate_sources(spec.cg_name, spec.functions)
    # Keep the CasADi entry points out of the dynamic symbol table (-fvisibility=hidden).
    return "#define CASADI_SYMBOL_EXPORT\n" + cg_c, cg_h


def generated_files(spec: FmuSpec, guid: str, cg: tuple[str, str] | None = None,
                    fmi_version: int = 2) -> tuple[str, dict[str, str], list[str]]:
    """``(modelDescription.xml, {source name: text}, C files to compile)`` of ``spec``.

    The sources are the shared layer, the per-model C file, the spec's extra sources,
    the generated headers and the CasADi C ``cg`` (default :func:`casadi_sources`);
    FMI 3.0 adds the layer's FMI 3.0 entry points and their export list, and writes the
    FMI 3.0 model description (:mod:`~ballbot_casadi.fmi.model_description3`) of the
    same table.
    """
    if fmi_version not in FMI_VERSIONS:
        raise BuildError(f"FMI version {fmi_version!r} is not supported (allowed: 2, 3)")
    cg_c, cg_h = casadi_sources(spec) if cg is None else cg
    src_dir = fmu_source_dir()
    model = (Path(spec.model_source) if isinstance(spec.model_source, Path)
             else src_dir / spec.model_source)
    files = {Path(name).name: (src_dir / name).read_text() for name in COMMON_SOURCES}
    for path in (model, *spec.extra_sources):
        if not Path(path).is_file():
            raise BuildError(f"C source {path} of {spec.model_identifier} does not exist")
    if model.name in files:
        raise BuildError(f"the per-model C file {model} clashes with a shared-layer file")
    files[model.name] = model.read_text()
    for path in spec.extra_sources:
        if path.name in files:
            raise BuildError(f"extra source {path} clashes with a source of the same name")
        files[path.name] = Path(path).read_text()
    files.update({
        f"{spec.prefix}_vr.h": vr_header(spec, guid),
        f"{spec.prefix}_vars.h": vars_header(spec),
        "fmu_model_info.h": info_header(spec),
        f"{spec.cg_name}.c": cg_c,
        f"{spec.cg_name}.h": cg_h,
    })
    c_sources = [*COMMON_C_SOURCES, model.name, f"{spec.cg_name}.c",
                 *[p.name for p in spec.extra_sources if p.suffix == ".c"]]
    if fmi_version == 3:
        for name in FMI3_SOURCES:
            files[Path(name).name] = (src_dir / name).read_text()
            c_sources.append(Path(name).name)
        files[FMI3_EXPORTS] = _FMI3_EXPORTS_TEXT
        return model_description3_xml(spec, guid), files, c_sources
    return model_description_xml(spec, guid, c_sources), files, c_sources


def build_fmu_from_spec(spec: FmuSpec, out: str | Path | None = None,
                        cc: str | None = None, fmi_version: int = 2) -> FmuBuild:
    """Generate, compile and zip ``<model_identifier>.fmu`` (cached by content hash, verified).

    The build lives in ``<out>/cache/<digest>/`` (the archive, the unpacked tree and a
    ``MANIFEST.json`` with the size and SHA-256 of every file).  Every call verifies the
    manifest and the archive (zip CRCs, binary hash) and rebuilds a damaged or partial
    cache: a new build is made in a private folder and renamed into place as a whole
    (the damaged folder is moved aside first), under a lock shared by concurrent
    builders.  The archive is then published as ``<out>/<model_identifier>.fmu``
    (copied, checked, renamed into place) unless an identical file is already there.

    Parameters
    ----------
    spec
        The FMU (:class:`~ballbot_casadi.fmi.spec.FmuSpec`).
    out
        Directory that receives the FMU (default ``<build>/fmu``).
    cc
        C compiler command, default ``$CC`` or ``gcc`` (``"ccache gcc"`` allowed).
    fmi_version
        2 (default) or 3: the same table and per-model C behind the FMI 3.0 entry points
        (``fmu/layer/fmi3_functions.c``), ``binaries/x86_64-linux/``.  Both versions
        have the same file name, so the FMI 3.0 default ``out`` is ``<build>/fmu3``.

    Raises
    ------
    BuildError
        Missing compiler, headers or sources, or a compile error.
    """
    default_out = "fmu" if fmi_version == 2 else "fmu3"
    out = Path(out) if out is not None else build_root() / default_out
    ccmd = compiler_command(cc)
    cg = casadi_sources(spec)
    probe_xml, probe_files, _ = generated_files(spec, "{GUID}", cg, fmi_version)
    seed = hashlib.sha256("\0".join(
        [probe_xml, *[f"{k}\n{v}" for k, v in sorted(probe_files.items())]]).encode()).digest()
    guid = "{" + str(uuid.UUID(bytes=seed[:16])) + "}"
    xml, files, c_sources = generated_files(spec, guid, cg, fmi_version)
    digest = hashlib.sha256(
        "\0".join([xml, *[f"{k}\n{v}" for k, v in sorted(files.items())], *ccmd, *CFLAGS,
                   *LDFLAGS, platform_dir()]).encode()
    ).hexdigest()[:16]
    cache_root = out / "cache"
    cache = cache_root / digest
    fmu_path = cache / f"{spec.model_identifier}.fmu"
    unz = cache / "unzipped"
    status = "cached"
    problem = verify_cache(cache, spec.model_identifier, fmi_version)
    if problem is not None:
        with build_lock(cache_root / f".{digest}.lock"):
            problem = verify_cache(cache, spec.model_identifier, fmi_version)  # maybe built
            if problem is not None:
                status = f"rebuilt: {problem}" if cache.exists() else "built"
                tmp = Path(tempfile.mkdtemp(prefix=".build-", dir=cache_root))
                try:
                    _build_into(tmp, spec, xml, files, c_sources, ccmd, fmi_version)
                    if cache.exists():  # damaged: move aside, then delete
                        trash = Path(tempfile.mkdtemp(prefix=".trash-", dir=cache_root))
                        os.replace(cache, trash / "old")
                        shutil.rmtree(trash, ignore_errors=True)
                    os.replace(tmp, cache)
                finally:
                    shutil.rmtree(tmp, ignore_errors=True)
    out.mkdir(parents=True, exist_ok=True)
    final = out / fmu_path.name
    _publish(fmu_path, final)
    return FmuBuild(final, unz, unz / binary_member(spec.model_identifier, fmi_version), guid,
                    digest, spec.model_identifier, status, fmi_version)


def build_tool(build: FmuBuild, name: str, cc: str | None = None) -> Path:
    """Compile the C host program ``fmu/tools/<name>.c`` against ``build``.

    The program includes the generated headers of the FMU (``<prefix>_vr.h``, or the
    neutral ``fmu_model_info.h``), the hosts' shared ``fmu/tools/fmi2_host.h`` and the fmpy FMI
    headers, and loads the FMU binary with ``dlopen`` at run time; it is cached (verified, see
    :func:`~ballbot_casadi.core.toolchain.cached_file`) next to the FMU build.
    """
    ccmd = compiler_command(cc)
    src = fmu_source_dir() / TOOLS_DIR / f"{name}.c"
    if not src.is_file():
        raise BuildError(f"no C host program {src}")
    text = src.read_text() + "\0" + (fmu_source_dir() / HOST_HEADER).read_text()
    tag = hashlib.sha256("\0".join([text, *ccmd, *CFLAGS]).encode()).hexdigest()[:12]
    exe = build.unzipped.parent / f"{name}-{tag}"

    def make(tmp: Path) -> None:
        run_tool([*ccmd, *CFLAGS, "-I", str(build.unzipped / "sources"), "-I",
                  str(fmi_headers_dir()), "-o", str(tmp), str(src), "-ldl", "-lm"],
                 f"compiling {name}.c")

    return cached_file(exe, make)
