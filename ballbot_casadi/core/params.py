"""Model parameters (thesis App. A) as an immutable, validated record.

The order of :data:`PARAM_NAMES` is the order of the parameter vector ``p`` that every
CasADi Function of the package takes as its last input, so one generated C library
serves every parameter set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np
import tomllib

from ballbot_casadi.errors import BallbotTypeError, ParameterError

__all__ = ["PARAM_NAMES", "PARAM_INFO", "Params", "ParamView", "load_params", "default_params_path"]

# name: (unit, description, rule)
# rules: "pos" > 0, "nonneg" >= 0, "any" finite, "alpha" in (0, pi/2), "gamma" in (0, pi)
PARAM_INFO: Mapping[str, tuple[str, str, str]] = MappingProxyType({
    "Mb": ("kg", "body mass including wheels and motors", "pos"),
    "l": ("m", "distance from ball centre to body centre of mass", "pos"),
    "Jbx": ("kg.m2", "body inertia about body x", "pos"),
    "Jby": ("kg.m2", "body inertia about body y", "pos"),
    "Jbz": ("kg.m2", "body inertia about body z", "pos"),
    "Jw": ("kg.m2", "inertia of wheel, gear and motor about the motor axis", "pos"),
    "rw": ("m", "omni-wheel radius", "pos"),
    "rk": ("m", "ball radius", "pos"),
    "Mk": ("kg", "ball mass", "pos"),
    "Jk": ("kg.m2", "ball inertia", "pos"),
    "alpha": ("rad", "wheel zenith angle", "alpha"),
    "gamma": ("rad", "angle between neighbouring wheels", "gamma"),
    "Bvk": ("N.s/m", "viscous friction ball-ground", "nonneg"),
    "Bvm": ("N.m.s/rad", "viscous friction motor and wheel", "nonneg"),
    "Bvb": ("N.m.s/rad", "viscous friction body-air", "nonneg"),
    "tau_max": ("N.m", "maximum wheel torque", "pos"),
    "n_ticks": ("1", "encoder ticks per wheel revolution", "pos"),
    "g": ("m/s2", "gravitational acceleration", "nonneg"),
    "com_x": ("m", "centre-of-mass offset along body x", "any"),
    "com_y": ("m", "centre-of-mass offset along body y", "any"),
    "beta": ("1/s", "Baumgarte stabilisation gain", "nonneg"),
})

PARAM_NAMES: tuple[str, ...] = tuple(PARAM_INFO)

_RULE_TEXT = {
    "pos": "a finite number > 0",
    "nonneg": "a finite number >= 0",
    "any": "a finite number",
    "alpha": "an angle strictly between 0 and 90 deg",
    "gamma": "an angle strictly between 0 and 180 deg",
}


def default_params_path() -> Path:
    """Path of the default parameter file shipped with the package."""
    return Path(str(resources.files("ballbot_casadi.core") / "default_params.toml"))


def _to_float(name: str, value: Any) -> float:
    """Convert one raw parameter value to float (angles may carry a unit string)."""
    if isinstance(value, bool):
        raise BallbotTypeError(f"parameter {name!r}: got a bool, expected a real number")
    if isinstance(value, str):
        unit = PARAM_INFO[name][0]
        text = value.strip().split()
        if unit == "rad" and len(text) == 2 and text[1] in ("deg", "rad"):
            try:
                num = float(text[0])
            except ValueError:
                num = math.nan
            return math.radians(num) if text[1] == "deg" else num
        allowed = "a number or '<value> deg' / '<value> rad'" if unit == "rad" else "a number"
        raise BallbotTypeError(f"parameter {name!r}: got string {value!r}, expected {allowed}")
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    raise BallbotTypeError(
        f"parameter {name!r}: got {type(value).__name__}, expected a real number"
    )


def _check(name: str, v: float) -> None:
    rule = PARAM_INFO[name][2]
    ok = math.isfinite(v)
    if ok and rule == "pos":
        ok = v > 0
    elif ok and rule == "nonneg":
        ok = v >= 0
    elif ok and rule == "alpha":
        ok = 0 < v < math.pi / 2
    elif ok and rule == "gamma":
        ok = 0 < v < math.pi
    if not ok:
        raise ParameterError(f"parameter {name!r} = {v!r} is invalid: must be {_RULE_TEXT[rule]}")


@dataclass(frozen=True)
class Params:
    """Immutable, validated ballbot parameter set (thesis App. A; SI units, radians).

    Build it with :func:`load_params`.  ``beta`` is the Baumgarte gain of thesis
    (C.64): the unit-norm constraint error obeys h'' + 2 beta h' + beta^2 h = 0, a
    critically damped double pole at -beta.  The default 10 1/s removes integration
    drift within ~0.5 s, is slower than nothing the controllers rely on and, at the
    1 ms RK4 step, gives |lambda h| = 0.01, far inside RK4's stability region.
    """

    Mb: float
    l: float
    Jbx: float
    Jby: float
    Jbz: float
    Jw: float
    rw: float
    rk: float
    Mk: float
    Jk: float
    alpha: float
    gamma: float
    Bvk: float
    Bvm: float
    Bvb: float
    tau_max: float
    n_ticks: float
    g: float
    com_x: float
    com_y: float
    beta: float

    def __post_init__(self) -> None:
        for f in fields(self):
            value = _to_float(f.name, getattr(self, f.name))
            _check(f.name, value)
            object.__setattr__(self, f.name, value)

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names in parameter-vector order."""
        return PARAM_NAMES

    def to_vector(self) -> np.ndarray:
        """Parameter vector ``p`` (float64, order of :attr:`names`)."""
        return np.array([getattr(self, n) for n in PARAM_NAMES], dtype=float)

    def as_dict(self) -> dict[str, float]:
        """Plain ``{name: value}`` dictionary in vector order."""
        return {n: getattr(self, n) for n in PARAM_NAMES}

    def replace(self, **overrides: Any) -> "Params":
        """Return a copy with some parameters changed (validated)."""
        _reject_unknown(overrides)
        return Params(**{**self.as_dict(), **overrides})

    @classmethod
    def from_vector(cls, p: Any) -> "Params":
        """Build from a parameter vector in :data:`PARAM_NAMES` order."""
        arr = np.asarray(p, dtype=float).reshape(-1)
        if arr.size != len(PARAM_NAMES):
            raise ParameterError(
                f"parameter vector has {arr.size} entries, expected {len(PARAM_NAMES)}"
            )
        return cls(**dict(zip(PARAM_NAMES, arr.tolist())))


