"""Zero-copy C entry point for closed-loop missions: one C call runs a whole mission.

The CasADi mission Function (:func:`ballbot_casadi.sim.mission.make_mission`) is the
reference implementation; calling it from Python converts every input and output
element between numpy and ``casadi.DM`` (a large share of a long mission's wall time,
see ``make bench``).  This module generates a few lines of C glue,
``ballbot_mission_<ctrl>(n, in, out)``, that chains the *generated* chunk Function
``ballbot_cl_chunk_<ctrl>`` (``CHUNK`` periods) and the step Function
``ballbot_cl_step_<ctrl>`` for the remainder, reading and writing numpy buffers in
place.  A ``(N, m)`` C-ordered numpy array has the memory layout of CasADi's
column-major ``(m, N)`` matrix, so no transposes are needed.  The glue is compiled
against the static closed-loop library (and the archives of the libraries it links) and
cached next to it.
"""

from __future__ import annotations

import ctypes
import hashlib
from importlib import resources
from pathlib import Path
from typing import Sequence

import casadi as ca
import numpy as np

from ballbot_casadi.core.toolchain import CFLAGS, Library, cached_file, compiler_command, run_tool
from ballbot_casadi.errors import BuildError, ShapeError

__all__ = ["glue_source", "MissionDriver"]

#: C template of the entry points (``str.format`` fields; braces of the C code doubled).
_TEMPLATE_FILE = "mission_driver.c.in"

_ENTRY = """
static const long ROWS_IN_{ctrl}[{n_in}] = {{{rows_in}}};
static const long ROWS_OUT_{ctrl}[{n_out}] = {{{rows_out}}};

int ballbot_mission_{ctrl}(long n, const casadi_real *const *in, casadi_real *const *out) {{
  return run(ballbot_cl_chunk_{ctrl}, ballbot_cl_chunk_{ctrl}_work,
             ballbot_cl_step_{ctrl}, ballbot_cl_step_{ctrl}_work,
             ROWS_IN_{ctrl}, ROWS_OUT_{ctrl}, n, in, out);
}}
"""


def glue_source(header: str, steps: dict[str, ca.Function], chunk: int, seq_inputs: Sequence[int]) -> str:
    """C source of the mission entry points ``ballbot_mission_<ctrl>`` for ``steps``."""
    step = next(iter(steps.values()))
    for name, f in steps.items():
        if f.name() != f"ballbot_cl_step_{name}":
            raise BuildError(f"step Function {f.name()!r} is not named ballbot_cl_step_{name}")
        if (f.name_in(), f.name_out()) != (step.name_in(), step.name_out()):
            raise BuildError("all step Functions must have the same inputs and outputs (the "
                             "state size may differ: a balance controller with a state)")
    template = resources.files("ballbot_casadi.sim").joinpath(_TEMPLATE_FILE).read_text()
    return template.format(
        header=header,
        n_in=step.n_in(),
        n_out=step.n_out(),
        nxz=max(f.size1_in(0) for f in steps.values()),
        chunk=chunk,
        seq_in=", ".join("1" if i in seq_inputs else "0" for i in range(step.n_in())),
        entries="".join(
            _ENTRY.format(
                ctrl=c,
                n_in=f.n_in(),
                n_out=f.n_out(),
                rows_in=", ".join(str(f.size1_in(i)) for i in range(f.n_in())),
                rows_out=", ".join(str(f.size1_out(i)) for i in range(f.n_out())),
            )
            for c, f in steps.items()
        ),
    )


class MissionDriver:
    """ctypes front end of the compiled mission entry points.

    Parameters
    ----------
    lib
        The compiled closed-loop library (its static archive is linked in).
    steps
        ``{controller: step Function}`` whose chunk Functions the library exports.
    chunk, seq_inputs
        Chunk length and the indices of the per-period sequence inputs.
    """

    def __init__(self, lib: Library, steps: dict[str, ca.Function], chunk: int, seq_inputs: Sequence[int]):
        self._steps = dict(steps)
        self._seq = tuple(seq_inputs)
        src = glue_source(lib.header.name, self._steps, chunk, self._seq)
        ccmd = compiler_command()
        digest = hashlib.sha256("\0".join([src, lib.digest, *ccmd, *CFLAGS]).encode()).hexdigest()[:16]
        so = lib.shared.parent / f"lib{lib.name}_mission_{digest}.so"
        # verified before use (size + SHA-256 manifest) and rebuilt when damaged
        cached_file(so, lambda tmp: self._compile(src, lib, tmp, ccmd), key=digest)
        self._dll = ctypes.CDLL(str(so))
        self._entries = {}
        for name in self._steps:
            fn = getattr(self._dll, f"ballbot_mission_{name}")
            fn.restype = ctypes.c_int
            fn.argtypes = [ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p]
            self._entries[name] = fn

    @staticmethod
    def _compile(src: str, lib: Library, so: Path, ccmd: list[str]) -> None:
        c = so.with_suffix(".c")
        c.write_text(src)
        # a library that links others (a separately compiled MPC): their archives too
        bind = ["-Wl,-Bsymbolic"] if lib.links else []
        cmd = [*ccmd, *CFLAGS, "-shared", *bind, "-I", str(lib.header.parent), "-o", str(so),
               str(c), *map(str, lib.archives), "-lm"]
        run_tool(cmd, "compiling the mission driver")

    def run(self, controller: str, n: int, args: Sequence[np.ndarray]) -> list[np.ndarray]:
        """Run ``n`` periods; ``args`` in step-input order, sequences as (n, rows) arrays.

        Returns the step outputs stacked as (n, rows) arrays.
        """
        step = self._steps[controller]
        ins = []
        for i, a in enumerate(args):
            arr = np.ascontiguousarray(a, dtype=float)
            want = step.size1_in(i) * (n if i in self._seq else 1)
            if arr.size != want:
                raise ShapeError(f"mission input {step.name_in(i)}: {arr.size} values, expected {want}")
            ins.append(arr)
        outs = [np.empty((n, step.size1_out(j))) for j in range(step.n_out())]
        pin = (ctypes.c_void_p * len(ins))(*[a.ctypes.data for a in ins])
        pout = (ctypes.c_void_p * len(outs))(*[o.ctypes.data for o in outs])
        flag = self._entries[controller](n, pin, pout)
        if flag:
            raise BuildError(f"mission of {controller!r} failed in C (flag {flag})")
        return outs
