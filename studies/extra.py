"""Studies that are not scenario-file runs of the closed loop (issue 22): ``envelope``,
``consistency``, ``heading``, ``sta_noise`` and ``flc_smc``.  Each is ``run(out, plot) -> metrics`` writing
``metrics.json``, ``report.md`` and its plot into ``out``; ``metrics["passed"]`` decides
the exit code of ``ballbot study <name>``."""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping

from ballbot_casadi.studies.consistency import run_consistency_study
from ballbot_casadi.studies.envelope import run_envelope_study
from ballbot_casadi.studies.flc_smc import run_flc_smc_study
from ballbot_casadi.studies.heading import run_heading_study
from ballbot_casadi.studies.sta_noise import run_sta_noise_study

__all__ = ["EXTRA_STUDIES", "EXTRA_DESCRIPTIONS", "run_extra_study"]

#: Study name -> runner ``(out, plot) -> metrics``.
EXTRA_STUDIES: Mapping[str, Callable[[Path, bool], dict[str, Any]]] = MappingProxyType({
    "envelope": run_envelope_study,
    "consistency": run_consistency_study,
    "heading": run_heading_study,
    "sta_noise": run_sta_noise_study,
    "flc_smc": run_flc_smc_study,
})
#: One line per study for ``ballbot study --list``.
EXTRA_DESCRIPTIONS: Mapping[str, str] = MappingProxyType({
    "envelope": "push-recovery envelope per balance controller by bisection (true state, UKFs)",
    "consistency": "NIS of the attitude and velocity filters with chi2 bands, every scenario "
                   "with estimators",
    "heading": "heading error over an hour with and without heading aiding (synthetic data)",
    "sta_noise": "super-twisting |S| with the UKFs against the gyroscope's noise floor",
    "flc_smc": "thesis §8.3: FLC against the V2019 SMC on the asymmetric sine, both set-ups",
})


def run_extra_study(name: str, out: Path, plot: bool = True) -> dict[str, Any]:
    """Run study ``name`` of :data:`EXTRA_STUDIES` into ``out``."""
    return EXTRA_STUDIES[name](out, plot)
