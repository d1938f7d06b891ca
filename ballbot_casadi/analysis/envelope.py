"""Recovery envelopes by bisection: the largest disturbance a closed loop recovers from.

A *recovery predicate* ``recovers(a) -> bool`` runs a closed loop with a disturbance of
size ``a`` (an attitude push, a wheel-torque step) and says whether it was recovered
within the limits (e.g. the thesis §7.1 specifications).  Assuming the predicate is
monotone - recovered below a limit ``a*``, not above - :func:`largest_recovered` brackets
``a*`` by bisection to an absolute tolerance, and :func:`envelope` does so per push
direction (the polar envelope of a balance controller).  ``a*`` is reported as the
largest value *verified* recovered (the bracket's lower end), so the envelope is never
optimistic by more than rounding of the predicate itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

from ballbot_casadi.errors import ScenarioError

__all__ = ["EnvelopeResult", "largest_recovered", "envelope"]


@dataclass(frozen=True)
class EnvelopeResult:
    """Bisection result: ``value`` (largest size verified recovered), the final bracket
    ``[value, failed]`` (``failed = inf`` when even ``hi`` was recovered), the number of
    predicate evaluations and whether the limit was bracketed inside ``[lo, hi]``."""

    value: float
    failed: float
    n_evals: int
    bracketed: bool


def largest_recovered(recovers: Callable[[float], bool], lo: float, hi: float,
                      tol: float) -> EnvelopeResult:
    """Largest ``a`` in ``[lo, hi]`` with ``recovers(a)``, by bisection to ``tol``.

    Parameters
    ----------
    recovers
        Monotone predicate: True below the limit, False above.
    lo, hi
        Search interval, ``0 <= lo < hi``; ``recovers(lo)`` must hold.
    tol
        Absolute width of the final bracket (> 0).

    Raises
    ------
    ScenarioError
        Bad interval or tolerance, or ``recovers(lo)`` is False (nothing is recovered).
    """
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise ScenarioError(f"envelope search interval must satisfy 0 <= lo < hi, got [{lo}, {hi}]")
    if not (math.isfinite(tol) and tol > 0):
        raise ScenarioError(f"envelope tolerance must be a finite number > 0, got {tol}")
    if not recovers(lo):
        raise ScenarioError(f"not even the smallest disturbance {lo} is recovered; lower lo")
    if recovers(hi):
        return EnvelopeResult(float(hi), math.inf, 2, False)
    a, b, n = float(lo), float(hi), 2
    while b - a > tol:
        m = 0.5 * (a + b)
        n += 1
        if recovers(m):
            a = m
        else:
            b = m
    return EnvelopeResult(a, b, n, True)


def envelope(recovers: Callable[[Sequence[float], float], bool], directions: Sequence[Sequence[float]],
             lo: float, hi: float, tol: float) -> list[EnvelopeResult]:
    """:func:`largest_recovered` along each unit ``direction`` (``recovers(direction, a)``)."""
    return [largest_recovered(lambda a, d=d: recovers(d, a), lo, hi, tol) for d in directions]
