"""Pass/fail specifications ``metric op threshold``: operators, :class:`Spec`, evaluation.

The one home of specs: a scenario file's ``[[spec]]`` rows
(:mod:`ballbot_casadi.sim.scenario.file`), the study registry's cross-run specs and the
Monte Carlo statistics all use these.  A spec is a pure function of a run's metrics
(a mapping ``{metric: value}``), so it sits in ``core`` where every layer may use it.
Not in ``analysis`` (where the metrics are computed): the scenario-file reader in ``sim``
validates the ``[[spec]]`` rows (their operators) when it reads a file, and ``sim`` may
not import ``analysis``; nothing here depends on how a metric is computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

__all__ = ["SPEC_OPS", "DEFAULT_SPECS", "Spec", "spec_ok", "spec_usage", "evaluate_specs",
           "specs_or_default", "FALL_TILT_DEG", "run_failure"]

_SPEC_FUNCS: Mapping[str, Callable[[Any, Any], Any]] = {
    "<": lambda a, b: a < b,
    "<=": lambda a, b: a <= b,
    ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b,
    "==": lambda a, b: a == b,
    "abs<=": lambda a, b: abs(a) <= b,
}
#: Comparison operators of a spec.
SPEC_OPS = tuple(_SPEC_FUNCS)
#: The specs of a Monte Carlo set whose scenario file declares none: the run completed.
DEFAULT_SPECS: tuple[Mapping[str, Any], ...] = (
    {"metric": "finite", "op": "==", "threshold": True, "source": "run completed", "thesis": ""},)


def spec_ok(value: Any, op: str, threshold: Any) -> bool:
    """``value op threshold``; ``None``, NaN or an incomparable value fails."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return False
    try:
        return bool(_SPEC_FUNCS[op](value, threshold))
    except TypeError:
        return False


def spec_usage(value: Any, op: str, threshold: Any) -> float | None:
    """How much of a spec's allowance a value uses: 1 at the threshold, above 1 beyond it
    (``value / threshold`` for upper bounds, ``threshold / value`` for lower bounds);
    ``None`` for ``==`` specs, non-numeric values or a zero threshold."""
    num = (int, float)
    if (op == "==" or not isinstance(value, num) or isinstance(value, bool)
            or not isinstance(threshold, num) or isinstance(threshold, bool) or threshold == 0
            or not math.isfinite(value)):
        return None
    if op in ("<", "<="):
        return value / threshold
    if op == "abs<=":
        return abs(value) / abs(threshold)
    return threshold / value if value > 0 else math.inf


@dataclass(frozen=True)
class Spec:
    """One pass/fail criterion ``metric op threshold``, where the number comes from, and
    the thesis's own value (shown beside ours in reports)."""

    metric: str
    op: str
    threshold: Any
    source: str
    thesis: str = ""

    def ok(self, metrics: Mapping[str, Any]) -> bool:
        """Whether ``metrics`` meet the criterion (a missing metric fails)."""
        return spec_ok(metrics.get(self.metric), self.op, self.threshold)

    def evaluate(self, metrics: Mapping[str, Any]) -> dict[str, Any]:
        """The criterion's row: ``metric, value, op, threshold, ok, source, thesis``."""
        val = metrics.get(self.metric)
        return {"metric": self.metric, "value": val, "op": self.op, "threshold": self.threshold,
                "ok": spec_ok(val, self.op, self.threshold), "source": self.source,
                "thesis": self.thesis}

    @classmethod
    def from_row(cls, row: Mapping[str, Any]) -> "Spec":
        """From a scenario file's ``[[spec]]`` row."""
        return cls(row["metric"], row["op"], row["threshold"], row.get("source", ""), row.get("thesis", ""))


def evaluate_specs(specs: Sequence[Spec], metrics: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Evaluate ``specs`` on ``metrics``: one row per criterion (see :meth:`Spec.evaluate`)."""
    return [s.evaluate(metrics) for s in specs]


def specs_or_default(specs: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """``specs`` as dicts, or :data:`DEFAULT_SPECS` when there are none."""
    return [dict(s) for s in (specs or DEFAULT_SPECS)]


#: Peak tilt (deg) at which a run counts as a fall whatever its specs say: the body is
#: horizontal, lying on the floor.
FALL_TILT_DEG = 90.0


def run_failure(metrics: Mapping[str, Any]) -> str | None:
    """Why a run failed whatever its specs say, or ``None``: its state or torques became
    NaN or Inf (metric ``finite``), or the robot fell (``peak_tilt_deg`` at or beyond
    :data:`FALL_TILT_DEG`, or not a finite number)."""
    if metrics.get("finite") is False:
        return "the state or the torques became NaN or Inf"
    tilt = metrics.get("peak_tilt_deg")
    if isinstance(tilt, (int, float)) and not isinstance(tilt, bool):
        if not math.isfinite(tilt):
            return f"peak tilt is {tilt!r}"
        if tilt >= FALL_TILT_DEG:
            return f"the robot fell: peak tilt {tilt:.4g} deg >= {FALL_TILT_DEG:g} deg"
    return None
