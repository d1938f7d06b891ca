"""Input checks shared by the numeric APIs: shapes, finiteness, unit quaternions."""

from __future__ import annotations

import json
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import BallbotTypeError, ShapeError, StateError

__all__ = ["as_vector", "check_state", "plain_json", "QUAT_TOL"]

#: Allowed deviation of the state quaternion norm from 1.
QUAT_TOL = 1e-6


def as_vector(value: Any, n: int, what: str) -> np.ndarray:
    """Return ``value`` as a finite float64 vector of length ``n`` or raise.

    Accepts shapes (n,), (n, 1) and (1, n).
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise BallbotTypeError(f"{what} must be an array of {n} real numbers") from None
    if arr.ndim > 2 or arr.size != n or (arr.ndim == 2 and 1 not in arr.shape):
        raise ShapeError(f"{what} must have shape ({n},), got {arr.shape}")
    arr = arr.reshape(n)
    if not np.all(np.isfinite(arr)):
        raise StateError(f"{what} contains NaN or Inf: {arr.tolist()}")
    return arr


def check_state(x: Any, what: str = "state") -> np.ndarray:
    """Validate a 12-state ``[x, y, q0..q3, dx, dy, dq0..dq3]``: finite, unit quaternion."""
    arr = as_vector(x, 12, what)
    nq = float(np.linalg.norm(arr[STATE["q"]]))
    if abs(nq - 1.0) > QUAT_TOL:
        raise StateError(
            f"{what}: quaternion [q0..q3] has norm {nq:.9g}; it must be 1 within {QUAT_TOL:g}"
        )
    return arr


def plain_json(value: Any, what: str) -> Any:
    """A deep copy of ``value`` made of plain JSON data (numpy arrays become lists, numpy
    scalars Python numbers, mappings dicts), as a scenario stores and writes it.

    Raises
    ------
    BallbotTypeError
        Something in ``value`` has no JSON form (the message names ``what`` and the type).
    """
    def plain(obj: Any) -> Any:
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        if isinstance(obj, (np.floating, np.integer, np.bool_)):
            return obj.item()
        if isinstance(obj, Mapping):
            return dict(obj)
        raise BallbotTypeError(f"{what}: a value of type {type(obj).__name__} has no JSON form; allowed: "
                               "numbers, strings, booleans, lists, tables and numpy arrays")
    return json.loads(json.dumps(value, default=plain))
