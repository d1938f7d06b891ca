"""Error hierarchy of ballbot-casadi.

Every error raised on bad user input derives from :class:`BallbotError` and from the
matching built-in (``ValueError``, ``TypeError`` or ``RuntimeError``), so callers can
catch either.  Messages say what was wrong and what is allowed.
"""

from __future__ import annotations

__all__ = [
    "BallbotError",
    "ParameterError",
    "StateError",
    "ShapeError",
    "ScenarioError",
    "BallbotTypeError",
    "BuildError",
    "PathError",
]


class BallbotError(Exception):
    """Base class of every ballbot-casadi error."""


class ParameterError(BallbotError, ValueError):
    """A model parameter is unknown, non-finite or outside its physical range."""


class StateError(BallbotError, ValueError):
    """A state vector is non-finite or off the unit-quaternion manifold."""


class ShapeError(BallbotError, ValueError):
    """An array does not have the shape the function requires."""


class ScenarioError(BallbotError, ValueError):
    """A scenario, reference or controller specification is invalid."""


class BallbotTypeError(BallbotError, TypeError):
    """An argument has the wrong type."""


class BuildError(BallbotError, RuntimeError):
    """Generating or compiling C code failed."""


class PathError(BallbotError, ValueError):
    """A file or folder path cannot be used (missing, wrong kind, not writable)."""
