"""The libcosim master: an SSP archive run by libcosim's fixed-step (Jacobi) algorithm.

``CosimExecution.from_ssp_file`` loads the archive; the start values libcosim skips
(those of states, which the SSP binds but libcosim applies only to parameters and inputs)
are applied as initial values; a time-series observer records the requested variables at
every communication point.  libcosim reads an input after the step that used it, so the
sample of an input is shifted by one step (row ``k`` the value held on ``[t_k, t_k+1)``).
``libcosimpy`` is an optional dependency (the ``fmi-extra`` extra), imported on use.
"""

from __future__ import annotations

from ctypes import c_double, c_int, c_int64, c_size_t, c_uint32
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ballbot_casadi.errors import BuildError, CosimError
from ballbot_casadi.fmi.system.ssp import SspSystem

__all__ = ["run_libcosim"]


def run_libcosim(ssp: Path, system: SspSystem, n: int, step: float, variables: Mapping[str, Any],
                 rec: Sequence[tuple[str, str]]) -> dict[str, np.ndarray]:
    """Run ``ssp`` (read as ``system``) for ``n`` steps of ``step`` s; the ``rec``
    ``(component, variable)`` samples as ``{"<component>.<variable>": (n + 1,) array}``
    (``variables``: ``{component: {name: fmpy ScalarVariable}}``)."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(ssp))
    index = {c: ex.slave_index_from_instance_name(c) for c in system.components}
    # values the SSP binds but libcosim skips (start values of states): initial values
    for comp, params in system.parameters.items():
        for name, value in params.items():
            v = variables[comp][name]
            if v.causality in ("parameter", "input"):
                continue
            if v.type != "Real":
                raise BuildError(f"{comp}.{name}: cannot apply a {v.type} start value")
            if not ex.real_initial_value(index[comp], v.valueReference, float(value)):
                raise CosimError(f"libcosim refused the initial value of {comp}.{name}")
    obs = CosimObserver.create_time_series(buffer_size=n + 1)
    last = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ex.add_observer(last)
    kinds = {"Real": CosimVariableType.REAL, "Integer": CosimVariableType.INTEGER}
    for comp, name in rec:
        v = variables[comp][name]
        if v.type in kinds:
            obs.start_time_series(index[comp], v.valueReference, kinds[v.type])
    if not ex.simulate_until(int(round(n * step * 1e9))):
        raise CosimError(f"libcosim stopped before t = {n * step:g} s (see the FMUs' log above)")
    out = {}
    for comp, name in rec:
        v = variables[comp][name]
        if v.type not in kinds:  # the time-series observer records Reals and Integers only
            out[f"{comp}.{name}"] = np.full(n + 1, float(last.last_boolean_values(
                index[comp], [v.valueReference])[0]))
            continue
        x = _samples(obs, index[comp], v, n)
        # libcosim reads an input after the step that used it: sample k + 1 is the value
        # the FMU held on [t_k, t_k+1)
        out[f"{comp}.{name}"] = np.append(x[1:], np.nan) if v.causality == "input" else x
    return out


def _samples(obs: Any, slave: int, var: Any, n: int) -> np.ndarray:
    """The n + 1 samples (steps 0 .. n) of a variable from a time series observer."""
    from libcosimpy._internal import libcosimc

    real = var.type == "Real"
    fn = (libcosimc().cosim_observer_slave_get_real_samples if real
          else libcosimc().cosim_observer_slave_get_integer_samples)
    vals = ((c_double if real else c_int) * (n + 1))()
    steps, times = (c_int64 * (n + 1))(), (c_int64 * (n + 1))()
    fn.restype = c_int64
    ptr = obs.ptr()
    fn.argtypes = [type(ptr), c_int, c_uint32, c_int64, c_size_t, type(vals), type(steps),
                   type(times)]
    got = fn(ptr, slave, var.valueReference, 0, n + 1, vals, steps, times)
    if got != n + 1 or list(steps) != list(range(n + 1)):
        raise CosimError(f"libcosim returned {got} samples of {var.name} (steps {steps[0]} .. "
                         f"{steps[max(got - 1, 0)]}), expected steps 0 .. {n}")
    return np.array(vals[:], dtype=float)
