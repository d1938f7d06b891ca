"""The simulation's specification records are immutable values: a scenario's sections,
the signal-key table, ports, blocks, laws and the declared loop dependencies are shared
(module-level tables, ``lru_cache`` keys, one scenario read by many runs), so an
assignment to one must fail and each must hash (mutant class: ``frozen=True`` -> ``False``,
which also drops ``__hash__``)."""

from __future__ import annotations

import dataclasses

import pytest

from ballbot_casadi.sim import embedded, guided, path_following, ports
from ballbot_casadi.sim.scenario import changes, file, path_section, sections, signals

_RECORDS = [
    path_following.LoopDependencies, guided.GuidanceLaw, file.ScenarioFile,
    sections.RunSection, sections.InitialSection, sections.ReferencesSection,
    sections.DisturbancesSection, sections.ModelSection, sections.SensorsSection,
    sections.EstimationSection, sections.ObserverSection, sections.GainsSection,
    sections.SpecsSection, sections.DispersionsSection, signals.SignalKey,
    changes.ParamChanges, path_section.PathSection, ports.Port, ports.PeriodBlocks,
    embedded.EstimatorBlocks,
]


@pytest.mark.parametrize("cls", _RECORDS, ids=lambda c: c.__name__)
def test_every_record_is_frozen_and_hashable(cls) -> None:
    assert dataclasses.is_dataclass(cls)
    assert cls.__dataclass_params__.frozen is True
    assert cls.__hash__ is not None


def test_a_shared_signal_key_refuses_an_assignment_and_keys_a_dict() -> None:
    rate = next(k for k in signals.SIGNAL_KEYS["ramp"] if k.name == "rate")
    with pytest.raises(dataclasses.FrozenInstanceError):
        rate.lo = -1.0  # type: ignore[misc]
    assert (rate.lo, rate.open, rate.required) == (0.0, True, True)
    assert {rate: 1}[signals.SignalKey("rate", "rate_deg_s", True, 0.0, open=True)] == 1


def test_the_declared_loop_dependencies_refuse_an_assignment() -> None:
    deps = path_following.LoopDependencies(("m_b",), (0, 1))
    with pytest.raises(dataclasses.FrozenInstanceError):
        deps.period = False  # type: ignore[misc]
    assert hash(deps) == hash(path_following.LoopDependencies(("m_b",), (0, 1), True))
