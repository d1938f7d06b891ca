"""Build the native FMI 2.0 plant FMU ``BallbotPlant.fmu`` (Model Exchange + Co-Simulation).

One Python table, :func:`plant_variables`, defines every FMU variable once: its value
reference, kind, start value, unit and description.  From it this module generates

* ``modelDescription.xml`` (:func:`model_description_xml`),
* the C header ``plant_vars.h`` with value references, start values, kinds, names and
  parameter ranges (:func:`vars_header`),

and from the model the CasADi C of the plant (``ballbot_plant_cg.c``: ODE, RK4 step,
outputs and the dense Jacobian used for directional derivatives).  Together with the
hand-written C in ``fmu/`` (the shared FMI 2.0 layer ``fmi2_common.c`` and the per-model
``plant_model.c``) they are compiled with gcc into ``binaries/<platform>/BallbotPlant.so``
and zipped with their sources (so ``fmpy compile`` can rebuild the binary elsewhere).

The binary exports only ``fmi2*`` symbols (``-fvisibility=hidden``; the FMI headers mark
the API) and links only libc and libm.  Builds are cached under
``<build>/fmu/cache/<hash>/`` keyed by the SHA-256 of every source, the compiler and its
flags, with a ``MANIFEST.json`` (size and SHA-256 of every file) that is verified on every
use: a damaged cache is rebuilt, and an archive is checked (zip CRCs, binary hash) before
it is published.  The FMI 2.0 headers are the ones shipped with fmpy (``fmpy/c-code``).
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import shutil
import tempfile
import uuid
import zipfile
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Sequence
from xml.sax.saxutils import quoteattr

import casadi as ca
import fmpy

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.files import check_manifest, sha256_file, write_manifest
from ballbot_casadi.core.params import PARAM_INFO, PARAM_NAMES, PARAM_RULES, load_params
from ballbot_casadi.core.toolchain import (
    MANIFEST,
    build_lock,
    build_root,
    cached_file,
    compiler_command,
    generate_sources,
    run_tool,
)
from ballbot_casadi.core.validation import QUAT_TOL
from ballbot_casadi.errors import BuildError
from ballbot_casadi.model.dynamics import (
    INPUT_NAMES,
    NP,
    NU,
    NX,
    STATE_NAMES,
    make_model_functions,
)
from ballbot_casadi.model.integrators import make_rk4
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.model.sensors import make_sensors

__all__ = [
    "MODEL_IDENTIFIER",
    "FmuVar",
    "FmuBuild",
    "plant_variables",
    "plant_functions",
    "model_description_xml",
    "vars_header",
    "fmi_headers_dir",
    "fmu_source_dir",
    "build_fmu",
    "build_tool",
    "binary_member",
    "validate_fmu_archive",
    "H_INTERNAL_DEFAULT",
]

MODEL_IDENTIFIER = "BallbotPlant"
#: Default internal RK4 step of fmi2DoStep (s).
H_INTERNAL_DEFAULT = 1e-3
#: Largest number of RK4 sub-steps one fmi2DoStep may take.
MAX_SUBSTEPS = 1_000_000
#: Hand-written C files of the FMU (in ``fmu/``) that go into the binary.
HAND_SOURCES = ("fmi2_common.c", "fmi2_common.h", "plant_model.c")
CG_NAME = "ballbot_plant_cg"
CFLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-fPIC",
          "-fvisibility=hidden")
LDFLAGS = ("-shared", "-static-libgcc", "-Wl,--no-undefined", "-Wl,--as-needed")

_STATE_UNITS = ("m", "m", "1", "1", "1", "1", "m/s", "m/s", "1/s", "1/s", "1/s", "1/s")
_STATE_DESC = (
    "ball position x in the inertial frame",
    "ball position y in the inertial frame",
    "attitude quaternion q0 (scalar part) of body B in ball frame K",
    "attitude quaternion q1",
    "attitude quaternion q2",
    "attitude quaternion q3",
    "ball velocity x",
    "ball velocity y",
    "quaternion rate dq0",
    "quaternion rate dq1",
    "quaternion rate dq2",
    "quaternion rate dq3",
)
_OUTPUTS = (
    ("roll", "rad", "ZYX roll angle of the body"),
    ("pitch", "rad", "ZYX pitch angle of the body"),
    ("yaw", "rad", "ZYX yaw angle of the body"),
    ("dphi0", "rad/s", "wheel 0 motor-shaft speed (inverse kinematics B.47)"),
    ("dphi1", "rad/s", "wheel 1 motor-shaft speed (inverse kinematics B.47)"),
    ("dphi2", "rad/s", "wheel 2 motor-shaft speed (inverse kinematics B.47)"),
    ("acc_x", "m/s2", "accelerometer, specific force along body x at the IMU (ball centre)"),
    ("acc_y", "m/s2", "accelerometer, specific force along body y at the IMU (ball centre)"),
    ("acc_z", "m/s2", "accelerometer, specific force along body z at the IMU (ball centre)"),
    ("gyro_x", "rad/s", "gyroscope, body angular velocity about body x (B.16)"),
    ("gyro_y", "rad/s", "gyroscope, body angular velocity about body y (B.16)"),
    ("gyro_z", "rad/s", "gyroscope, body angular velocity about body z (B.16)"),
    ("enc0", "1/s", "wheel 0 encoder rate in ticks per second"),
    ("enc1", "1/s", "wheel 1 encoder rate in ticks per second"),
    ("enc2", "1/s", "wheel 2 encoder rate in ticks per second"),
)


def _rule(v: FmuVar) -> tuple[float, float, bool, bool, str]:
    """Range rule of a parameter variable, from :data:`~ballbot_casadi.core.params.PARAM_RULES`
    (the one definition): ``(lo, hi, lo_open, hi_open, text)``.  FMU values are SI and
    radians, so an angle's text also gives the range in radians."""
    lo, hi, lo_open, hi_open, text = PARAM_RULES[v.rule]
    if v.unit == "rad":
        text = (f"{text}; FMU values are radians: {lo:.6g} {'<' if lo_open else '<='} value "
                f"{'<' if hi_open else '<='} {hi:.6g}")
    return lo, hi, lo_open, hi_open, text


