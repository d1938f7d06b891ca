"""The C sources of the firmware library: the generated period and its API configuration.

The period is ``ballbot_embedded_<ctrl>_<est>``, taken from the Functions the compiled
mission runs (:func:`~ballbot_casadi.sim.embedded.embedded_software`, as the
controller FMU takes it).  Its inputs split into the state ``c``, the readings ``meas``
(:data:`~ballbot_casadi.sim.embedded.MEAS`, or ``MEAS_HEADING`` for ``ukf_heading``:
:func:`~ballbot_casadi.sim.embedded.embedded_readings`), the references (:data:`REFERENCE_INPUTS`),
the mode ``cascade`` and the parameters (every other input, in the Function's order:
``ballbot_fw_params``, settable at run time).  ``ballbot_fw_config.h`` is generated from the
Function (sizes, argument positions, X-macro field lists), so the API follows the
Function without hand-counted offsets; ``ballbot_fw_defaults.c`` holds the default
parameters and power-on state of a scenario (constants, in flash).

Single precision: CasADi's C with ``casadi_real = float``; the math calls are switched
to their float versions (``sqrtf``, ``sinf``, ...) and the build adds
``-fsingle-precision-constant -Wdouble-promotion -Werror``, so no double arithmetic
remains (the single-precision FPU has none).  The model's numerical guards ``DBL_MAX`` and
``1e-300`` (floors before divisions and square roots) are clamped to ``FLT_MAX`` and
``FLT_MIN`` (the smallest normal float), which keeps their meaning in float.

Guidance (issue 18): ``firmware_function(..., guidance="mpc")`` is the same period with
the path-following block of the guided mission in its guidance slot
(:func:`~ballbot_casadi.sim.embedded.embedded_software` with the block of
:func:`firmware_guidance`: the MPC's real-time iteration every
``BALLBOT_FW_GUIDANCE_EVERY`` periods, 10 Hz inside the 200 Hz step).  Its data ``k_guid``
(path table and obstacles, :func:`~ballbot_casadi.guidance.path_table.pack_path`) is
not a parameter: the caller hands a pointer to it (``ballbot_fw_set_guidance``; it can
stay in flash), and ``ballbot_fw_defaults.c`` holds a default path
(:func:`default_guidance_path`) as a constant table.  The block's state ``guide`` is part
of ``c`` (:func:`~ballbot_casadi.sim.embedded.software_layout`); its start depends on the
path (the robot's projection onto it, :func:`scenario_values` with ``path``).

Split guidance (issue 18, ``latency >= 1``): the period's block is the guided mission's
with that latency in its interrupt-step form (:func:`~ballbot_casadi.sim.guided.make_guidance`
with ``split``: no sample, a snapshot), and the sample Function is generated beside it
for the background task ``ballbot_fw_guidance_background`` (``csrc/ballbot_fw.h``) as its
two branches (:data:`~ballbot_casadi.guidance.blocks.MPC_SAMPLE_BRANCHES`: the warm sample
and the cold first, ``BALLBOT_FW_GUIDANCE_SAMPLE_NEXT`` / ``_FIRST``), which the C picks by
the snapshot's ``first`` as the sample's ``Function.conditional`` does: the same arithmetic,
but the work is the larger branch's own generated C's instead of the conditional's (which
sizes it from CasADi's virtual-machine counts: 40,285 against 11,810 doubles with the
default MPC).  ``ballbot_fw_config.h`` carries the offsets of the guidance state the C
reads and writes (the counter, the sample state and its ``first``, ``due``, ``snap``) and
the work sizes of the period and of the branches.
"""

from __future__ import annotations

