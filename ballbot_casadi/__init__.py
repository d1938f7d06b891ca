"""ballbot-casadi: the 3D quaternion ballbot model in CasADi, code-generated to C.

Public API::

    from ballbot_casadi import load_params, BallbotModel, make_state, ClosedLoop, run_scenario

Where things are (each layer imports only from the ones above it in this list):

* :mod:`ballbot_casadi.errors` - the error hierarchy;
* :mod:`ballbot_casadi.core` - parameters, quaternions, validation, named layouts,
  constants, the C toolchain and its hash-keyed build cache;
* :mod:`ballbot_casadi.model` - kinematics, dynamics, numeric front end, sensors,
  integrators, linearisation;
* :mod:`ballbot_casadi.control` / :mod:`ballbot_casadi.estimation` - controllers and
  estimators (they receive CasADi Functions, never import the model);
* :mod:`ballbot_casadi.sim` - the control period, missions, logs, scenarios, references;
* :mod:`ballbot_casadi.analysis`, :mod:`ballbot_casadi.codegen`, :mod:`ballbot_casadi.fmi`;
* :mod:`ballbot_casadi.studies` (the ``studies/`` folder), :mod:`ballbot_casadi.bench`,
  :mod:`ballbot_casadi.cli`.
"""

from ballbot_casadi.core.params import PARAM_NAMES, Params, load_params
from ballbot_casadi.errors import (
    BallbotError,
    BallbotTypeError,
    BuildError,
    ParameterError,
    ScenarioError,
    ShapeError,
    StateError,
)
from ballbot_casadi.model.numeric import BallbotModel, make_state
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario

__all__ = [
    "BallbotError",
    "BallbotTypeError",
    "BuildError",
    "ParameterError",
    "ScenarioError",
    "ShapeError",
    "StateError",
    "PARAM_NAMES",
    "Params",
    "load_params",
    "BallbotModel",
    "make_state",
    "ClosedLoop",
    "run_scenario",
]
