"""The C benchmarks check what they time: each prints the outputs of the call it timed
(on inputs that do not change between calls), and :func:`check_c_outputs` compares them
with the same Function evaluated by CasADi on the same inputs.  A benchmark that wired an
argument to the wrong buffer, or timed the wrong configuration, stops with
:class:`~ballbot_casadi.errors.BuildError` instead of reporting a time for it."""

from __future__ import annotations

import subprocess
from typing import Any, Sequence

import casadi as ca
import numpy as np

from ballbot_casadi.errors import BuildError

__all__ = ["C_RTOL", "check_c_outputs", "function_nonzeros", "run_program"]

#: Relative tolerance of generated C against CasADi's virtual machine (same operations;
#: the compiler may reorder a few): of each output's largest magnitude (at least 1).
C_RTOL = 1e-9


def run_program(what: str, cmd: Sequence[str]) -> str:
    """Run a benchmark program and return its standard output; a non-zero exit status is a
    :class:`BuildError` with the program's last lines of standard error."""
    run = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if run.returncode != 0:
        raise BuildError(f"{what} failed (exit {run.returncode}): {run.stderr[-2000:]}")
    return run.stdout


def function_nonzeros(f: ca.Function, *args: Any) -> list[np.ndarray]:
    """The nonzeros of every output of ``f`` on ``args`` (positional; the inputs after them
    zero, as the NULL arguments of a C call), the numbers a C benchmark prints."""
    full = [ca.DM(np.asarray(a, float)) for a in args]
    full += [ca.DM.zeros(f.sparsity_in(i)) for i in range(len(args), f.n_in())]
    return [np.asarray(o.nonzeros()) for o in f.call(full)]


def check_c_outputs(what: str, c_outputs: Sequence[Any], expected: Sequence[Any]) -> float:
    """Largest difference between the outputs a C benchmark printed and ``expected`` (the
    Function's outputs, each flattened column-major as CasADi stores them).

    Raises
    ------
    BuildError
        A count, size or value that differs beyond :data:`C_RTOL` (the message names the
        benchmark, the output and the difference).
    """
    if len(c_outputs) != len(expected):
        raise BuildError(f"{what}: the C benchmark printed {len(c_outputs)} outputs, "
                         f"the Function has {len(expected)}")
    worst = 0.0
    for i, (c, e) in enumerate(zip(c_outputs, expected)):
        c = np.asarray(c, float).ravel()
        e = np.ravel(np.asarray(e, float), order="F")
        if c.shape != e.shape:
            raise BuildError(f"{what}: output {i} has {c.size} numbers in C, {e.size} in the Function")
        if not np.all(np.isfinite(e)) or not np.array_equal(np.isfinite(c), np.isfinite(e)):
            raise BuildError(f"{what}: output {i} is not finite in C or in the Function")
        diff = float(np.max(np.abs(c - e))) if c.size else 0.0
        if diff > C_RTOL * max(1.0, float(np.max(np.abs(e))) if e.size else 1.0):
            raise BuildError(f"{what}: output {i} of the C benchmark differs from the Function "
                             f"by {diff:.3g} (the benchmark does not time what it claims)")
        worst = max(worst, diff)
    return worst