import os
import re
import tempfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.firmware.toolchain import PRECISIONS
from ballbot_casadi.guidance.blocks import MPC_SAMPLE_BRANCHES
from ballbot_casadi.guidance.paths import Path as GuidancePath, figure_eight
from ballbot_casadi.sim.embedded import (
    DEFAULT_ESTIMATOR,
    ESTIMATOR_FILTERS,
    embedded_readings,
    embedded_software,
    initial_controller_state,
    software_layout,
)
from ballbot_casadi.sim.guided import GUIDANCE_EVERY, GUIDANCE_LAWS, GuidanceLaw, scenario_law
from ballbot_casadi.sim.ports import GUIDANCE_CONSTANTS
from ballbot_casadi.sim.period import require_finite_controller_limit
from ballbot_casadi.sim.scenario import Scenario

__all__ = [
    "REFERENCE_INPUTS",
    "COVARIANCE_INPUTS",
    "HAND_WRITTEN",
    "CG_NAME",
    "GUIDANCE_INPUT",
    "SPLIT_LATENCY",
    "firmware_guidance",
    "guidance_every",
    "default_guidance_path",
    "firmware_function",
    "background_functions",
    "param_inputs",
    "FirmwareValues",
    "scenario_values",
    "generate_sources",
    "codegen_work",
    "generated_work",
    "csrc_path",
]

#: Inputs of the period that are references (ballbot_fw_references), in its order.
REFERENCE_INPUTS = ("q_ref", "dq_ref", "ddq_ref", "v_ref")
#: The guidance block's data (path table and obstacles): a pointer given at init, not a parameter.
GUIDANCE_INPUT = GUIDANCE_CONSTANTS[0]
#: Inputs that are not parameters: state, readings, references, mode, guidance data.
_NOT_PARAMS = ("c", "meas", *REFERENCE_INPUTS, "cascade", GUIDANCE_INPUT)
#: Parameter inputs that are covariance matrices (column-major, diagonal >= 0).
COVARIANCE_INPUTS = ("Qa", "Ra", "Qv", "Rv")
#: Latency (periods) of the split build's guidance sample (issue 18): the smallest whose
#: sample fits :data:`~ballbot_casadi.firmware.cost.SPLIT_MARGIN` times into the time the
#: interrupt steps leave free until its due period at 480 MHz and 1 IPC
#: (:func:`~ballbot_casadi.firmware.cost.min_latency`; the measured figures and the
#: arithmetic: README, firmware; ``make bench --only firmware_split`` reports it again).
SPLIT_LATENCY = 5
#: Hand-written C files of the library (package data, csrc/).
HAND_WRITTEN = ("ballbot_fw.h", "ballbot_fw.c")
#: Base name of the generated CasADi C file.
CG_NAME = "ballbot_fw_cg"
_FLOAT_MATH = ("sqrt", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "exp", "log", "pow",
               "fabs", "fmin", "fmax", "floor", "ceil", "tanh", "sinh", "cosh", "fmod", "erf")


def csrc_path(name: str) -> Path:
    """Path of a C file shipped with the package (``ballbot_casadi/firmware/csrc``)."""
    return Path(str(resources.files("ballbot_casadi.firmware") / "csrc" / name))


def firmware_guidance(guidance: str | None, controller: str = "flc",
                      latency: int = 0) -> GuidanceLaw | None:
    """The guidance block of the firmware: the guided mission's law (``mpc``: the MPC
    predicting the default velocity loop, as :func:`~ballbot_casadi.sim.guided.scenario_law`
    builds it for a path scenario; ``pursuit``), or ``None``; ``latency >= 1``: the MPC
    with that latency, split into the interrupt step's block and a background sample.

    Raises
    ------
    ScenarioError
        Unknown law, or a controller other than the FLC cascade (the one path following runs).
    """
    if guidance is None:
        return None
    if guidance not in GUIDANCE_LAWS:
        raise ScenarioError(f"unknown guidance {guidance!r}; allowed: {', '.join(GUIDANCE_LAWS)} "
                            "(or none)")
    if controller != "flc":
        raise ScenarioError(f"the firmware's guidance runs above the FLC cascade (controller "
                            f"'flc'), got controller {controller!r}")
    if not (isinstance(latency, int) and latency >= 0):
        raise ScenarioError(f"guidance latency must be an int >= 0 periods, got {latency!r}")
    return scenario_law(Scenario(name="firmware_guidance", controller="flc", cascade=True,
                                 duration=TS_CONTROL, guidance=guidance), latency, latency > 0)


