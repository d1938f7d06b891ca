"""Attitude reference signals of a scenario: one schema, one check (with the Nyquist limit).

A signal is a dict ``{"type": ..., key: number}`` with angles in degrees; the scenario file
writes the same signal with units in every key name (``t_step_s``, ``sweep_s``, ...).
:data:`SIGNAL_KEYS` is the single description of both: for each type, its keys, the file
name of each, whether it is required and its lower bound.  :func:`check_signal` validates
a signal (finite numbers, known and required keys, frequencies below the Nyquist frequency
of the control loop: a faster reference is aliased by the sampling, thesis §7.1) and
:func:`make_signal` samples it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim import references as R

__all__ = ["SignalKey", "SIGNAL_KEYS", "SIGNAL_TYPES", "AXES", "check_signal", "make_signal",
           "signal_from_file", "signal_to_file", "check_attitude", "attitude_reference"]

#: Attitude axes a scenario may give a reference for (missing axes are 0).
AXES = ("roll", "pitch", "yaw")


@dataclass(frozen=True)
class SignalKey:
    """One key of a signal type: its name in a :class:`Scenario` signal, in a file, and
    its constraints (``lo``: lower bound, ``open``: strictly above it, ``frequency``: below
    the Nyquist frequency)."""

    name: str
    file: str
    required: bool = False
    lo: float | None = None
    open: bool = False
    frequency: bool = False


_AMP = SignalKey("amplitude_deg", "amplitude_deg", required=True)
_OFFSET = SignalKey("offset_deg", "offset_deg")

#: Keys of each signal type.
SIGNAL_KEYS: Mapping[str, tuple[SignalKey, ...]] = {
    "const": (SignalKey("value_deg", "value_deg"),),
    "sine": (_AMP, SignalKey("frequency_hz", "frequency_hz", True, 0.0, frequency=True),
             SignalKey("phase_rad", "phase_rad"), _OFFSET),
    "step": (_AMP, SignalKey("t_step", "t_step_s", lo=0.0), SignalKey("rise_time", "rise_time_s", lo=0.0),
             _OFFSET),
    "ramp": (_AMP, SignalKey("t_start", "t_start_s", lo=0.0), SignalKey("rate", "rate_deg_s", True, 0.0, open=True),
             _OFFSET),
    "chirp": (_AMP, SignalKey("f0_hz", "f0_hz", True, 0.0, frequency=True),
              SignalKey("f1_hz", "f1_hz", True, 0.0, frequency=True),
              SignalKey("duration", "sweep_s", True, 0.0, open=True), _OFFSET),
}
#: Signal types.
SIGNAL_TYPES = tuple(SIGNAL_KEYS)


def _check_value(k: SignalKey, v: Any, key: str, Ts: float) -> None:
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
        raise ScenarioError(f"{v!r} is not a finite number; references must be finite", key=key)
    if k.lo is not None and (v <= k.lo if k.open else v < k.lo):
        raise ScenarioError(f"must be {'>' if k.open else '>='} {k.lo:g}, got {v!r}", key=key)
    nyquist = 0.5 / Ts
    if k.frequency and v >= nyquist:
        raise ScenarioError(f"{v:g} Hz is not below the Nyquist frequency {nyquist:g} Hz of the "
                            f"{1 / Ts:g} Hz control loop", key=key)


def _check(spec: Any, where: str, Ts: float, file: bool) -> dict[str, Any]:
    """The signal ``spec`` validated, as a :class:`Scenario` signal; ``file``: keys are file names."""
    if not isinstance(spec, Mapping) or spec.get("type") not in SIGNAL_KEYS:
        raise ScenarioError(f"must be a table with 'type' in {SIGNAL_TYPES}, got {spec!r}",
                            key=f"{where}.type" if isinstance(spec, Mapping) else where)
    kind = spec["type"]
    keys = SIGNAL_KEYS[kind]
    names = {(k.file if file else k.name): k for k in keys}
    for key in spec:
        if key != "type" and key not in names:
            raise ScenarioError(f"unknown key ({kind}); allowed here: type, {', '.join(names)}",
                                key=f"{where}.{key}")
    for name, k in names.items():
        if k.required and name not in spec:
            raise ScenarioError(f"missing {name} (required for {kind}); needs "
                                f"{', '.join(n for n, kk in names.items() if kk.required)}",
                                key=f"{where}.{name}")
    out: dict[str, Any] = {"type": kind}
    for name, k in names.items():
        if name in spec:
            _check_value(k, spec[name], f"{where}.{name}", Ts)
            out[k.name] = float(spec[name]) if file else spec[name]
    return out


def check_signal(axis: str, spec: Any, Ts: float) -> None:
    """Validate one :class:`Scenario` attitude signal (raises :class:`ScenarioError`, key
    ``attitude.<axis>[.<key>]``)."""
    _check(spec, f"attitude.{axis}", Ts, file=False)


def signal_from_file(axis: str, table: Any, Ts: float) -> dict[str, Any]:
    """A scenario file's ``[attitude.<axis>]`` table as a validated :class:`Scenario` signal."""
    return _check(table, f"attitude.{axis}", Ts, file=True)


