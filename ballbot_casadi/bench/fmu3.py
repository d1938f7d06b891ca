"""The FMI 3.0 plant beside CasADi's own FMU export of the same ODE (group ``fmu``).

CasADi's ``DaeBuilder.export_fmu`` writes an FMI 3.0 Model Exchange FMU of a DAE;
:func:`casadi_export_fmu` builds one of the model ODE (the 12 states, the wheel torques
as inputs, the model parameters as constants: declared as FMU parameters, CasADi 3.8's
export evaluated NaN derivatives) under ``<build>/bench/casadi_export`` (benchmark
only, never shipped).  :func:`bench_fmu3_vs_casadi` simulates both in fmpy with the same
solver (CVode, relative tolerance 1e-10, 1 s from a 0.05 rad roll, constant torques):

* ``fmu3_vs_casadi_export_ratio``: wall time of the package's FMI 3.0 plant divided by
  that of CasADi's export, with the plant's sensor sampling moved past the stop time
  (``Ts_sensor`` = 100 s), so both integrate the same ODE without events (best of three);
* ``fmu3_vs_casadi_export_ratio_sampled``: the same with the robot's 5 ms sensor
  sampling (a time event every 5 ms in the package's plant, each a CVode restart);
* ``fmu3_vs_casadi_export_state_diff``: the largest difference of the 12 states on the
  output grid (event-free runs); it comes from CVode's step sequence (the package's
  plant also integrates the three wheel angles), not from the model.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import casadi as ca
import fmpy
import numpy as np

from ballbot_casadi.bench.fmpy_timing import fmpy_best_time
from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.fmi.build import build_fmu
from ballbot_casadi.fmi.plant.plant import X0_PREFIX
from ballbot_casadi.model.dynamics import INPUT_NAMES, STATE_NAMES, make_model_functions
from ballbot_casadi.model.numeric import make_state

__all__ = ["CASADI_EXPORT_NAME", "casadi_export_fmu", "bench_fmu3_vs_casadi"]

#: Model identifier of CasADi's export.
CASADI_EXPORT_NAME = "BallbotCasadiExport"
_ROLL0 = 0.05
_TAU = (0.1, -0.05, 0.02)
_STOP = 1.0
_DT = 0.005
_RTOL = 1e-10


def casadi_export_fmu(out: Path | None = None, roll0: float = _ROLL0) -> Path:
    """CasADi's FMI 3.0 ME export of the model ODE (start state: a roll of ``roll0``)."""
    out = Path(out) if out is not None else build_root() / "bench" / "casadi_export"
    out.mkdir(parents=True, exist_ok=True)
    ode = make_model_functions()["ode"]
    dae = ca.DaeBuilder(CASADI_EXPORT_NAME)
    xs = [dae.add(n, "output", "continuous", {}) for n in STATE_NAMES]
    us = [dae.add(n, "input", "continuous", {}) for n in INPUT_NAMES]
    for n, v in zip(STATE_NAMES, make_state(roll=roll0)):
        dae.set_start(n, float(v))
    for n in INPUT_NAMES:
        dae.set_start(n, 0.0)
    rhs = ode(ca.vertcat(*xs), ca.vertcat(*us), ca.DM(load_params().to_vector()))
    for i, x in enumerate(xs):
        dae.eq(dae.der(x), rhs[i], {})
    headers = str(Path(fmpy.__file__).parent / "c-code")
    with contextlib.chdir(out):  # export_fmu writes into the current directory
        files = dae.export_fmu({"no_warning": True})
        files = dae.compile_fmu(files, {"include_dirs": [headers]})
        path = dae.pack_fmu(files, {})
    return out / path


def _time(fmu: Path, start_values: dict, reps: int = 3) -> tuple[float, np.ndarray]:
    best, res = fmpy_best_time(fmu, reps, fmi_type="ModelExchange", solver="CVode",
                               relative_tolerance=_RTOL, stop_time=_STOP, output_interval=_DT,
                               start_values=start_values, output=list(STATE_NAMES))
    # the values after the events (a time event repeats its time in the result)
    last = np.array([np.flatnonzero(res["time"] == t)[-1] for t in np.unique(res["time"])])
    return best, np.column_stack([res[n][last] for n in STATE_NAMES])


def bench_fmu3_vs_casadi() -> dict[str, float]:
    """The package's FMI 3.0 plant vs CasADi's export of the same ODE (module docstring)."""
    ours = build_fmu(fmi_version=3).fmu
    theirs = casadi_export_fmu()
    taus = {f"tau{i}": t for i, t in enumerate(_TAU)}
    x0 = {X0_PREFIX + n: float(v) for n, v in zip(STATE_NAMES, make_state(roll=_ROLL0))}
    t_ours, x_ours = _time(ours, {**taus, **x0, "Ts_sensor": 100.0})
    t_sampled, _ = _time(ours, {**taus, **x0})
    t_casadi, x_casadi = _time(theirs, taus)
    return {
        "fmu3_cvode_1s_s": t_ours,
        "fmu3_cvode_1s_sampled_s": t_sampled,
        "casadi_export_cvode_1s_s": t_casadi,
        "fmu3_vs_casadi_export_ratio": t_ours / t_casadi,
        "fmu3_vs_casadi_export_ratio_sampled": t_sampled / t_casadi,
        "fmu3_vs_casadi_export_state_diff": float(np.max(np.abs(x_ours - x_casadi))),
    }