def guidance_every(law: GuidanceLaw) -> int:
    """Control periods per guidance sample of ``law`` (20: 10 Hz at 200 Hz)."""
    return int(round(law.config.dt / TS_CONTROL)) if law.config is not None else GUIDANCE_EVERY


def default_guidance_path() -> GuidancePath:
    """The path compiled into the library as its default guidance data: the figure-eight
    4 m x 2 m at 0.5 m/s of the path study, starting where the default robot stands."""
    return figure_eight(4.0, 2.0, speed=0.5)


def firmware_function(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR,
                      guidance: str | None = None, latency: int = 0) -> ca.Function:
    """The period ``ballbot_embedded_<controller>_<estimator>`` the compiled mission exports
    (with ``guidance``: the one the guided mission with that estimator runs; ``latency >=
    1``: its interrupt step, the sample split off, :func:`firmware_guidance`).

    Raises
    ------
    ScenarioError
        Unknown controller, estimator or guidance (the message lists the allowed ones).
    """
    if estimator in ("true",) or not isinstance(estimator, str):
        raise ScenarioError(f"the firmware needs an estimator (one of "
                            f"{', '.join(ESTIMATOR_FILTERS)}), got {estimator!r}")
    law = firmware_guidance(guidance, controller, latency)
    return embedded_software(controller, estimator, guidance=None if law is None else law.function)


def background_functions(law: GuidanceLaw) -> tuple[ca.Function, ca.Function]:
    """The split build's background Functions: the MPC sample's branches (warm, first:
    :data:`~ballbot_casadi.guidance.blocks.MPC_SAMPLE_BRANCHES`), each ``(X, g, k) -> (v,
    g_next)``.

    Raises
    ------
    ScenarioError
        ``law`` is not the MPC (only its sample runs in the background).
    """
    if law.sample is None or law.name != "mpc":
        raise ScenarioError(f"the background task runs the MPC's sample, not {law.name!r}'s")
    return tuple(law.sample.find_function(n) for n in MPC_SAMPLE_BRANCHES)  # type: ignore[return-value]


def param_inputs(f: ca.Function) -> list[str]:
    """The parameter inputs of the period (``ballbot_fw_params`` fields), in its order."""
    return [n for n in f.name_in() if n not in _NOT_PARAMS]


@dataclass(frozen=True)
class FirmwareValues:
    """Parameter values (input name -> flat array, column-major), power-on state ``c0``
    and, with a guidance block, its data ``guidance`` (``k_guid``: path table, obstacles)."""

    params: Mapping[str, np.ndarray]
    c0: np.ndarray
    guidance: np.ndarray | None = None

    def flat_params(self, f: ca.Function) -> np.ndarray:
        """The parameters as ``ballbot_fw_params`` lays them out (fields in the Function's order)."""
        return np.concatenate([np.asarray(self.params[n], float).ravel(order="F")
                               for n in param_inputs(f)])