@dataclass(frozen=True)
class FmuVar:
    """One real FMU variable (the single source of VRs, start values and metadata).

    ``kind`` is ``state``, ``derivative``, ``input``, ``output`` or ``parameter``;
    ``rule`` (parameters only) is a key of the parameter rules of
    :data:`~ballbot_casadi.core.params.PARAM_INFO`.
    """

    name: str
    vr: int
    kind: str
    start: float | None
    unit: str | None
    description: str
    rule: str | None = None
    derivative_of: int | None = None  # vr of the state (derivatives only)


def plant_variables() -> list[FmuVar]:
    """The variable table of BallbotPlant, ordered by value reference (0, 1, 2, ...)."""

    x0 = make_state()
    params = load_params()
    rows: list[FmuVar] = []

    def add(**kw) -> None:
        rows.append(FmuVar(vr=len(rows), **kw))

    for i, name in enumerate(STATE_NAMES):
        add(name=name, kind="state", start=float(x0[i]), unit=_STATE_UNITS[i],
            description=_STATE_DESC[i])
    for i, name in enumerate(STATE_NAMES):
        add(name=f"der({name})", kind="derivative", start=None, unit=None,
            description=f"time derivative of {name}", derivative_of=i)
    for i, name in enumerate(INPUT_NAMES):
        add(name=name, kind="input", start=0.0, unit="N.m",
            description=f"wheel {i} torque (thesis wheel order), saturated at +-tau_max")
    for i in range(NU):
        add(name=f"tau_dist{i}", kind="input", start=0.0, unit="N.m",
            description=f"wheel {i} disturbance torque, added after the saturation")
    for name, unit, desc in _OUTPUTS:
        add(name=name, kind="output", start=None, unit=unit, description=desc)
    for name in PARAM_NAMES:
        unit, desc, rule = PARAM_INFO[name]
        add(name=name, kind="parameter", start=float(getattr(params, name)), unit=unit,
            description=desc, rule=rule)
    add(name="h_internal", kind="parameter", start=H_INTERNAL_DEFAULT, unit="s",
        description="internal RK4 step of fmi2DoStep (each communication step is split into "
        "ceil(h / h_internal) equal sub-steps)", rule="pos")
    return rows


