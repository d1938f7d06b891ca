"""Error hierarchy of ballbot-casadi, by kind of failure.

Every error the package raises on purpose derives from :class:`BallbotError` and from the
matching built-in (``ValueError``, ``TypeError`` or ``RuntimeError``), so callers can
catch either.  Messages say what was wrong and what is allowed.

Each class carries the exit code of the ``ballbot`` command line (``exit_code``):

* **2, user input** -- a bad argument, parameter, state, scenario or path
  (:class:`ArgumentError` and its subclasses, :class:`ParameterError`,
  :class:`StateError`, :class:`ShapeError`, :class:`BallbotTypeError`,
  :class:`PathError`, :class:`FileFormatError`);
* **3, the machinery failed** -- the C toolchain (:class:`BuildError`), a
  co-simulation engine (:class:`CosimError`) or a Dask cluster (:class:`ClusterError`),
  not something the user wrote.
"""

from __future__ import annotations

__all__ = [
    "BallbotError",
    "EXIT_USER_ERROR",
    "EXIT_INTERNAL_ERROR",
    "ArgumentError",
    "ParameterError",
    "StateError",
    "ShapeError",
    "ScenarioError",
    "ScenarioFileError",
    "BallbotTypeError",
    "BuildError",
    "CosimError",
    "SolverError",
    "SolverError",
    "ClusterError",
    "PathError",
    "FileFormatError",
]

#: Exit code of a user mistake (bad option, path, value): one line on stderr.
EXIT_USER_ERROR = 2
#: Exit code of a failure of the machinery (toolchain, co-simulation engine, a bug).
EXIT_INTERNAL_ERROR = 3


class BallbotError(Exception):
    """Base class of every ballbot-casadi error; ``exit_code`` is the command line's."""

    exit_code: int = EXIT_USER_ERROR


class ArgumentError(BallbotError, ValueError):
    """An argument of a library function (gains, estimator name, sample time, ...) is invalid."""


class ParameterError(BallbotError, ValueError):
    """A model parameter is unknown, non-finite or outside its physical range."""


class StateError(BallbotError, ValueError):
    """A state vector is non-finite or off the unit-quaternion manifold."""


class ShapeError(BallbotError, ValueError):
    """An array does not have the shape the function requires."""


class ScenarioError(ArgumentError):
    """A scenario, reference or run specification is invalid.

    ``key`` names the offending scenario-file key (e.g. ``"plant.Mb"``,
    ``"attitude.roll.frequency_hz"``) when the code that raised it knows it; ``None``
    otherwise.  Callers that need the key read this field, never the message text.
    """

    def __init__(self, message: str = "", *, key: str | None = None, reason: str | None = None) -> None:
        super().__init__(message)
        self.key = key
        #: The message without the prefix naming the scenario or file (what a file
        #: reader prints after the key).
        self.reason = message if reason is None else reason

    def within(self, prefix: str) -> "ScenarioError":
        """The same error (key and reason kept) with ``prefix: `` before the message."""
        return type(self)(f"{prefix}: {self}", key=self.key, reason=self.reason)


class ScenarioFileError(ScenarioError):
    """A scenario file is unreadable or holds an unknown key, a wrong type or an impossible value."""


class BallbotTypeError(BallbotError, TypeError):
    """An argument has the wrong type."""


class BuildError(BallbotError, RuntimeError):
    """Generating, compiling or loading C code failed (the toolchain, not the user)."""

    exit_code = EXIT_INTERNAL_ERROR


class SolverError(BallbotError, RuntimeError):
    """A generated solver inside a run did not converge (e.g. the guidance's QP)."""

    exit_code = EXIT_INTERNAL_ERROR


class CosimError(BallbotError, RuntimeError):
    """A co-simulation engine (libcosim, fmpy) refused a value or stopped during a run."""

    exit_code = EXIT_INTERNAL_ERROR


class ClusterError(BallbotError, RuntimeError):
    """A Dask cluster lost its workers or its tasks during a run (the machinery, exit 3).

    ``finished`` maps the index of each task (or run) that had finished to its result
    when the run stopped (``None`` when the raiser kept none), so that the caller can
    save them.
    """

    exit_code = EXIT_INTERNAL_ERROR

    def __init__(self, message: str = "", *, finished: dict | None = None) -> None:
        super().__init__(message)
        self.finished = finished


class PathError(BallbotError, ValueError):
    """A file or folder path cannot be used (missing, wrong kind, not writable)."""


class FileFormatError(BuildError):
    """A file the user gave (SSP, FMU archive) is malformed: not the format it claims to be.

    A :class:`BuildError` (a damaged cached artefact is one, and callers that rebuild catch
    those), but a user mistake when the file came from the user: exit code 2.
    """

    exit_code = EXIT_USER_ERROR
