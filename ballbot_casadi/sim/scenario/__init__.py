"""Scenarios: one closed-loop run, as a validated object and as a TOML file.

* :mod:`~ballbot_casadi.sim.scenario.scenario` -- :class:`Scenario`, the run (composed
  of sections, attributes read through them, input sequences of the closed loop);
* :mod:`~ballbot_casadi.sim.scenario.sections` -- the sections mirroring the file
  (run, initial, references, disturbances, model changes, sensors, estimation, observer,
  gains, specs, dispersions), each owning its keys, units, validation and TOML round trip;
* :mod:`~ballbot_casadi.sim.scenario.checker` -- the key-by-key checks of a file table;
* :mod:`~ballbot_casadi.sim.scenario.changes` -- :class:`ParamChanges`, the one type of
  ``set``/``scale``/``add`` parameter changes (plant, controller and estimator models,
  sensors);
* :mod:`~ballbot_casadi.sim.scenario.signals` -- the attitude-reference schema and its
  check (Nyquist limit);
* :mod:`~ballbot_casadi.sim.scenario.file` -- reading and validating scenario files;
* :mod:`~ballbot_casadi.sim.scenario.toml_write` -- writing them back;
* :mod:`~ballbot_casadi.sim.scenario.dispersions` -- the Monte Carlo dispersions of a file
  and the runs drawn from them.

The specs of a file's ``[[spec]]`` rows are :mod:`ballbot_casadi.core.specs`.
"""

from ballbot_casadi.errors import ScenarioFileError
from ballbot_casadi.sim.scenario.changes import CHANGE_OPS, ParamChanges, apply_changes
from ballbot_casadi.sim.scenario.file import (
    DISPERSION_TARGETS,
    ScenarioFile,
    load_scenario_file,
    parse_scenario,
)
from ballbot_casadi.sim.scenario.scenario import (
    ESTIMATOR_CHOICES,
    ESTIMATOR_TUNING_KEYS,
    ESTIMATOR_TUNING_TARGETS,
    FEEDFORWARD_MODES,
    TORQUE_LIMIT_MODES,
    Scenario,
    initial_state,
)
from ballbot_casadi.sim.scenario.toml_write import dump_toml, set_value

__all__ = ["Scenario", "ScenarioFile", "ScenarioFileError", "ParamChanges", "CHANGE_OPS",
           "apply_changes", "initial_state", "load_scenario_file", "parse_scenario", "dump_toml",
           "set_value", "DISPERSION_TARGETS", "ESTIMATOR_CHOICES", "ESTIMATOR_TUNING_KEYS",
           "ESTIMATOR_TUNING_TARGETS", "FEEDFORWARD_MODES", "TORQUE_LIMIT_MODES"]