def _first(rows: Sequence[FmuVar], kind: str) -> int:
    vrs = [v.vr for v in rows if v.kind == kind]
    if vrs != list(range(vrs[0], vrs[0] + len(vrs))):
        raise BuildError(f"variables of kind {kind!r} must have consecutive value references")
    return vrs[0]


def plant_functions() -> list[ca.Function]:
    """The CasADi Functions compiled into the FMU: ``bbp_ode``, ``bbp_rk4``, ``bbp_out``,
    ``bbp_dd`` (see ``fmu/plant_model.c``)."""

    f = make_model_functions()
    ode, jac = f["ode"], f["jac"]
    sens = make_sensors(ode)
    x, tau, p = ca.MX.sym("x", NX), ca.MX.sym("tau", NU), ca.MX.sym("p", NP)
    acc, gyro, enc = sens(x, tau, p)
    y = ca.vertcat(Q.to_rpy(x[2:6]), f["wheel_speeds"](x, p), acc, gyro, enc)
    out = ca.Function("bbp_out", [x, tau, p], [y], ["x", "tau", "p"], ["y"]).expand()
    A, B = jac(x, tau, p)
    J = ca.vertcat(ca.horzcat(A, B), ca.horzcat(ca.jacobian(y, x), ca.jacobian(y, tau)))
    dd = ca.Function("bbp_dd", [x, tau, p], [ca.densify(J)], ["x", "tau", "p"], ["J"]).expand()
    xs, taus, ps = ca.SX.sym("x", NX), ca.SX.sym("tau", NU), ca.SX.sym("p", NP)
    bbp_ode = ca.Function("bbp_ode", [xs, taus, ps], [ode(xs, taus, ps)], ["x", "tau", "p"],
                          ["xdot"])
    rk4 = make_rk4(bbp_ode)
    bbp_rk4 = ca.Function("bbp_rk4", rk4.mx_in(), rk4.call(rk4.mx_in()), rk4.name_in(),
                          rk4.name_out())
    return [bbp_ode, bbp_rk4, out, dd]


def _fmt(v: float) -> str:
    return repr(float(v))


def model_description_xml(rows: Sequence[FmuVar], guid: str, sources: Sequence[str]) -> str:
    """``modelDescription.xml`` (FMI 2.0, ME + CS) for the variable table."""
    units = sorted({v.unit for v in rows if v.unit})
    src = "".join(f'      <File name="{s}"/>\n' for s in sources)
    caps = ('canGetAndSetFMUstate="true" canSerializeFMUstate="true" '
            'providesDirectionalDerivative="true" canNotUseMemoryManagementFunctions="false"')
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<fmiModelDescription fmiVersion="2.0" modelName="BallbotPlant"',
        f'  guid="{guid}"',
        '  description="3D quaternion Euler-Lagrange ballbot plant (Roche and Borja, AAU 2020) '
        'generated with CasADi; wheel torques in, state, attitude, wheel speeds and noise-free '
        'IMU and encoder signals out"',
        '  generationTool="ballbot-casadi" numberOfEventIndicators="0">',
        f'  <ModelExchange modelIdentifier="{MODEL_IDENTIFIER}" {caps}>',
        "    <SourceFiles>",
        src.rstrip("\n"),
        "    </SourceFiles>",
        "  </ModelExchange>",
        f'  <CoSimulation modelIdentifier="{MODEL_IDENTIFIER}" {caps}',
        '    canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false"',
        '    maxOutputDerivativeOrder="0" canRunAsynchronuously="false">',
        "    <SourceFiles>",
        src.rstrip("\n"),
        "    </SourceFiles>",
        "  </CoSimulation>",
        "  <UnitDefinitions>",
        *[f'    <Unit name="{u}"/>' for u in units],
        "  </UnitDefinitions>",
        "  <LogCategories>",
        '    <Category name="logStatusError" description="errors (on by default)"/>',
        '    <Category name="logStatusWarning" description="warnings (on by default)"/>',
        '    <Category name="logCalls" description="trace of FMI calls (off by default)"/>',
        "  </LogCategories>",
        '  <DefaultExperiment startTime="0" stopTime="5" stepSize="0.005"/>',
        "  <ModelVariables>",
    ]
    for v in rows:
        out.append(f"    <!-- index {v.vr + 1} -->")
        attrs = f'name={quoteattr(v.name)} valueReference="{v.vr}"'
        desc = f" description={quoteattr(v.description)}"
        unit = f' unit="{v.unit}"' if v.unit else ""
        if v.kind == "state":
            head = f'{attrs} causality="output" variability="continuous" initial="exact"'
            real = f'<Real{unit} start="{_fmt(v.start)}"/>'
        elif v.kind == "derivative":
            head = f'{attrs} causality="local" variability="continuous" initial="calculated"'
            real = f'<Real derivative="{v.derivative_of + 1}"/>'
        elif v.kind == "input":
            head = f'{attrs} causality="input" variability="continuous"'
            real = f'<Real{unit} start="{_fmt(v.start)}"/>'
        elif v.kind == "output":
            head = f'{attrs} causality="output" variability="continuous" initial="calculated"'
            real = f"<Real{unit}/>"
        else:
            lo, hi, _, _, _ = _rule(v)
            mm = (f' min="{_fmt(lo)}"' if math.isfinite(lo) else "") + (
                f' max="{_fmt(hi)}"' if math.isfinite(hi) else "")
            head = f'{attrs} causality="parameter" variability="fixed" initial="exact"'
            real = f'<Real{unit}{mm} start="{_fmt(v.start)}"/>'
        out.append(f"    <ScalarVariable {head}{desc}>")
        out.append(f"      {real}")
        out.append("    </ScalarVariable>")
    out.append("  </ModelVariables>")
    out.append("  <ModelStructure>")
    out.append("    <Outputs>")
    out += [f'      <Unknown index="{v.vr + 1}"/>' for v in rows if v.kind in ("state", "output")]
    out.append("    </Outputs>")
    out.append("    <Derivatives>")
    out += [f'      <Unknown index="{v.vr + 1}"/>' for v in rows if v.kind == "derivative"]
    out.append("    </Derivatives>")
    out.append("    <InitialUnknowns>")
    out += [f'      <Unknown index="{v.vr + 1}"/>' for v in rows
            if v.kind in ("output", "derivative")]
    out.append("    </InitialUnknowns>")
    out.append("  </ModelStructure>")
    out.append("</fmiModelDescription>")
    return "\n".join(out) + "\n"