def signal_to_file(spec: Mapping[str, Any]) -> dict[str, Any]:
    """A validated :class:`Scenario` signal as a file's ``[attitude.<axis>]`` table
    (inverse of :func:`signal_from_file`)."""
    names = {k.name: k.file for k in SIGNAL_KEYS[spec["type"]]}
    return {"type": spec["type"], **{names[k]: v for k, v in spec.items() if k != "type"}}


def check_attitude(attitude: Any, Ts: float) -> None:
    """Validate an ``{axis: signal}`` mapping."""
    if not isinstance(attitude, Mapping):
        raise ScenarioError(f"attitude must be a table of axes, got {attitude!r}", key="attitude")
    for axis in attitude:
        if axis not in AXES:
            raise ScenarioError(f"attitude axes [{axis!r}] unknown; allowed roll, pitch, yaw",
                                key=f"attitude.{axis}")
    for axis, spec in attitude.items():
        check_signal(axis, spec, Ts)


def make_signal(spec: Mapping[str, Any], t: np.ndarray) -> R.Signal:
    """Angle signal (rad) from a validated signal with angles in degrees."""
    d = math.radians
    kind = spec["type"]
    if kind == "const":
        v = d(spec.get("value_deg", 0.0))
        return R.Signal(np.full(t.size, v), np.zeros(t.size), np.zeros(t.size))
    if kind == "sine":
        return R.sine(t, d(spec["amplitude_deg"]), spec["frequency_hz"], spec.get("phase_rad", 0.0),
                      d(spec.get("offset_deg", 0.0)))
    if kind == "step":
        return R.step(t, d(spec["amplitude_deg"]), spec.get("t_step", 0.0), spec.get("rise_time", 0.0),
                      d(spec.get("offset_deg", 0.0)))
    if kind == "ramp":
        return R.ramp(t, d(spec["amplitude_deg"]), spec.get("t_start", 0.0), d(spec["rate"]),
                      d(spec.get("offset_deg", 0.0)))
    return R.chirp(t, d(spec["amplitude_deg"]), spec["f0_hz"], spec["f1_hz"], spec["duration"],
                   d(spec.get("offset_deg", 0.0)))


def attitude_reference(attitude: Mapping[str, Any], t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``q, dq, ddq`` (N, 4) of the ``{axis: signal}`` reference at times ``t`` (analytic
    derivatives; missing axes are 0)."""
    sig = {ax: make_signal(attitude.get(ax, {"type": "const"}), t) for ax in AXES}
    return R.rpy_reference(sig["roll"], sig["pitch"], sig["yaw"])