def scenario_values(f: ca.Function, scenario: Scenario, law: GuidanceLaw | None = None,
                    path: GuidancePath | None = None) -> FirmwareValues:
    """The period's parameters and power-on state for ``scenario``, as the compiled mission
    starts it (velocity controller, filters aligned with the initial state, COM observer;
    with a guidance block ``law`` on ``path``: its data and start state, as
    :func:`~ballbot_casadi.sim.guided.run_guided` starts it).

    Raises
    ------
    ScenarioError
        The scenario has no estimator in the loop; a guided period without ``law`` and ``path``;
        the per-wheel torque limit (the firmware's controller limit is a finite constant).
    BuildError
        A value's size differs from the Function's input.
    """
    if scenario.estimator == "true":
        raise ScenarioError(f"scenario {scenario.name!r}: the firmware needs an estimator "
                            f"(estimator = one of {', '.join(ESTIMATOR_FILTERS)})")
    require_finite_controller_limit(scenario.torque_limit, scenario.name, "the firmware")
    inp = scenario.inputs()
    est = inp["estimation"]
    vals: dict[str, Any] = {"p_ctrl": inp["p_ctrl"], "p_est": est["p_est"], "k_bal": inp["k_bal"],
                            "k_vel": inp["k_vel"], "Ts": inp["Ts"],
                            "feedforward": 1.0 if inp["feedforward"] else 0.0,
                            **{k: est[k] for k in COVARIANCE_INPUTS},
                            "com_observer": 1.0 if inp["com_observer"] else 0.0,
                            "k_obs": inp["k_obs"]}
    params = {}
    for n in param_inputs(f):
        v = np.asarray(vals[n], float).ravel(order="F")
        if v.size != f.size1_in(f.index_in(n)) * f.size2_in(f.index_in(n)):
            raise BuildError(f"{f.name()}: input {n} has {f.numel_in(f.index_in(n))} entries, "
                             f"the scenario gives {v.size}")
        params[n] = v
    guided = GUIDANCE_INPUT in f.name_in()
    if guided and (law is None or path is None):
        raise ScenarioError(f"{f.name()} has a guidance block: give its law and the path")
    # the state at power-on: the Function the compiled mission and the controller FMU use
    n_guide = law.block_size if guided else 0  # the period counter first
    layout = software_layout(f, scenario.estimator, n_guide)
    observer = "obs" in layout.fields
    n_bal = layout.size_of("bal") if "bal" in layout.fields else 0
    c0 = initial_controller_state(scenario.estimator, inp["x0"], inp["p_ctrl"], observer, n_bal)
    data = None
    if guided:
        g0 = law.initial_state(path, inp["x0"], c0[layout["z"]])
        data = law.parameters(path)
        c0 = np.concatenate([c0[:layout.offset("guide")], g0, c0[layout.offset("guide"):]])
        if data.size != f.numel_in(f.index_in(GUIDANCE_INPUT)):
            raise BuildError(f"{f.name()}: guidance data of {f.numel_in(f.index_in(GUIDANCE_INPUT))} "
                             f"entries, the law gives {data.size}")
    if c0.size != f.size1_in(0):
        raise BuildError(f"{f.name()}: state of {f.size1_in(0)} entries, the scenario gives {c0.size}")
    return FirmwareValues(params, c0, data)


def _float_constant(m: re.Match) -> str:
    """A double literal outside float's normal range clamped into it (the model's guards
    ``DBL_MAX`` and ``1e-300`` become ``FLT_MAX`` and ``FLT_MIN``)."""
    v = float(m.group(0))
    big, tiny = float(np.finfo(np.float32).max), float(np.finfo(np.float32).tiny)
    if abs(v) > big:
        return repr(float(np.copysign(big, v)))
    if 0.0 < abs(v) < tiny:
        return repr(float(np.copysign(tiny, v)))
    return m.group(0)


def _float_math(src: str) -> str:
    """Float versions of the math calls (``sqrt(`` -> ``sqrtf(``) and of the out-of-range
    constants (:func:`_float_constant`)."""
    src = re.sub(r"(?<![\w.])(" + "|".join(_FLOAT_MATH) + r")\(", r"\1f(", src)
    return re.sub(r"(?<![\w.])\d\.\d+e[+-]\d+", _float_constant, src)