def _c_double(v: float) -> str:
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "-HUGE_VAL"
    return repr(float(v))


def _c_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def vars_header(rows: Sequence[FmuVar], guid: str,
                functions: Sequence[ca.Function]) -> tuple[str, str]:
    """C headers ``plant_vr.h`` (VRs, sizes, GUID, work sizes; for hosts too) and
    ``plant_vars.h`` (start values, kinds, names, parameter ranges)."""

    kinds = {"state": "FMU_KIND_STATE", "derivative": "FMU_KIND_DERIVATIVE",
             "input": "FMU_KIND_INPUT", "output": "FMU_KIND_OUTPUT",
             "parameter": "FMU_KIND_PARAMETER"}
    params = [v for v in rows if v.kind == "parameter"]
    ny = sum(v.kind == "output" for v in rows)
    h_int = next(v.vr for v in rows if v.name == "h_internal")
    sz = {k: max(getattr(f, f"sz_{k}")() for f in functions) for k in ("arg", "res", "iw", "w")}
    defs = [
        "/* plant_vr.h - GENERATED by ballbot_casadi/fmi/build.py from the variable table;",
        " * do not edit.  Value references and sizes of BallbotPlant (also for C hosts). */",
        "#ifndef PLANT_VR_H",
        "#define PLANT_VR_H",
        f'#define PLANT_MODEL_IDENTIFIER "{MODEL_IDENTIFIER}"',
        f'#define PLANT_GUID "{guid}"',
        f"#define PLANT_N_REALS {len(rows)}",
        f"#define PLANT_NX {NX}",
        f"#define PLANT_NU {NU}",
        f"#define PLANT_NY {ny}",
        f"#define PLANT_NP {NP}",
        f"#define PLANT_NJROW {NX + ny}",
        f"#define PLANT_NJCOL {NX + NU}",
        f"#define PLANT_VR_STATE0 {_first(rows, 'state')}",
        f"#define PLANT_VR_DER0 {_first(rows, 'derivative')}",
        f"#define PLANT_VR_INPUT0 {_first(rows, 'input')}",
        f"#define PLANT_VR_DIST0 {next(v.vr for v in rows if v.name == 'tau_dist0')}",
        f"#define PLANT_VR_OUTPUT0 {_first(rows, 'output')}",
        f"#define PLANT_VR_PARAM0 {_first(rows, 'parameter')}",
        f"#define PLANT_VR_H_INTERNAL {h_int}",
        f"#define PLANT_P_TAU_MAX {PARAM_NAMES.index('tau_max')}",
        f"#define PLANT_QUAT_TOL {QUAT_TOL!r}",
        f"#define PLANT_MAX_SUBSTEPS {float(MAX_SUBSTEPS)!r}",
        *[f"#define PLANT_SZ_{k.upper()} {max(int(v), 1)}" for k, v in sz.items()],
        "",
        "/* value references */",
        *[f"#define VR_{v.name.replace('(', '_').replace(')', '')} {v.vr}" for v in rows],
        "#endif /* PLANT_VR_H */",
    ]
    lines = [
        "/* plant_vars.h - GENERATED by ballbot_casadi/fmi/build.py from the variable table;",
        " * do not edit.  Included once, by plant_model.c. */",
        "#ifndef PLANT_VARS_H",
        "#define PLANT_VARS_H",
        "#include <math.h>",
        '#include "fmi2_common.h"',
        '#include "plant_vr.h"',
        "",
        "static const double plant_start[PLANT_N_REALS] = {",
        *[f"    {_c_double(v.start if v.start is not None else 0.0)}, /* {v.name} */" for v in rows],
        "};",
        "static const unsigned char plant_kind[PLANT_N_REALS] = {",
        *[f"    {kinds[v.kind]}, /* {v.name} */" for v in rows],
        "};",
        "static const char *const plant_names[PLANT_N_REALS] = {",
        *[f"    {_c_str(v.name)}," for v in rows],
        "};",
        "/* parameter ranges, indexed by vr - PLANT_VR_PARAM0 */",
        f"static const double plant_lo[{len(params)}] = {{"
        + ", ".join(_c_double(_rule(v)[0]) for v in params) + "};",
        f"static const double plant_hi[{len(params)}] = {{"
        + ", ".join(_c_double(_rule(v)[1]) for v in params) + "};",
        f"static const unsigned char plant_lo_open[{len(params)}] = {{"
        + ", ".join(str(int(_rule(v)[2])) for v in params) + "};",
        f"static const unsigned char plant_hi_open[{len(params)}] = {{"
        + ", ".join(str(int(_rule(v)[3])) for v in params) + "};",
        f"static const char *const plant_rule[{len(params)}] = {{"
        + ", ".join(_c_str(_rule(v)[4]) for v in params) + "};",
        "",
        "#endif /* PLANT_VARS_H */",
    ]
    return "\n".join(defs) + "\n", "\n".join(lines) + "\n"