def _reject_unknown(values: Mapping[str, Any]) -> None:
    unknown = sorted(set(values) - set(PARAM_NAMES))
    if unknown:
        raise ParameterError(
            f"unknown parameter name(s) {unknown}; allowed names: {', '.join(PARAM_NAMES)}"
        )


def _flatten(table: Mapping[str, Any], path: str, out: dict[str, Any] | None = None) -> dict[str, Any]:
    """Flatten TOML tables (sections are only for readability); reject duplicates."""
    out = {} if out is None else out
    for key, value in table.items():
        if isinstance(value, Mapping):
            _flatten(value, path, out)
        elif key in out:
            raise ParameterError(f"{path}: parameter {key!r} is given twice")
        else:
            out[key] = value
    return out


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ParameterError(f"parameter file {str(path)!r} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"parameter file {str(path)!r} is not valid TOML: {exc}") from None
    values = _flatten(data, str(path))
    _reject_unknown(values)
    return values


def load_params(path: str | Path | None = None, **overrides: Any) -> Params:
    """Load a parameter set.

    Parameters
    ----------
    path
        TOML file.  It may give any subset of the parameters (in any tables); the rest
        come from the packaged defaults (thesis App. A).  ``None`` loads the defaults.
    **overrides
        Parameter values that replace those of the file.

    Returns
    -------
    Params
        The validated, immutable parameter set.

    Raises
    ------
    ParameterError
        Unknown name, missing file, non-finite or non-physical value.
    BallbotTypeError
        A value of the wrong type.
    """
    values = _read_toml(default_params_path())
    if path is not None:
        values.update(_read_toml(Path(path)))
    _reject_unknown(overrides)
    values.update(overrides)
    missing = sorted(set(PARAM_NAMES) - set(values))
    if missing:
        raise ParameterError(f"parameters missing from the defaults: {missing}")
    return Params(**values)


class ParamView:
    """Attribute access to the entries of a parameter vector (numpy or CasADi).

    ``ParamView(p).Mb`` is ``p[PARAM_NAMES.index("Mb")]``; used by the symbolic model so
    that parameters stay runtime inputs of every generated Function.
    """

    __slots__ = ("_p",)

    def __init__(self, p: Any) -> None:
        if isinstance(p, Params):
            p = p.to_vector()
        n = p.numel() if hasattr(p, "numel") else np.asarray(p).size
        if n != len(PARAM_NAMES):
            raise ParameterError(f"parameter vector has {n} entries, expected {len(PARAM_NAMES)}")
        self._p = p

    def __getattr__(self, name: str) -> Any:
        try:
            i = PARAM_NAMES.index(name)
        except ValueError:
            raise AttributeError(f"unknown parameter {name!r}") from None
        return self._p[i]
