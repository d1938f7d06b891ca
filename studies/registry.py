"""The registry of studies: each study's scenarios, metrics and specs, defined in one place.

A :class:`Study` is what ``ballbot study <name>`` runs: the scenario(s) for a balance
controller, the metrics computed from their logs (:mod:`ballbot_casadi.analysis.metrics`),
and the pass/fail specs with their source.  :data:`STUDIES` holds the thesis experiments:

============  ===========================================================================
``zero``      zero reference from roll = pitch = 5 deg (thesis §8.2.3)
``sine``      roll sine 3 deg at 0.5 Hz (thesis §8.2.5)
``robustness`` plant mass +10 %, inertias x3.2, controller nominal (thesis §8.4.1)
``com``       COM offset (-2, -3, +3) cm: balance alone (runaway, §8.4.2) and cascade (§9.2)
``push``      4 deg roll jump of the plant attitude (thesis §8.4.3)
``velocity``  velocity profile in the spirit of thesis Fig. 9.3 (§9.2)
============  ===========================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ballbot_casadi.analysis.metrics import (
    base_metrics,
    com_metrics,
    push_metrics,
    sine_metrics,
    velocity_metrics,
    zero_metrics,
)
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim import references as R
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.scenarios import Scenario, initial_state

__all__ = ["Spec", "Study", "STUDIES", "STUDY_NAMES", "get_study", "study_scenarios",
           "evaluate_specs", "COM_CHANGES"]

#: COM offset of thesis §8.4.2 / §9.2: (-2, -3, +3) cm in the body frame.
COM_CHANGES = MappingProxyType({"com_x": ("set", -0.02), "com_y": ("set", -0.03), "l": ("add", 0.03)})

_OPS: Mapping[str, Callable[[Any, Any], bool]] = MappingProxyType({
    "<": lambda a, b: a < b,
    "<=": lambda a, b: a <= b,
    ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b,
    "==": lambda a, b: a == b,
    "abs<=": lambda a, b: abs(a) <= b,
})


@dataclass(frozen=True)
class Spec:
    """One pass/fail criterion: ``metric op threshold``, with where the number comes from."""

    metric: str
    op: str
    threshold: Any
    source: str

    def evaluate(self, metrics: Mapping[str, Any]) -> dict[str, Any]:
        """The criterion's row: ``metric, value, op, threshold, ok, source``."""
        val = metrics.get(self.metric)
        ok = (val is not None and not (isinstance(val, float) and math.isnan(val))
              and bool(_OPS[self.op](val, self.threshold)))
        return {"metric": self.metric, "value": val, "op": self.op, "threshold": self.threshold,
                "ok": ok, "source": self.source}