def fmi_headers_dir() -> Path:
    """Directory of the FMI 2.0 headers shipped with fmpy (``fmpy/c-code``)."""

    d = Path(fmpy.__file__).resolve().parent / "c-code"
    if not (d / "fmi2Functions.h").is_file():
        raise BuildError(f"the FMI 2.0 headers are missing from the fmpy installation ({d})")
    return d


def fmu_source_dir() -> Path:
    """Directory of the hand-written FMU C sources.

    The installed package data ``ballbot_casadi.fmu_src`` if present, else ``fmu/`` of the
    source checkout.
    """
    try:
        d = Path(str(resources.files("ballbot_casadi.fmu_src")))
        if (d / "fmi2_common.c").is_file():
            return d
    except (ModuleNotFoundError, TypeError):
        pass
    d = Path(__file__).resolve().parents[2] / "fmu"
    if (d / "fmi2_common.c").is_file():
        return d
    raise BuildError("the FMU C sources (fmu/fmi2_common.c, ...) were not found; "
                     "reinstall the package or run from the source checkout")


@dataclass(frozen=True)
class FmuBuild:
    """Result of :func:`build_fmu`."""

    fmu: Path  #: the .fmu archive
    unzipped: Path  #: directory with the unpacked FMU (modelDescription.xml, binaries, sources)
    binary: Path  #: the shared library inside ``unzipped``
    guid: str
    digest: str
    status: str = field(default="cached", compare=False)  #: cached, built or rebuilt: <why>


