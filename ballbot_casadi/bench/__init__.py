"""Benchmarks (``make bench``): generated-C timings of the model, written to JSON.

Timing goals live here, never in tests.  Targets (issue 2): generated ODE <= 0.5 us
per call, (A, B) <= 3 us per call.
"""

from __future__ import annotations

import json
import os
import time
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Callable, Mapping

import numpy as np

from ballbot_casadi.bench.control import bench_control
from ballbot_casadi.bench.estimation import bench_estimation
from ballbot_casadi.bench.firmware import bench_firmware, bench_firmware_mpc, bench_firmware_split
from ballbot_casadi.bench.fmu import bench_fmu
from ballbot_casadi.bench.guidance import bench_mpc
from ballbot_casadi.bench.montecarlo import bench_montecarlo
from ballbot_casadi.bench.verify import check_c_outputs, function_nonzeros, run_program
from ballbot_casadi.codegen.libraries import model_functions_list, model_library
from ballbot_casadi.core.files import atomic_write_text
from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.toolchain import CFLAGS, build_root, compiler_command, run_tool
from ballbot_casadi.errors import BallbotError
from ballbot_casadi.model.dynamics import make_ode

__all__ = ["bench_model", "run_benchmarks", "BENCHMARKS", "BenchmarkError"]


class BenchmarkError(BallbotError, ValueError):
    """An unknown benchmark group was requested."""


#: The model benchmark's operating point: the default robot slightly tilted, moving and
#: turning, with torques on every wheel (C and Python calls alike).
BENCH_STATE = (0.1, -0.2, 0.99904822, 0.0348995, 0.0261769, 0.0, 0.1, 0.05, 0.0, 0.01, -0.02, 0.03)
BENCH_TAU = (0.2, -0.1, 0.3)


def _python_call_ns(n: int = 20000) -> float:
    """ns per call of the symbolic ODE Function called from Python with numpy arrays."""

    ode = make_ode()
    x, tau, p = np.array(BENCH_STATE), np.array(BENCH_TAU), load_params().to_vector()
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter_ns()
        for _ in range(n):
            ode(x, tau, p)
        best = min(best, (time.perf_counter_ns() - t0) / n)
    return best


def bench_model(n_calls: int = 200000) -> dict[str, float]:
    """Compile and run the C micro-benchmark of the model library.

    Returns ``ode_ns``, ``jac_ns`` (ns per call of the generated C), ``python_call_ns``
    (same ODE as a CasADi Function called from Python) and ``python_over_c_ratio``.
    """
    lib = model_library()
    out = build_root() / "bench"
    out.mkdir(parents=True, exist_ok=True)
    src = Path(str(resources.files("ballbot_casadi.bench") / "csrc" / "bench_model.c"))
    exe = out / "bench_model"
    tmp = out / f".bench_model.{os.getpid()}.tmp"
    run_tool([*compiler_command(), *CFLAGS, "-I", str(lib.header.parent), "-o", str(tmp),
              str(src), str(lib.static), "-lm"], "compiling the model benchmark")
    os.replace(tmp, exe)  # a concurrent run keeps the executable it started
    p = load_params().to_vector()
    args = [repr(float(v)) for v in (*BENCH_STATE, *BENCH_TAU, *p)]
    data = json.loads(run_program("the model benchmark", [exe, n_calls, *args]))
    data.pop("sink", None)
    fns = {f.name(): f for f in model_functions_list()}
    for key, name in (("check_ode", "ballbot_ode"), ("check_jac", "ballbot_jac")):
        got = data.pop(key)
        check_c_outputs(f"model benchmark ({name})", got,
                        function_nonzeros(fns[name], BENCH_STATE, BENCH_TAU, p))
    data["python_call_ns"] = _python_call_ns()
    data["python_over_c_ratio"] = data["python_call_ns"] / data["ode_ns"]
    data["ode_target_ns"] = 500.0
    data["jac_target_ns"] = 3000.0
    return data


#: Benchmark groups run by ``ballbot bench``: name -> callable returning a flat dict.
BENCHMARKS: Mapping[str, Callable[[], dict[str, float]]] = MappingProxyType({
    "model": bench_model,
    "fmu": bench_fmu,
    "control": bench_control,
    "estimation": bench_estimation,
    "montecarlo": bench_montecarlo,
    "firmware": bench_firmware,
    "firmware_mpc": bench_firmware_mpc,
    "firmware_split": bench_firmware_split,
    "mpc": bench_mpc,
})


def run_benchmarks(path: Path, only: list[str] | None = None) -> dict[str, float]:
    """Run the benchmark groups and merge their results into the JSON file ``path``.

    Raises
    ------
    BenchmarkError
        ``only`` names a group that does not exist (nothing is run).
    """
    unknown = [n for n in only or () if n not in BENCHMARKS]
    if unknown:
        raise BenchmarkError(f"unknown benchmark group(s) {', '.join(map(repr, unknown))}; "
                             f"valid groups: {', '.join(BENCHMARKS)}")
    results: dict[str, float] = {}
    if path.is_file():
        try:
            results.update(json.loads(path.read_text()))
        except ValueError:
            pass  # a damaged earlier file is replaced by this run's results
    for name, fn in BENCHMARKS.items():
        if only and name not in only:
            continue
        results.update(fn())
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(results, indent=2, sort_keys=True) + "\n")
    return results