def _strict(src: str) -> str:
    """Mark the generated entry points' unused parameters as used (``-Wextra -Werror``)."""
    src = re.sub(r"(static int casadi_f\d+\(const casadi_real\*\* arg, casadi_real\*\* res, "
                 r"casadi_int\* iw, casadi_real\* w, int mem\) \{\n)",
                 r"\1  (void)arg; (void)res; (void)iw; (void)w; (void)mem;\n", src)
    return re.sub(r"(void \w+_(?:release|incref|decref)\(int mem\) \{\n)", r"\1  (void)mem;\n", src)


def _codegen(f: ca.Function, real: str, extra: tuple[ca.Function, ...] = ()) -> tuple[str, str]:
    opts = {"with_header": True, "casadi_real": real, "casadi_int": "int", "with_export": False,
            "verbose": False}
    cg = ca.CodeGenerator(f"{CG_NAME}.c", opts)
    cg.add(f)
    for e in extra:
        cg.add(e)
    with tempfile.TemporaryDirectory() as tmp:
        cg.generate(tmp + os.sep)
        c_src = Path(tmp, f"{CG_NAME}.c").read_text()
        h_src = Path(tmp, f"{CG_NAME}.h").read_text()
    c_src = _strict(c_src)
    if real == "float":
        c_src = _float_math(c_src)
    return c_src, h_src


def _fields(f: ca.Function, names: list[str] | tuple[str, ...], out: bool = False) -> str:
    numel = f.numel_out if out else f.numel_in
    index = f.index_out if out else f.index_in
    return " ".join(f"X({n}, {numel(index(n))})" for n in names)


def codegen_work(f: ca.Function, c_src: str) -> tuple[int, int, int, int]:
    """``(sz_arg, sz_res, sz_iw, sz_w)`` the generated C of ``f`` declares in its
    ``<name>_work`` function: what the C needs, which can be less than the Function's
    own ``sz_w()`` (the generated code reads inputs and constants in place where
    CasADi's virtual machine copies them: 67,408 against 77,373 doubles with the MPC).

    Raises
    ------
    BuildError
        The generated C has no such function.
    """
    m = re.search(rf"int {re.escape(f.name())}_work\([^)]*\) {{\n"
                  r"  if \(sz_arg\) \*sz_arg = (\d+);\n  if \(sz_res\) \*sz_res = (\d+);\n"
                  r"  if \(sz_iw\) \*sz_iw = (\d+);\n  if \(sz_w\) \*sz_w = (\d+);", c_src)
    if m is None:
        raise BuildError(f"the generated C of {f.name()} declares no work sizes ({f.name()}_work)")
    return tuple(int(v) for v in m.groups())  # type: ignore[return-value]


def generated_work(f: ca.Function, precision: str = "double") -> tuple[int, int, int, int]:
    """:func:`codegen_work` of ``f`` generated alone as the firmware generates it."""
    return codegen_work(f, _codegen(f, PRECISIONS[precision])[0])


def _split_lines(f: ca.Function, law: GuidanceLaw | None, estimator: str, c_src: str) -> list[str]:
    """The config lines of the split guidance (``BALLBOT_FW_GUIDANCE_SPLIT``)."""
    if law is None or not law.split:
        return ["#define BALLBOT_FW_GUIDANCE_SPLIT 0"]
    branches = background_functions(law)
    sz = np.max([codegen_work(b, c_src) for b in branches], axis=0)
    off = software_layout(f, estimator, law.block_size).offset("guide")
    tail = 1 + law.state.size  # the tail's offsets inside the block's state
    return [
        "/* Split guidance: the sample runs in the background (ballbot_fw_guidance_background);",
        "   offsets in c of the block's state and, inside it, of due and snap. */",
        "#define BALLBOT_FW_GUIDANCE_SPLIT 1",
        f"#define BALLBOT_FW_GUIDANCE_SAMPLE_NEXT {branches[0].name()}",
        f"#define BALLBOT_FW_GUIDANCE_SAMPLE_FIRST {branches[1].name()}",
        f"#define BALLBOT_FW_GUIDE_FIRST {law.state.offset('first')}",
        f"#define BALLBOT_FW_GUIDANCE_LATENCY {law.latency}",
        f"#define BALLBOT_FW_GUIDANCE_FIRST_LATENCY {law.first_latency}",
        f"#define BALLBOT_FW_GUIDE_OFFSET {off}",
        f"#define BALLBOT_FW_GUIDE_NS {law.state.size}",
        f"#define BALLBOT_FW_GUIDE_NV {branches[0].numel_out(0)}",
        f"#define BALLBOT_FW_GUIDE_DUE {tail + law.tail.offset('due')}",
        f"#define BALLBOT_FW_GUIDE_SNAP {tail + law.tail.offset('snap')}",
        f"#define BALLBOT_FW_GUIDE_NSNAP {law.tail.size_of('snap')}",
        *(f"#define BALLBOT_FW_BG_SZ_{n} {v}" for n, v in zip(("ARG", "RES", "IW", "W"), sz)),
    ]


