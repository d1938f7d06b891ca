"""Model parameters (thesis App. A) as an immutable, validated record.

The order of :data:`PARAM_NAMES` is the order of the parameter vector ``p`` that every
CasADi Function of the package takes as its last input, so one generated C library
serves every parameter set.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping, NamedTuple, Sequence

import numpy as np
import tomllib

from ballbot_casadi.errors import BallbotTypeError, ParameterError

__all__ = [
    "PARAM_NAMES",
    "PARAM_INFO",
    "PARAM_RULES",
    "RangeRule",
    "SENSOR_TABLE",
    "Params",
    "ParamView",
    "load_params",
    "default_params_path",
    "to_float",
    "check_value",
    "read_param_file",
    "flatten_tables",
]


class RangeRule(NamedTuple):
    """Allowed range of a parameter: ``lo < v < hi`` or with ``<=`` where a side is closed.

    A plain tuple ``(lo, hi, lo_open, hi_open, text)`` so other modules (the FMU's
    start-value checks, generated C tables) can read it without this class.  Values
    are in SI units and radians; ``text`` is the human-readable rule used in error
    messages (angles there in degrees).  Every rule also requires a finite value.
    """

    lo: float
    hi: float
    lo_open: bool
    hi_open: bool
    text: str

    def contains(self, v: float) -> bool:
        """True when ``v`` is finite and inside the range."""
        if not math.isfinite(v):
            return False
        above = v > self.lo if self.lo_open else v >= self.lo
        below = v < self.hi if self.hi_open else v <= self.hi
        return above and below


#: The parameter range rules, defined once: rule key -> :class:`RangeRule`.
#: ``PARAM_INFO`` (and the sensor parameter table) refer to them by key.
PARAM_RULES: Mapping[str, RangeRule] = MappingProxyType({
    "pos": RangeRule(0.0, math.inf, True, False, "a finite number > 0"),
    "nonneg": RangeRule(0.0, math.inf, False, False, "a finite number >= 0"),
    # Physical ranges of a robot the model supports: beyond them the products of the
    # model (M g l, inertias) leave double precision or no stabilising gain exists.
    "mass": RangeRule(0.0, 1e4, True, False, "a mass > 0 and <= 10000 kg"),
    "length": RangeRule(1e-3, 10.0, False, False,
                        "a length between 1 mm and 10 m (below 1 mm the tilt has no lever)"),
    "inertia": RangeRule(0.0, 1e4, True, False, "an inertia > 0 and <= 10000 kg.m2"),
    "wheel_inertia": RangeRule(0.0, 1.0, True, False, "an inertia > 0 and <= 1 kg.m2"),
    "friction": RangeRule(0.0, 1e3, False, False, "a friction coefficient between 0 and 1000"),
    "torque": RangeRule(0.0, 1e3, True, False, "a torque > 0 and <= 1000 N.m"),
    "ticks": RangeRule(0.0, 1e9, True, False, "a tick count > 0 and <= 1e9 per revolution"),
    "gravity": RangeRule(0.0, 100.0, False, False, "an acceleration between 0 and 100 m/s2"),
    "offset": RangeRule(-1.0, 1.0, False, False, "an offset between -1 and 1 m"),
    "baumgarte": RangeRule(0.0, 2000.0, False, False,
                           "a gain between 0 and 2000 1/s (the 1 ms RK4 step needs beta h < 2.8)"),
    "any": RangeRule(-math.inf, math.inf, False, False, "a finite number"),
    "alpha": RangeRule(0.0, math.pi / 2, True, True, "an angle strictly between 0 and 90 deg"),
    "gamma": RangeRule(0.0, math.pi, True, True, "an angle strictly between 0 and 180 deg"),
    # small mounting misalignment of a sensor (rotation-vector component)
    "misalignment": RangeRule(-math.pi / 4, math.pi / 4, False, False,
                              "an angle between -45 and 45 deg (a small mounting misalignment)"),
})

# name: (unit, description, rule key of PARAM_RULES)
PARAM_INFO: Mapping[str, tuple[str, str, str]] = MappingProxyType({
    "Mb": ("kg", "body mass including wheels and motors", "mass"),
    "l": ("m", "distance from ball centre to body centre of mass", "length"),
    "Jbx": ("kg.m2", "body inertia about body x", "inertia"),
    "Jby": ("kg.m2", "body inertia about body y", "inertia"),
    "Jbz": ("kg.m2", "body inertia about body z", "inertia"),
    "Jw": ("kg.m2", "inertia of wheel, gear and motor about the motor axis", "wheel_inertia"),
    "rw": ("m", "omni-wheel radius", "length"),
    "rk": ("m", "ball radius", "length"),
    "Mk": ("kg", "ball mass", "mass"),
    "Jk": ("kg.m2", "ball inertia", "inertia"),
    "alpha": ("rad", "wheel zenith angle", "alpha"),
    "gamma": ("rad", "angle between neighbouring wheels", "gamma"),
    "Bvk": ("N.s/m", "viscous friction ball-ground", "friction"),
    "Bvm": ("N.m.s/rad", "viscous friction motor and wheel", "friction"),
    "Bvb": ("N.m.s/rad", "viscous friction body-air", "friction"),
    "tau_max": ("N.m", "maximum wheel torque", "torque"),
    "n_ticks": ("1", "encoder ticks per wheel revolution", "ticks"),
    "g": ("m/s2", "gravitational acceleration", "gravity"),
    "com_x": ("m", "centre-of-mass offset along body x", "offset"),
    "com_y": ("m", "centre-of-mass offset along body y", "offset"),
    "beta": ("1/s", "Baumgarte stabilisation gain", "baumgarte"),
})

PARAM_NAMES: tuple[str, ...] = tuple(PARAM_INFO)

#: Top-level TOML table holding the sensor parameters (read by
#: :func:`ballbot_casadi.core.sensor_params.load_sensor_params`, skipped by :func:`load_params`).
SENSOR_TABLE = "sensors"

_ANGLE_UNITS: Mapping[str, str] = MappingProxyType({
    "deg": "deg", "degree": "deg", "degrees": "deg",
    "rad": "rad", "radian": "rad", "radians": "rad",
})
_ANGLE_RE = re.compile(r"^\s*(\S+?)\s*([A-Za-z]+)\s*$")


def default_params_path() -> Path:
    """Path of the default parameter file shipped with the package."""
    return Path(str(resources.files("ballbot_casadi.core") / "default_params.toml"))


def to_float(label: str, value: Any, unit: str) -> float:
    """Convert one raw parameter value to float.

    Values whose ``unit`` is ``"rad"`` may also be strings ``"<number> <unit>"`` with
    unit ``deg``/``degree``/``degrees`` or ``rad``/``radian``/``radians`` (the space
    is optional: ``"45deg"``); plain numbers are radians.

    Raises
    ------
    BallbotTypeError
        A bool, a non-numeric type, or a string that is not an angle with a unit.
    """
    if isinstance(value, bool):
        raise BallbotTypeError(f"parameter {label!r}: got a bool, expected a real number")
    if isinstance(value, str):
        if unit == "rad":
            m = _ANGLE_RE.match(value)
            kind = _ANGLE_UNITS.get(m.group(2).lower()) if m else None
            if kind is not None:
                try:
                    num = float(m.group(1))
                except ValueError:
                    kind = None
                else:
                    return math.radians(num) if kind == "deg" else num
            raise BallbotTypeError(
                f"parameter {label!r}: got string {value!r}, expected a number in radians or "
                "a string '<value> deg' / '<value> rad' (e.g. \"45 deg\")"
            )
        raise BallbotTypeError(f"parameter {label!r}: got string {value!r}, expected a number")
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    raise BallbotTypeError(
        f"parameter {label!r}: got {type(value).__name__}, expected a real number"
    )


def check_value(label: str, v: float, rule: str, unit: str, raw: Any = None) -> None:
    """Raise :class:`ParameterError` unless ``v`` satisfies ``PARAM_RULES[rule]``.

    ``raw`` is the value as the user gave it; when an angle (``unit == "rad"``) was
    given as a plain number that is out of range, the message says that numbers are
    radians and suggests the degree string.
    """
    r = PARAM_RULES[rule]
    if r.contains(v):
        return
    shown = repr(v)
    if unit == "rad" and math.isfinite(v):
        shown = f"{v!r} rad ({math.degrees(v):g} deg)"
    msg = f"parameter {label!r} = {shown} is invalid: must be {r.text}"
    plain = raw is None or (isinstance(raw, (int, float, np.integer, np.floating))
                            and not isinstance(raw, bool))
    if unit == "rad" and plain and math.isfinite(v):
        msg += "; plain numbers are radians"
        if r.contains(math.radians(v)):
            msg += f": did you mean \"{v:g} deg\"?"
        else:
            msg += ", give degrees as a string such as \"45 deg\""
    raise ParameterError(msg)


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
            raw = getattr(self, f.name)
            unit, _, rule = PARAM_INFO[f.name]
            value = to_float(f.name, raw, unit)
            check_value(f.name, value, rule, unit, raw)
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
        arr = np.asarray(p, dtype=float).ravel()
        if arr.size != len(PARAM_NAMES):
            raise ParameterError(
                f"parameter vector has {arr.size} entries, expected {len(PARAM_NAMES)}"
            )
        return cls(**dict(zip(PARAM_NAMES, arr.tolist())))


def _reject_unknown(values: Mapping[str, Any]) -> None:
    unknown = sorted(set(values) - set(PARAM_NAMES))
    if unknown:
        raise ParameterError(
            f"unknown parameter name(s) {unknown}; allowed names: {', '.join(PARAM_NAMES)} "
            f"(sensor parameters belong in the [{SENSOR_TABLE}] table)"
        )


def flatten_tables(table: Mapping[str, Any], path: str,
                   out: dict[str, Any] | None = None) -> dict[str, Any]:
    """Flatten TOML tables (sections are only for readability); reject duplicates.

    Lists (array values) are kept as values, only tables are descended into.
    """
    out = {} if out is None else out
    for key, value in table.items():
        if isinstance(value, Mapping):
            flatten_tables(value, path, out)
        elif key in out:
            raise ParameterError(f"{path}: parameter {key!r} is given twice")
        else:
            out[key] = value
    return out


def read_param_file(path: str | Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read a parameter TOML file into ``(model_values, sensor_table)``.

    ``model_values`` are the flattened model parameters (every table except
    ``[sensors]``); ``sensor_table`` is the raw ``[sensors]`` table (``{}`` if absent),
    handed to :func:`ballbot_casadi.core.sensor_params.load_sensor_params`.

    Raises
    ------
    ParameterError
        Missing file, invalid TOML, or ``sensors`` that is not a table.
    """
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ParameterError(f"parameter file {str(path)!r} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"parameter file {str(path)!r} is not valid TOML: {exc}") from None
    sensors = data.pop(SENSOR_TABLE, {})
    if not isinstance(sensors, Mapping):
        raise ParameterError(
            f"{path}: {SENSOR_TABLE!r} must be a table ([{SENSOR_TABLE}]), got {sensors!r}"
        )
    return flatten_tables(data, str(path)), dict(sensors)


def _read_toml(path: Path) -> dict[str, Any]:
    values, _ = read_param_file(path)
    _reject_unknown(values)
    return values


def layered_values(
    read: Callable[[Path], dict[str, Any]],
    reject_unknown: Callable[[Mapping[str, Any]], None],
    names: Sequence[str],
    path: str | Path | None,
    overrides: Mapping[str, Any],
    what: str,
) -> dict[str, Any]:
    """The values of a parameter record: packaged defaults, then ``path``, then ``overrides``.

    ``read(file)`` returns a file's (known) values; ``reject_unknown`` refuses unknown
    override names; every name of ``names`` must end up with a value.  Shared by
    :func:`load_params` and :func:`~ballbot_casadi.core.sensor_params.load_sensor_params`.
    """
    values = read(default_params_path())
    if path is not None:
        values.update(read(Path(path)))
    reject_unknown(overrides)
    values.update(overrides)
    missing = sorted(set(names) - set(values))
    if missing:
        raise ParameterError(f"{what} missing from the defaults: {missing}")
    return values


def load_params(path: str | Path | None = None, **overrides: Any) -> Params:
    """Load a parameter set.

    Parameters
    ----------
    path
        TOML file.  It may give any subset of the parameters (in any tables); the rest
        come from the packaged defaults (thesis App. A).  ``None`` loads the defaults.
        A ``[sensors]`` table is not read here (see
        :func:`ballbot_casadi.core.sensor_params.load_sensor_params`).
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
    return Params(**layered_values(_read_toml, _reject_unknown, PARAM_NAMES, path, overrides,
                                   "parameters"))


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
