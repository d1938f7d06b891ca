"""A closed-loop mission: the step Function chained over ``N`` control periods.

The mission over ``N`` periods is ``step.mapaccum(N)`` (:func:`make_mission`; CasADi
nests it in log-depth folds): one call runs a whole mission.  A compiled library holds
the step and a chunk of :data:`CHUNK` periods (:func:`make_chunk`, the step's
``mapaccum`` in C); a mission of any length chains compiled chunks and runs the
remainder through the compiled step's ``mapaccum``, composed into one Function
(:func:`compose_mission`), so missions run as a single call without regenerating C.

Sequence inputs (:func:`~ballbot_casadi.sim.ports.sequence_positions`) are ``(size, N)``
matrices, one column per period; the state and the constants are single columns.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.ports import sequence_positions

__all__ = ["CHUNK", "make_mission", "make_chunk", "compose_mission"]

#: Control periods per compiled chunk (1 s at 200 Hz).
CHUNK = 200


def make_mission(step: ca.Function, n_periods: int) -> ca.Function:
    """The closed loop over ``n_periods`` control periods as one Function (``mapaccum``).

    Sequence inputs are ``(size, n_periods)`` matrices (one column per period);
    constants (parameters, gains, ``Ts``, ``cascade``) may be single columns.
    """
    if not isinstance(n_periods, (int, np.integer)) or n_periods < 1:
        raise ScenarioError(f"number of control periods must be an int >= 1, got {n_periods!r}")
    name = step.name().replace("ballbot_cl_step_", "ballbot_mission_")
    return step.mapaccum(name, int(n_periods))


def make_chunk(step: ca.Function, n_periods: int = CHUNK) -> ca.Function:
    """``n_periods`` steps as one Function whose first output is the *last* ``xz``.

    ``ballbot_cl_chunk_<ctrl>(xz, sequences..., constants...) -> (xz_last, xz_next,
    x, tau_cmd, tau, q_ref_used, dq_ref_used, ddq_ref_used, diag)``: the shape of the
    accumulated input equals that of the first output, so chunks chain with
    ``mapaccum`` themselves (see :meth:`ClosedLoop.mission`).
    """
    inner = make_mission(step, n_periods)
    seq = sequence_positions(step)
    # constants (parameters, gains, Ts, cascade) are single columns, broadcast inside
    args = [ca.MX.sym(inner.name_in(i), inner.size1_in(i), n_periods if i in seq else 1)
            for i in range(inner.n_in())]
    args[0] = ca.MX.sym(inner.name_in(0), inner.sparsity_in(0))
    outs = inner(*[a if i == 0 or i in seq else ca.repmat(a, 1, n_periods)
                   for i, a in enumerate(args)])
    return ca.Function(
        step.name().replace("ballbot_cl_step_", "ballbot_cl_chunk_"),
        args,
        [outs[0][:, -1], *outs],
        inner.name_in(),
        ["xz_last", *inner.name_out()],
    )


def compose_mission(step: ca.Function, chunk: ca.Function, n_chunk: int, n_periods: int) -> ca.Function:
    """Mission of ``n_periods``: a chain of ``chunk`` calls + ``step.mapaccum`` for the rest.

    Same inputs and outputs as ``make_mission(step, n_periods)``.  The chunks are chained
    by explicit calls (one call node per chunk, each running ``n_chunk`` periods in
    compiled C); building ``chunk.mapaccum`` instead is two orders of magnitude slower to
    construct (seconds for a 100 s mission) and no faster to run.
    """
    if not isinstance(n_periods, (int, np.integer)) or n_periods < 1:
        raise ScenarioError(f"number of control periods must be an int >= 1, got {n_periods!r}")
    n_c, rem = divmod(int(n_periods), n_chunk)
    seq = sequence_positions(step)
    args = [ca.MX.sym(step.name_in(i), step.size1_in(i), n_periods if i in seq else 1)
            for i in range(step.n_in())]
    parts: list[list[ca.MX]] = []
    xz = args[0]
    for c in range(n_c):
        cols = slice(c * n_chunk, (c + 1) * n_chunk)
        a = [xz] + [args[i][:, cols] if i in seq else args[i] for i in range(1, len(args))]
        outs = chunk(*a)
        xz = outs[0]
        parts.append(list(outs[1:]))
    if rem:
        start = n_c * n_chunk
        a = [xz] + [args[i][:, start:] if i in seq else args[i] for i in range(1, len(args))]
        parts.append(list(step.mapaccum(f"{step.name()}_x{rem}", rem)(*a)))
    outs = [ca.horzcat(*[p[j] for p in parts]) for j in range(step.n_out())]
    name = step.name().replace("ballbot_cl_step_", "ballbot_mission_")
    return ca.Function(name, args, outs, step.name_in(), step.name_out())