def _write_zip(root: Path, target: Path) -> None:
    """Deterministic zip of ``root`` (sorted names, fixed timestamps and modes)."""
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(p for p in root.rglob("*") if p.is_file()):
            info = zipfile.ZipInfo(path.relative_to(root).as_posix(), (1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if path.suffix == ".so" else 0o644) << 16
            zf.writestr(info, path.read_bytes())
    os.replace(tmp, target)


def platform_dir() -> str:
    """FMI 2.0 platform directory name of this machine (e.g. ``linux64``)."""

    return fmpy.platform


def binary_member() -> str:
    """Archive path of the FMU binary, ``binaries/<platform>/BallbotPlant.so``."""
    return f"binaries/{platform_dir()}/{MODEL_IDENTIFIER}.so"


def validate_fmu_archive(path: str | Path, binary_sha256: str | None = None,
                         require_binary: bool = True) -> None:
    """Check an FMU archive before it is published or used.

    The zip must be readable with every member's CRC intact, hold
    ``modelDescription.xml`` and (``require_binary``) the BallbotPlant binary of this
    platform, and (when ``binary_sha256`` is given) the binary must have that SHA-256.

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
                raise BuildError(f"{path} is corrupt: member {bad} fails its CRC check")
            names = set(zf.namelist())
            need_all = ("modelDescription.xml", binary_member()) if require_binary else (
                "modelDescription.xml",)
            for need in need_all:
                if need not in names:
                    raise BuildError(f"{path} lacks {need}")
            if binary_sha256 is not None:
                got = hashlib.sha256(zf.read(binary_member())).hexdigest()
                if got != binary_sha256:
                    raise BuildError(f"{path}: {binary_member()} differs from the built binary "
                                     "(SHA-256 mismatch)")
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError, ValueError) as exc:
        raise BuildError(f"{path} is not a valid FMU archive ({exc})") from None


def _cache_files(cache: Path) -> list[str]:
    """Relative paths of every file of a cache folder except the manifest and tools."""
    return sorted(p.relative_to(cache).as_posix() for p in (cache / "unzipped").rglob("*")
                  if p.is_file()) + [f"{MODEL_IDENTIFIER}.fmu"]


def _verify_cache(cache: Path) -> str | None:
    """``None`` if the cached build in ``cache`` matches its manifest (and the archive is
    sound), else the reason it cannot be used."""
    problem = check_manifest(cache, [f"{MODEL_IDENTIFIER}.fmu", f"unzipped/{binary_member()}",
                                     "unzipped/modelDescription.xml"], MANIFEST)
    if problem is not None:
        return problem
    try:
        validate_fmu_archive(cache / f"{MODEL_IDENTIFIER}.fmu",
                             sha256_file(cache / "unzipped" / binary_member()))
    except BuildError as exc:
        return str(exc)
    return None


def _build_into(tmp: Path, xml: str, files: dict[str, str], c_sources: list[str],
                ccmd: list[str]) -> None:
    """Write, compile and zip one FMU into the empty folder ``tmp``; manifest last."""
    troot = tmp / "unzipped"
    (troot / "sources").mkdir(parents=True)
    (troot / "binaries" / platform_dir()).mkdir(parents=True)
    (troot / "modelDescription.xml").write_text(xml)
    for name, text in files.items():
        (troot / "sources" / name).write_text(text)
    cmd = [*ccmd, *CFLAGS, "-I", str(troot / "sources"), "-I", str(fmi_headers_dir()),
           *[str(troot / "sources" / s) for s in c_sources], *LDFLAGS, "-o",
           str(troot / binary_member()), "-lm"]
    run_tool(cmd, "compiling BallbotPlant")
    _write_zip(troot, tmp / f"{MODEL_IDENTIFIER}.fmu")
    write_manifest(tmp, _cache_files(tmp), MANIFEST)


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


def build_fmu(out: str | Path | None = None, cc: str | None = None) -> FmuBuild:
    """Generate, compile and zip ``BallbotPlant.fmu`` (cached by content hash, verified).

    The build lives in ``<out>/cache/<digest>/`` (the archive, the unpacked tree and a
    ``MANIFEST.json`` with the size and SHA-256 of every file).  Every call verifies the
    manifest and the archive (zip CRCs, binary hash) and rebuilds a damaged or partial
    cache: a new build is made in a private folder and renamed into place as a whole
    (the damaged folder is moved aside first), under a lock shared by concurrent
    builders.  The archive is then published as ``<out>/BallbotPlant.fmu`` (copied,
    checked, renamed into place) unless an identical file is already there.

    Parameters
    ----------
    out
        Directory that receives ``BallbotPlant.fmu`` (default ``<build>/fmu``).
    cc
        C compiler command, default ``$CC`` or ``gcc`` (``"ccache gcc"`` allowed).

    Returns
    -------
    FmuBuild
        Paths of the FMU, its unpacked tree and binary, the GUID, the cache digest and
        what was done (``status``).

    Raises
    ------
    BuildError
        Missing compiler, headers or sources, or a compile error.
    """
    out = Path(out) if out is not None else build_root() / "fmu"
    ccmd = compiler_command(cc)
    rows = plant_variables()
    funcs = plant_functions()
    cg_c, cg_h = generate_sources(CG_NAME, funcs)
    # Keep the CasADi entry points out of the dynamic symbol table (-fvisibility=hidden).
    cg_c = "#define CASADI_SYMBOL_EXPORT\n" + cg_c
    src_dir = fmu_source_dir()
    hand = {name: (src_dir / name).read_text() for name in HAND_SOURCES}
    c_sources = ["fmi2_common.c", "plant_model.c", f"{CG_NAME}.c"]
    # The GUID is a hash of everything that defines the binary's behaviour.
    probe_xml = model_description_xml(rows, "{GUID}", c_sources)
    probe_h = "".join(vars_header(rows, "{GUID}", funcs))
    seed = hashlib.sha256(
        "\0".join([probe_xml, probe_h, cg_c, cg_h, *hand.values()]).encode()).digest()
    guid = "{" + str(uuid.UUID(bytes=seed[:16])) + "}"
    xml = model_description_xml(rows, guid, c_sources)
    vr_h, vars_h = vars_header(rows, guid, funcs)
    files = {**hand, "plant_vr.h": vr_h, "plant_vars.h": vars_h, f"{CG_NAME}.c": cg_c, f"{CG_NAME}.h": cg_h}
    digest = hashlib.sha256(
        "\0".join([xml, *[f"{k}\n{v}" for k, v in sorted(files.items())], *ccmd, *CFLAGS,
                   *LDFLAGS, platform_dir()]).encode()
    ).hexdigest()[:16]
    cache_root = out / "cache"
    cache = cache_root / digest
    fmu_path = cache / f"{MODEL_IDENTIFIER}.fmu"
    unz = cache / "unzipped"
    binary = unz / binary_member()
    status = "cached"
    problem = _verify_cache(cache)
    if problem is not None:
        with build_lock(cache_root / f".{digest}.lock"):
            problem = _verify_cache(cache)  # another process may have built it meanwhile
            if problem is not None:
                status = f"rebuilt: {problem}" if cache.exists() else "built"
                tmp = Path(tempfile.mkdtemp(prefix=".build-", dir=cache_root))
                try:
                    _build_into(tmp, xml, files, c_sources, ccmd)
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
    return FmuBuild(final, unz, binary, guid, digest, status)


def build_tool(build: FmuBuild, name: str, cc: str | None = None) -> Path:
    """Compile the C host program ``fmu/<name>.c`` (``host`` or ``fuzz``) for ``build``.

    The program includes the generated ``plant_vr.h`` and the fmpy FMI headers and loads
    the FMU binary with ``dlopen`` at run time; it is cached (verified, see
    :func:`~ballbot_casadi.core.toolchain.cached_file`) next to the FMU build.
    """
    ccmd = compiler_command(cc)
    src = fmu_source_dir() / f"{name}.c"
    if not src.is_file():
        raise BuildError(f"no C host program {src}")
    text = src.read_text()
    tag = hashlib.sha256("\0".join([text, *ccmd, *CFLAGS]).encode()).hexdigest()[:12]
    exe = build.unzipped.parent / f"{name}-{tag}"

    def make(tmp: Path) -> None:
        run_tool([*ccmd, *CFLAGS, "-I", str(build.unzipped / "sources"), "-I",
                  str(fmi_headers_dir()), "-o", str(tmp), str(src), "-ldl", "-lm"],
                 f"compiling {name}.c")

    return cached_file(exe, make)