def evaluate_specs(specs: Sequence[Spec], metrics: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Evaluate ``specs`` on ``metrics``: one row per criterion (see :meth:`Spec.evaluate`)."""
    return [s.evaluate(metrics) for s in specs]


@dataclass(frozen=True)
class Study:
    """A study: scenarios for a controller, metrics of their logs, specs.

    Attributes
    ----------
    name, description
        Identifier (``ballbot study <name>``) and one line for ``--list`` and reports.
    scenarios
        ``controller -> (Scenario, ...)``; the *last* scenario is the study's main run.
    metrics
        ``logs -> dict`` (logs in scenario order); merged over :func:`base_metrics` of the
        main run.
    specs
        The pass/fail criteria.
    """

    name: str
    description: str
    scenarios: Callable[[str], tuple[Scenario, ...]]
    metrics: Callable[[Sequence[SimulationLog]], dict[str, Any]]
    specs: tuple[Spec, ...]

    def compute_metrics(self, logs: Sequence[SimulationLog]) -> dict[str, Any]:
        """:func:`base_metrics` of the main run plus the study's own metrics."""
        return {**base_metrics(logs[-1]), **self.metrics(logs)}

    def check(self, metrics: Mapping[str, Any]) -> list[dict[str, Any]]:
        """Evaluate the specs on ``metrics``."""
        return evaluate_specs(self.specs, metrics)


def _sine_initial_state(amplitude_deg: float, frequency_hz: float) -> tuple:
    """Plant at rest on the ground, body on the sine reference at t = 0 (q, dq)."""
    sig = R.sine(np.zeros(1), math.radians(amplitude_deg), frequency_hz)
    q, dq, _ = R.rpy_reference(sig, 0.0, 0.0)
    return tuple(float(v) for v in np.concatenate([[0.0, 0.0], q[0], [0.0, 0.0], dq[0]]))


_FINITE = Spec("finite", "==", True, "run completed")


def _zero(c: str) -> tuple[Scenario, ...]:
    return (Scenario("zero", c, 5.0, initial_state(5, 5), study="zero",
                     description="zero reference from roll = pitch = 5 deg (thesis §8.2.3)"),)


def _sine(c: str) -> tuple[Scenario, ...]:
    return (Scenario("sine", c, 10.0, _sine_initial_state(3.0, 0.5),
                     attitude={"roll": {"type": "sine", "amplitude_deg": 3.0, "frequency_hz": 0.5}},
                     study="sine",
                     description="roll sine 3 deg at 0.5 Hz (thesis §8.2.5), plant starts on the reference"),)


def _robustness(c: str) -> tuple[Scenario, ...]:
    changes = {"Mb": ["scale", 1.1], "Jbx": ["scale", 3.2], "Jby": ["scale", 3.2], "Jbz": ["scale", 3.2]}
    return (Scenario("robustness", c, 8.0, initial_state(5, -5), plant_changes=changes,
                     study="robustness",
                     description="plant mass +10 %, inertias x3.2, controller on the nominal model, "
                                 "from roll 5, pitch -5 deg (thesis §8.4.1, Fig. 8.10)"),)


def _com(c: str) -> tuple[Scenario, ...]:
    changes = {k: list(v) for k, v in COM_CHANGES.items()}
    return (
        Scenario("com_balance_only", c, 5.0, initial_state(), plant_changes=changes, study="com",
                 description="COM offset (-2, -3, +3) cm, balance controller alone: runaway (thesis §8.4.2)"),
        Scenario("com", c, 30.0, initial_state(), cascade=True, plant_changes=changes, study="com",
                 description="COM offset (-2, -3, +3) cm with the velocity loop (thesis §9.2)"),
    )


def _push(c: str) -> tuple[Scenario, ...]:
    return (Scenario("push", c, 6.0, initial_state(), pushes=((1.0, 4.0, 0.0, 0.0),), study="push",
                     description="4 deg roll jump of the plant attitude at t = 1 s (thesis §8.4.3)"),)


def _velocity(c: str) -> tuple[Scenario, ...]:
    return (Scenario("velocity", c, 22.0, initial_state(), cascade=True,
                     velocity_keyframes=R.FIG93_KEYFRAMES, study="velocity",
                     description="velocity profile in the spirit of thesis Fig. 9.3 (§9.2)"),)


def _sine_metrics(logs: Sequence[SimulationLog]) -> dict[str, Any]:
    main = logs[-1]
    return sine_metrics(main, main.scenario["attitude"]["roll"]["frequency_hz"])


def _push_metrics(logs: Sequence[SimulationLog]) -> dict[str, Any]:
    main = logs[-1]
    return {**push_metrics(main, main.scenario["pushes"][0][0]), **zero_metrics(main)}


STUDIES: Mapping[str, Study] = MappingProxyType({s.name: s for s in (
    Study("zero", "zero reference from roll = pitch = 5 deg (thesis §8.2.3)", _zero,
          lambda logs: zero_metrics(logs[-1]),
          (_FINITE, Spec("steady_state_error_deg", "<", 0.01,
                         "converges, steady-state error < 0.01 deg"))),
    Study("sine", "roll sine 3 deg at 0.5 Hz (thesis §8.2.5)", _sine, _sine_metrics,
          (_FINITE,
           Spec("roll_lag_s", "abs<=", 0.02, "thesis §8.2.5: < 0.1 s"),
           Spec("pitch_error_max_deg", "<=", 0.01, "thesis: <= 0.25 deg"),
           Spec("yaw_error_max_deg", "<=", 0.01, "thesis: < 0.1 deg"),
           Spec("torque_tv_ratio", "<=", 1.5, "no chattering (thesis Fig. 8.7)"))),
    Study("robustness", "plant mass +10 %, inertias x3.2, controller nominal (thesis §8.4.1)",
          _robustness, lambda logs: zero_metrics(logs[-1]),
          (_FINITE, Spec("steady_state_error_deg", "<", 0.01,
                         "converges despite mass/inertia error (thesis §8.4.1)"))),
    Study("com", "COM offset (-2, -3, +3) cm: runaway alone, held by the velocity loop "
          "(thesis §8.4.2, §9.2)", _com,
          lambda logs: com_metrics(logs[0], logs[-1], logs[-1].params),
          (_FINITE,
           Spec("runaway_speed_mps", ">", 0.5, "balance controller alone runs away (thesis §8.4.2)"),
           Spec("final_speed_mps", "<", 0.01, "velocity loop stops the runaway (thesis §9.2)"),
           Spec("equilibrium_error_deg", "<", 0.1, "tilt settles with the COM over the ball centre"))),
    Study("push", "4 deg roll jump of the plant attitude (thesis §8.4.3)", _push, _push_metrics,
          (_FINITE,
           Spec("push_max_tilt_deg", ">=", 3.9, "the push was applied"),
           Spec("steady_state_error_deg", "<", 0.01, "recovers to upright (thesis §8.4.3)"))),
    Study("velocity", "velocity profile like thesis Fig. 9.3 (§9.2)", _velocity,
          lambda logs: velocity_metrics(logs[-1]),
          (_FINITE,
           Spec("max_abs_roll_pitch_deg", "<=", 5.0, "inclination limit +-5 deg (thesis §7.1)"),
           Spec("velocity_error_rms_delayed_mps", "<=", 0.05,
                "tracked with no significant error (thesis §9.2): rms <= 10 % of v_max after "
                "the non-minimum-phase delay"),
           Spec("final_velocity_error_mps", "<=", 0.01, "reaches the final reference"))),
)})

#: Names of the registered studies (``ballbot study <name>``).
STUDY_NAMES: tuple[str, ...] = tuple(STUDIES)


def get_study(name: str) -> Study:
    """The registered study ``name`` (error listing the allowed names otherwise)."""
    try:
        return STUDIES[name]
    except KeyError:
        raise ScenarioError(f"unknown study {name!r}; allowed: {', '.join(STUDIES)}") from None


def study_scenarios(name: str, controller: str = "flc") -> tuple[Scenario, ...]:
    """The scenario(s) of study ``name`` for ``controller`` (main run last)."""
    return get_study(name).scenarios(controller)
