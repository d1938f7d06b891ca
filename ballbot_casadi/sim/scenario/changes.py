"""Parameter changes ``{name: [op, value]}`` (op ``set``, ``scale`` or ``add``): one type for all.

A scenario deviates from the nominal robot through such changes (thesis §8.4): the plant's
parameters (``[plant]``), the controller's internal model (``[controller_model]``), the
estimators' internal model (``[estimator_model]``) and the sensors (``[sensors]``, whose
vector parameters take a list with ``set``).  :class:`ParamChanges` is the only place that
parses, validates and applies them; a bad change raises a
:class:`~ballbot_casadi.errors.ScenarioError` whose ``key`` is ``"<section>.<name>"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.core.params import PARAM_NAMES, Params, load_params
from ballbot_casadi.core.sensor_params import SENSOR_PARAM_INFO, SENSOR_PARAM_NAMES, load_sensor_params
from ballbot_casadi.errors import BallbotError, ScenarioError

__all__ = ["CHANGE_OPS", "ParamChanges", "apply_changes"]

#: Operations of a parameter change: the new value, a factor, or an increment.
CHANGE_OPS = ("set", "scale", "add")


def _new_value(op: str, current: Any, value: Any) -> Any:
    return value if op == "set" else current * value if op == "scale" else current + value


@dataclass(frozen=True)
class ParamChanges:
    """Changes to one parameter set.

    Attributes
    ----------
    section
        Where the changes come from (``"plant"``, ``"controller_model"``, ``"sensors"``,
        ...): the prefix of the ``key`` of every error.
    sensors
        The changes apply to :class:`~ballbot_casadi.core.sensor_params.SensorParams`
        (vector values allowed) instead of the model's
        :class:`~ballbot_casadi.core.params.Params`.
    """

    section: str
    sensors: bool = False

    @property
    def names(self) -> tuple[str, ...]:
        """The parameter names a change may target."""
        return SENSOR_PARAM_NAMES if self.sensors else PARAM_NAMES

    def fail(self, name: str | None, reason: str) -> ScenarioError:
        """A :class:`ScenarioError` keyed ``section.name`` (or ``section``)."""
        key = f"{self.section}.{name}" if name else self.section
        return ScenarioError(f"{self.section}: {reason}", key=key)

    def _checked(self, name: str, change: Any, current: Any) -> tuple[str, Any]:
        """``(op, value)`` of one change, validated (value broadcast to ``current``'s shape)."""
        if name not in self.names:
            kind = "sensor parameter" if self.sensors else "parameter"
            raise self.fail(name, f"unknown {kind} {name!r}; allowed: {', '.join(self.names)}")
        try:
            op, value = change
            value = (np.broadcast_to(np.asarray(value, float), np.shape(current)) if self.sensors
                     else float(value))
        except (TypeError, ValueError):
            what = f"number or list of {np.size(current)}" if self.sensors else "number"
            raise self.fail(name, f"change of {name!r} must be [op, {what}] with op in {CHANGE_OPS}, "
                                  f"got {change!r}") from None
        if op not in CHANGE_OPS or not np.all(np.isfinite(value)):
            raise self.fail(name, f"change of {name!r} must be [op, finite number] with op in "
                                  f"{CHANGE_OPS}, got {change!r}")
        return op, value

    def apply(self, base: Any, changes: Mapping[str, Any]) -> Any:
        """``base`` (``Params`` or ``SensorParams``) with ``changes`` applied, validated.

        A change that makes the parameter set invalid (a negative mass, ...) is reported
        under the first changed name that is invalid on its own, else the section.
        """
        values = base.as_dict()
        new: dict[str, Any] = {}
        for name, change in changes.items():
            op, value = self._checked(name, change, values.get(name, 0.0))
            if self.sensors:
                current = np.asarray(values[name], float)
                new[name] = [float(v) for v in np.ravel(_new_value(op, current, value))]
            else:
                new[name] = _new_value(op, values[name], value)
        if not new:
            return base
        try:
            return base.replace(**new)
        except BallbotError as exc:
            bad = next((n for n, v in new.items() if not _valid_alone(base, n, v)), None)
            raise ScenarioError(f"{self.section}: {exc}", key=f"{self.section}.{bad}" if bad
                                else self.section) from None

    def check(self, changes: Mapping[str, Any]) -> None:
        """Validate ``changes`` against the nominal parameters (raises :class:`ScenarioError`)."""
        self.apply(load_sensor_params() if self.sensors else load_params(), changes)

    def parse(self, table: Any) -> dict[str, list]:
        """Changes from a scenario file's table: ``name = v`` (= set), ``name = { op = v }``
        or, for sensors, ``name = [a, b, c]`` (= set); validated.  Returns ``{name: [op, v]}``."""
        if not isinstance(table, Mapping):
            raise ScenarioError(f"{self.section}: expected a table, got {type(table).__name__}",
                                key=self.section)
        out: dict[str, list] = {}
        for name, v in table.items():
            if name not in self.names:
                raise ScenarioError(f"unknown key; allowed here: {', '.join(self.names)}",
                                    key=f"{self.section}.{name}")
            plain = (isinstance(v, (int, float)) and not isinstance(v, bool)) or (
                self.sensors and isinstance(v, (list, tuple)))
            if plain:
                op, val = "set", v
            elif isinstance(v, Mapping) and len(v) == 1 and next(iter(v)) in CHANGE_OPS:
                op, val = next(iter(v.items()))
            else:
                forms = "a list, a number" if self.sensors else "a number"
                raise ScenarioError(f"expected {forms} or one of {{ set = v }}, {{ scale = f }}, "
                                    f"{{ add = d }}, got {v!r}", key=f"{self.section}.{name}")
            n = len(SENSOR_PARAM_INFO[name][3]) if self.sensors else None
            out[name] = [op, _file_number(val, f"{self.section}.{name}.{op}", n)]
        self.check(out)
        return out

    def rebased(self, changes: Mapping[str, Any], new: Mapping[str, float],
                nominal: Mapping[str, float]) -> dict[str, list]:
        """Changes on another robot: every parameter where ``new`` differs from ``nominal``
        becomes a ``set``; ``changes`` then apply on top of the new robot's values."""
        out = {k: ["set", v] for k, v in new.items() if v != nominal[k]}
        for k, (op, v) in changes.items():
            out[k] = ["set", _new_value(op, new[k], v)]
        return out


def _valid_alone(base: Any, name: str, value: Any) -> bool:
    try:
        base.replace(**{name: value})
    except BallbotError:
        return False
    return True


def _file_number(v: Any, key: str, n: int | None) -> Any:
    """A finite number (or, with ``n``, a list of ``n`` finite numbers) from a file."""
    if isinstance(v, (list, tuple)) and n is not None:
        if any(not isinstance(e, (int, float)) or isinstance(e, bool) for e in v):
            raise ScenarioError(f"expected an array of numbers, got {v!r}", key=key)
        if len(v) != n:
            raise ScenarioError(f"expected {n} numbers, got {len(v)}", key=key)
        if not all(math.isfinite(e) for e in v):
            raise ScenarioError("numbers must be finite", key=key)
        return [float(e) for e in v]
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        raise ScenarioError(f"expected a number, got {v!r} ({type(v).__name__})", key=key)
    if not math.isfinite(v):
        raise ScenarioError(f"must be finite, got {v!r}", key=key)
    return float(v)


def apply_changes(base: Params, changes: Mapping[str, Any], what: str) -> Params:
    """Apply ``{name: [op, value]}`` changes (op ``set``, ``scale`` or ``add``) to ``base``."""
    return ParamChanges(what).apply(base, changes)