def _config_header(f: ca.Function, real: str, every: int, c_src: str,
                   law: GuidanceLaw | None = None, estimator: str = DEFAULT_ESTIMATOR) -> str:
    params = param_inputs(f)
    sz_arg, sz_res, sz_iw, sz_w = codegen_work(f, c_src)
    n_guid = f.numel_in(f.index_in(GUIDANCE_INPUT)) if GUIDANCE_INPUT in f.name_in() else 0
    outputs = [n for n in f.name_out() if n != "c_next"]
    cov = [f"X({n}, {int(round(np.sqrt(f.numel_in(f.index_in(n)))))})" for n in COVARIANCE_INPUTS
           if n in params]
    M = embedded_readings(f)  # MEAS, or MEAS_HEADING with the heading reading last
    lines = [
        f"/* ballbot_fw_config.h - generated from {f.name()} ({real}); do not edit. */",
        "#ifndef BALLBOT_FW_CONFIG_H", "#define BALLBOT_FW_CONFIG_H", "",
        f'#include "{CG_NAME}.h"', "",
        f"typedef {real} ballbot_fw_real;",
        f"#define BALLBOT_FW_PRECISION_{'DOUBLE' if real == 'double' else 'SINGLE'} 1",
        f"#define BALLBOT_FW_EMBEDDED {f.name()}",
        f"#define BALLBOT_FW_NC {f.numel_in(0)}",
        f"#define BALLBOT_FW_N_READINGS {M.size}",
        *(f"#define BALLBOT_FW_READING_{k.upper()} {M[k].start}" for k in M.fields),
        f"#define BALLBOT_FW_N_ENC {M['enc'].stop - M['enc'].start}",
        "/* Work sizes of the generated C (its _work function). */",
        f"#define BALLBOT_FW_SZ_ARG {sz_arg}",
        f"#define BALLBOT_FW_SZ_RES {sz_res}",
        f"#define BALLBOT_FW_SZ_IW {sz_iw}",
        f"#define BALLBOT_FW_SZ_W {sz_w}",
        *(f"#define BALLBOT_FW_ARG_{n} {i}" for i, n in enumerate(f.name_in())),
        *(f"#define BALLBOT_FW_RES_{n} {i}" for i, n in enumerate(f.name_out())),
        "/* The guidance block: 1 with one (its data: BALLBOT_FW_N_GUIDANCE values, a sample",
        "   every BALLBOT_FW_GUIDANCE_EVERY periods), 0 without. */",
        f"#define BALLBOT_FW_GUIDANCE {1 if n_guid else 0}",
        f"#define BALLBOT_FW_N_GUIDANCE {n_guid}",
        f"#define BALLBOT_FW_GUIDANCE_EVERY {every if n_guid else 0}",
        *_split_lines(f, law, estimator, c_src),
        f"#define BALLBOT_FW_PARAM_FIELDS(X) {_fields(f, params)}",
        f"#define BALLBOT_FW_REFERENCE_FIELDS(X) {_fields(f, REFERENCE_INPUTS)}",
        f"#define BALLBOT_FW_OUTPUT_FIELDS(X) {_fields(f, outputs, out=True)}",
        f"#define BALLBOT_FW_COV_FIELDS(X) {' '.join(cov)}", "",
        "/* Parameters (the period's inputs in its order; matrices column-major). */",
        "typedef struct ballbot_fw_params {",
        *(f"    ballbot_fw_real {n}[{f.numel_in(f.index_in(n))}];" for n in params),
        "} ballbot_fw_params;", "",
        "/* Outputs of the last period (the period's outputs but the next state). */",
        "typedef struct ballbot_fw_outputs {",
        *(f"    ballbot_fw_real {n}[{f.numel_out(f.index_out(n))}];" for n in outputs),
        "} ballbot_fw_outputs;", "",
        "extern const ballbot_fw_params ballbot_fw_default_params_data;",
        f"extern const ballbot_fw_real ballbot_fw_default_c0[{f.numel_in(0)}];",
        *((f"extern const ballbot_fw_real ballbot_fw_default_guidance_data[{n_guid}];",)
          if n_guid else ()), "",
        "#endif", "",
    ]
    return "\n".join(lines)


