"""Logs of closed-loop runs: named numpy arrays plus the run's metadata, saved as ``.npz``."""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import Params
from ballbot_casadi.errors import BallbotError, FileFormatError

__all__ = ["SimulationLog", "save_log", "load_log", "PATH_KEY", "log_path"]

#: Key of a path run's followed path in the log's ``extra`` metadata: ``{"xy": [[x, y],
#: ...] (the path sampled along its length, m), "obstacles": [[x, y, r], ...] (m)}``.
PATH_KEY = "path"


@dataclass
class SimulationLog:
    """Result of a closed-loop run: named numpy arrays plus the run's metadata.

    Attributes
    ----------
    arrays
        ``time``, ``state``, ``z``, ``tau_cmd``, ``tau``, ``q_ref``, ``dq_ref``,
        ``ddq_ref``, ``v_ref``, ``w``, ``diag`` (see :meth:`ClosedLoop.simulate`).
    scenario
        The scenario as a JSON-compatible dict.
    params, ctrl_params
        Plant and controller internal-model parameter sets.
    diag_names
        Names of the ``diag`` columns.
    """

    arrays: dict[str, np.ndarray]
    scenario: dict[str, Any]
    params: Params
    ctrl_params: Params
    diag_names: tuple[str, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, key: str) -> np.ndarray:
        return self.arrays[key]

    def __contains__(self, key: object) -> bool:
        return key in self.arrays

    def keys(self):
        """Names of the logged arrays."""
        return self.arrays.keys()

    def save(self, path: str | Path) -> Path:
        """Write the log to ``path`` (``.npz``); see :func:`save_log`."""
        return save_log(self, path)


def save_log(log: SimulationLog, path: str | Path) -> Path:
    """Save a log to ``.npz``: the arrays plus parameters and scenario as a JSON string."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    meta = {
        "scenario": log.scenario,
        "params": log.params.as_dict(),
        "ctrl_params": log.ctrl_params.as_dict(),
        "diag_names": list(log.diag_names),
        "state_names": list(STATE.names),
        "extra": log.extra,
    }
    np.savez_compressed(path, **log.arrays, meta_json=np.array(json.dumps(meta)))
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


def load_log(path: str | Path) -> SimulationLog:
    """Load a log written by :func:`save_log`.

    Raises
    ------
    FileFormatError
        The file is not a readable ballbot log: not an npz, damaged, missing entries,
        pickled objects, bad metadata or arrays of the wrong shape (one line, exit 2).
    """
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            if "meta_json" not in data.files:
                raise FileFormatError(f"{path}: not a ballbot simulation log (no meta_json entry)")
            arrays = {k: np.array(data[k]) for k in data.files if k != "meta_json"}
            meta = json.loads(str(data["meta_json"]))
        log = SimulationLog(
            arrays=arrays,
            scenario=meta["scenario"],
            params=Params(**meta["params"]),
            ctrl_params=Params(**meta["ctrl_params"]),
            diag_names=tuple(meta.get("diag_names", ())),
            extra=meta.get("extra", {}),
        )
    except FileFormatError:
        raise
    except (BallbotError, OSError, EOFError, ValueError, KeyError, TypeError, AttributeError,
            zipfile.BadZipFile) as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise FileFormatError(f"{path}: not a readable ballbot simulation log "
                              f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})") from None
    _check_shapes(log, path)
    log_path(log, path)  # a damaged path table is refused here, not when drawing it
    return log


def log_path(log: SimulationLog, source: str | Path = "log") -> tuple[np.ndarray, np.ndarray] | None:
    """The followed path of a path run (:data:`PATH_KEY`): the sampled path ``(n, 2)``
    and the obstacles ``(m, 3)`` as ``x, y, r``; ``None`` for a run without a path.

    Raises
    ------
    FileFormatError
        The metadata is not a path table: not finite, fewer than two points, rows of the
        wrong length, a radius <= 0 (one line naming ``source``).
    """
    meta = log.extra.get(PATH_KEY) if isinstance(log.extra, dict) else None
    if meta is None:
        return None
    try:
        if not isinstance(meta, dict):
            raise ValueError(f"a table expected, got {type(meta).__name__}")
        xy = np.asarray(meta["xy"], dtype=float)
        obs = np.asarray(meta.get("obstacles", []), dtype=float)
        obs = np.zeros((0, 3)) if obs.size == 0 else obs
    except (KeyError, TypeError, ValueError) as exc:
        raise FileFormatError(f"{source}: damaged path metadata ({type(exc).__name__}: "
                              f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    if xy.ndim != 2 or xy.shape[1] != 2 or xy.shape[0] < 2 or obs.ndim != 2 or obs.shape[1] != 3:
        raise FileFormatError(f"{source}: damaged path metadata: xy {xy.shape}, obstacles "
                              f"{obs.shape}; expected (n >= 2, 2) and (m, 3)")
    if not (np.all(np.isfinite(xy)) and np.all(np.isfinite(obs)) and np.all(obs[:, 2] > 0)):
        raise FileFormatError(f"{source}: damaged path metadata: non-finite points or an "
                              "obstacle radius <= 0")
    return xy, obs


def _check_shapes(log: SimulationLog, path: str | Path) -> None:
    """``time`` (N,) and ``state`` (N, 12) with N >= 1, as every log has them."""
    t, x = log.arrays.get("time"), log.arrays.get("state")
    if t is None or x is None:
        raise FileFormatError(f"{path}: not a ballbot simulation log (no time or state array)")
    if t.ndim != 1 or x.ndim != 2 or x.shape != (t.shape[0], STATE.size) or t.shape[0] < 1:
        raise FileFormatError(f"{path}: damaged log: time {t.shape} and state {x.shape}, expected "
                              f"(N,) and (N, {STATE.size}) with N >= 1")
