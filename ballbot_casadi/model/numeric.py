"""Numeric front end of the model: :class:`BallbotModel` (numpy in, numpy out)."""

from __future__ import annotations

from typing import Any, NamedTuple

import casadi as ca
import numpy as np

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.params import Params, load_params
from ballbot_casadi.core.validation import as_vector, check_state
from ballbot_casadi.errors import BallbotTypeError, StateError
from ballbot_casadi.model.dynamics import NU, NX, make_model_functions

__all__ = ["BallbotModel", "Energy", "make_state"]


class Energy(NamedTuple):
    """Kinetic, potential and total energy in joules."""

    kinetic: float
    potential: float
    total: float


def make_state(
    x: float = 0.0,
    y: float = 0.0,
    roll: float = 0.0,
    pitch: float = 0.0,
    yaw: float = 0.0,
    dx: float = 0.0,
    dy: float = 0.0,
    omega_body: Any = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """12-state from position, ZYX angles (rad), ball velocity and body-frame angular rate.

    ``dq = 1/2 q o ^omega_b`` (thesis E.32).

    Raises
    ------
    StateError
        A value is NaN or infinite (names the argument).
    BallbotTypeError
        A scalar argument is not a real number.
    """
    scalars = {"x": x, "y": y, "roll": roll, "pitch": pitch, "yaw": yaw, "dx": dx, "dy": dy}
    for name, value in scalars.items():
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise BallbotTypeError(f"make_state: {name} must be a real number, got "
                                   f"{value!r}") from None
        if not np.isfinite(v):
            raise StateError(f"make_state: {name} must be finite, got {v}")
        scalars[name] = v
    w = as_vector(omega_body, 3, "make_state: omega_body")
    q = Q.from_rpy(scalars["roll"], scalars["pitch"], scalars["yaw"])
    dq = 0.5 * Q.mul(q, Q.hat(w))
    return np.concatenate([[scalars["x"], scalars["y"]], q, [scalars["dx"], scalars["dy"]], dq])


class BallbotModel:
    """The ballbot model for one parameter set.

    Parameters
    ----------
    params
        A :class:`~ballbot_casadi.core.params.Params`; ``None`` loads the defaults.
    functions
        Optional dict of model Functions (e.g. compiled ones from
        :func:`ballbot_casadi.codegen.load_model_library`); default: the symbolic ones
        of :func:`ballbot_casadi.model.dynamics.make_model_functions`.

    Notes
    -----
    State ``x = [x, y, q0, q1, q2, q3, dx, dy, dq0, dq1, dq2, dq3]`` (thesis 2.4), inputs
    the three wheel torques.  Every method validates its arguments: wrong shapes, NaN
    or a quaternion whose norm is off by more than 1e-6 raise ``ValueError``
    subclasses from :mod:`ballbot_casadi.errors`.
    """

    def __init__(self, params: Params | None = None, functions: dict[str, ca.Function] | None = None):
        if params is None:
            params = load_params()
        if not isinstance(params, Params):
            raise TypeError(f"params must be a Params (see load_params), got {type(params).__name__}")
        self._params = params
        self._p = params.to_vector()
        self._functions = dict(functions) if functions is not None else make_model_functions()

    @property
    def params(self) -> Params:
        """The parameter set."""
        return self._params

    @property
    def p(self) -> np.ndarray:
        """The parameter vector (copy)."""
        return self._p.copy()

    @property
    def functions(self) -> dict[str, ca.Function]:
        """The CasADi Functions, keyed ``ode``, ``jac``, ``affine``, ``energy``, ...."""
        return dict(self._functions)

    def ode(self, x: Any, tau: Any) -> np.ndarray:
        """State derivative ``xdot = f(x, tau)`` (thesis C.10, C.68)."""
        x = check_state(x)
        tau = as_vector(tau, NU, "tau")
        return np.asarray(self._functions["ode"](x, tau, self._p)).reshape(NX)

    def linearize(self, x0: Any, tau0: Any) -> tuple[np.ndarray, np.ndarray]:
        """Jacobians ``A = df/dx`` (12x12) and ``B = df/dtau`` (12x3) at ``(x0, tau0)``."""
        x0 = check_state(x0)
        tau0 = as_vector(tau0, NU, "tau")
        A, B = self._functions["jac"](x0, tau0, self._p)
        return np.asarray(A), np.asarray(B)

    def affine(self, x: Any) -> tuple[np.ndarray, np.ndarray]:
        """Control-affine split ``ddchi = f + g tau``: returns ``f`` (6,) and ``g`` (6x3)."""
        x = check_state(x)
        f, g = self._functions["affine"](x, self._p)
        return np.asarray(f).reshape(6), np.asarray(g)

    def energy(self, x: Any) -> Energy:
        """Kinetic, potential and total energy (thesis C.14-C.24)."""
        x = check_state(x)
        T, V, E = self._functions["energy"](x, self._p)
        return Energy(float(T), float(V), float(E))

    def wheel_speeds(self, x: Any) -> np.ndarray:
        """Motor-shaft angular velocities (inverse kinematics, thesis B.47)."""
        x = check_state(x)
        return np.asarray(self._functions["wheel_speeds"](x, self._p)).reshape(3)

    def upright(self, yaw: float = 0.0, x: float = 0.0, y: float = 0.0) -> np.ndarray:
        """Upright state at rest with heading ``yaw`` (an equilibrium when com_x = com_y = 0)."""
        return make_state(x=x, y=y, yaw=yaw)