def _c_array(v: np.ndarray) -> str:
    return "{" + ", ".join(repr(float(x)) for x in np.asarray(v, float).ravel()) + "}"


def _defaults_source(f: ca.Function, values: FirmwareValues) -> str:
    fields = ",\n    ".join(_c_array(values.params[n]) for n in param_inputs(f))
    guidance = []
    if GUIDANCE_INPUT in f.name_in():
        if values.guidance is None or values.guidance.size != f.numel_in(f.index_in(GUIDANCE_INPUT)):
            raise BuildError(f"{f.name()}: the default values have no guidance data of "
                             f"{f.numel_in(f.index_in(GUIDANCE_INPUT))} entries")
        guidance = [f"const ballbot_fw_real ballbot_fw_default_guidance_data"
                    f"[{values.guidance.size}] = {_c_array(values.guidance)};", ""]
    return "\n".join([
        "/* ballbot_fw_defaults.c - generated default parameters and power-on state; do not edit. */",
        '#include "ballbot_fw_config.h"', "",
        f"const ballbot_fw_params ballbot_fw_default_params_data = {{\n    {fields}\n}};", "",
        f"const ballbot_fw_real ballbot_fw_default_c0[{f.numel_in(0)}] = {_c_array(values.c0)};", "",
        *guidance,
    ])


def generate_sources(f: ca.Function, precision: str, values: FirmwareValues,
                     guidance_every: int = 0, law: GuidanceLaw | None = None,
                     estimator: str = DEFAULT_ESTIMATOR) -> dict[str, str]:
    """Every C file of the library: file name -> text (deterministic); ``guidance_every``:
    periods per sample of the period's guidance block (if it has one); ``law``: the
    guidance law of the block (needed when it is split: its sample is generated too, for
    the background task), ``estimator``: the period's (the state layout).

    Raises
    ------
    ScenarioError
        Unknown precision (the message lists the allowed ones).
    """
    if precision not in PRECISIONS:
        raise ScenarioError(f"unknown precision {precision!r}; allowed: {', '.join(PRECISIONS)}")
    real = PRECISIONS[precision]
    split = law is not None and law.split
    c_src, h_src = _codegen(f, real, background_functions(law) if split else ())
    files = {f"{CG_NAME}.c": c_src, f"{CG_NAME}.h": h_src,
             "ballbot_fw_config.h": _config_header(f, real, guidance_every, c_src, law, estimator),
             "ballbot_fw_defaults.c": _defaults_source(f, values)}
    for name in HAND_WRITTEN:
        files[name] = csrc_path(name).read_text()
    return files
