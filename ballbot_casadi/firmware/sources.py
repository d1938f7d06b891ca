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
from ballbot_casadi.firmware.toolchain import PRECISIONS
from ballbot_casadi.sim.embedded import (
    embedded_readings,
    embedded_software,
    initial_controller_state,
    software_layout,
)
from ballbot_casadi.sim.scenario import Scenario

__all__ = [
    "REFERENCE_INPUTS",
    "COVARIANCE_INPUTS",
    "HAND_WRITTEN",
    "CG_NAME",
    "firmware_function",
    "param_inputs",
    "FirmwareValues",
    "scenario_values",
    "generate_sources",
    "csrc_path",
]

#: Inputs of the period that are references (ballbot_fw_references), in its order.
REFERENCE_INPUTS = ("q_ref", "dq_ref", "ddq_ref", "v_ref")
#: Inputs that are not parameters: state, readings, references, mode.
_NOT_PARAMS = ("c", "meas", *REFERENCE_INPUTS, "cascade")
#: Parameter inputs that are covariance matrices (column-major, diagonal >= 0).
COVARIANCE_INPUTS = ("Qa", "Ra", "Qv", "Rv")
#: Hand-written C files of the library (package data, csrc/).
HAND_WRITTEN = ("ballbot_fw.h", "ballbot_fw.c")
#: Base name of the generated CasADi C file.
CG_NAME = "ballbot_fw_cg"
_FLOAT_MATH = ("sqrt", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "exp", "log", "pow",
               "fabs", "fmin", "fmax", "floor", "ceil", "tanh", "sinh", "cosh", "fmod", "erf")


def csrc_path(name: str) -> Path:
    """Path of a C file shipped with the package (``ballbot_casadi/firmware/csrc``)."""
    return Path(str(resources.files("ballbot_casadi.firmware") / "csrc" / name))


def firmware_function(controller: str = "flc", estimator: str = "ukf") -> ca.Function:
    """The period ``ballbot_embedded_<controller>_<estimator>`` the compiled mission exports.

    Raises
    ------
    ScenarioError
        Unknown controller or estimator (the message lists the allowed ones).
    """
    if estimator in ("true",) or not isinstance(estimator, str):
        raise ScenarioError(f"the firmware needs an estimator ('ukf' or 'ekf'), got {estimator!r}")
    return embedded_software(controller, estimator)


def param_inputs(f: ca.Function) -> list[str]:
    """The parameter inputs of the period (``ballbot_fw_params`` fields), in its order."""
    return [n for n in f.name_in() if n not in _NOT_PARAMS]


@dataclass(frozen=True)
class FirmwareValues:
    """Parameter values (input name -> flat array, column-major) and power-on state ``c0``."""

    params: Mapping[str, np.ndarray]
    c0: np.ndarray

    def flat_params(self, f: ca.Function) -> np.ndarray:
        """The parameters as ``ballbot_fw_params`` lays them out (fields in the Function's order)."""
        return np.concatenate([np.asarray(self.params[n], float).ravel(order="F")
                               for n in param_inputs(f)])


def scenario_values(f: ca.Function, scenario: Scenario) -> FirmwareValues:
    """The period's parameters and power-on state for ``scenario``, as the compiled mission
    starts it (velocity controller, filters aligned with the initial state, COM observer).

    Raises
    ------
    ScenarioError
        The scenario has no estimator in the loop.
    BuildError
        A value's size differs from the Function's input.
    """
    if scenario.estimator == "true":
        raise ScenarioError(f"scenario {scenario.name!r}: the firmware needs an estimator "
                            "(estimator = 'ukf' or 'ekf')")
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
    # the state at power-on: the Function the compiled mission and the controller FMU use
    layout = software_layout(f, scenario.estimator)
    observer = "obs" in layout.fields
    n_bal = layout.size_of("bal") if "bal" in layout.fields else 0
    c0 = initial_controller_state(scenario.estimator, inp["x0"], inp["p_ctrl"], observer, n_bal)
    if c0.size != f.size1_in(0):
        raise BuildError(f"{f.name()}: state of {f.size1_in(0)} entries, the scenario gives {c0.size}")
    return FirmwareValues(params, c0)


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


def _codegen(f: ca.Function, real: str) -> tuple[str, str]:
    opts = {"with_header": True, "casadi_real": real, "casadi_int": "int", "with_export": False,
            "verbose": False}
    cg = ca.CodeGenerator(f"{CG_NAME}.c", opts)
    cg.add(f)
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


def _config_header(f: ca.Function, real: str) -> str:
    params = param_inputs(f)
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
        f"#define BALLBOT_FW_SZ_ARG {f.sz_arg()}",
        f"#define BALLBOT_FW_SZ_RES {f.sz_res()}",
        f"#define BALLBOT_FW_SZ_IW {f.sz_iw()}",
        f"#define BALLBOT_FW_SZ_W {f.sz_w()}",
        *(f"#define BALLBOT_FW_ARG_{n} {i}" for i, n in enumerate(f.name_in())),
        *(f"#define BALLBOT_FW_RES_{n} {i}" for i, n in enumerate(f.name_out())),
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
        f"extern const ballbot_fw_real ballbot_fw_default_c0[{f.numel_in(0)}];", "",
        "#endif", "",
    ]
    return "\n".join(lines)


def _c_array(v: np.ndarray) -> str:
    return "{" + ", ".join(repr(float(x)) for x in np.asarray(v, float).ravel()) + "}"


def _defaults_source(f: ca.Function, values: FirmwareValues) -> str:
    fields = ",\n    ".join(_c_array(values.params[n]) for n in param_inputs(f))
    return "\n".join([
        "/* ballbot_fw_defaults.c - generated default parameters and power-on state; do not edit. */",
        '#include "ballbot_fw_config.h"', "",
        f"const ballbot_fw_params ballbot_fw_default_params_data = {{\n    {fields}\n}};", "",
        f"const ballbot_fw_real ballbot_fw_default_c0[{f.numel_in(0)}] = {_c_array(values.c0)};", "",
    ])


def generate_sources(f: ca.Function, precision: str, values: FirmwareValues) -> dict[str, str]:
    """Every C file of the library: file name -> text (deterministic).

    Raises
    ------
    ScenarioError
        Unknown precision (the message lists the allowed ones).
    """
    if precision not in PRECISIONS:
        raise ScenarioError(f"unknown precision {precision!r}; allowed: {', '.join(PRECISIONS)}")
    real = PRECISIONS[precision]
    c_src, h_src = _codegen(f, real)
    files = {f"{CG_NAME}.c": c_src, f"{CG_NAME}.h": h_src,
             "ballbot_fw_config.h": _config_header(f, real),
             "ballbot_fw_defaults.c": _defaults_source(f, values)}
    for name in HAND_WRITTEN:
        files[name] = csrc_path(name).read_text()
    return files
