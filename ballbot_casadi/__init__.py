"""ballbot-casadi: the 3D quaternion ballbot model in CasADi, code-generated to C."""

from .errors import (
    BallbotError,
    BallbotTypeError,
    BuildError,
    ParameterError,
    ScenarioError,
    ShapeError,
    StateError,
)
from .params import PARAM_NAMES, Params, load_params

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
]
