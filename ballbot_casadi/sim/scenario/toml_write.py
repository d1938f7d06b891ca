"""Writing scenario tables back to TOML, and changing one dotted key of a table.

:func:`dump_toml` is the inverse of ``tomllib.loads`` for scenario files (a Monte Carlo
run's scenario is written this way, rerunnable alone with ``ballbot simulate``);
:func:`set_value` changes one key such as ``"plant.Mb"`` (``--set`` on the command line,
Monte Carlo draws).
"""

from __future__ import annotations

import copy
import json
import math
from typing import Any, Mapping

from ballbot_casadi.errors import ScenarioFileError
from ballbot_casadi.sim.scenario.sections import (
    CONTROLLER_CHANGES,
    ESTIMATOR_CHANGES,
    PLANT_CHANGES,
    SENSOR_CHANGES,
)

__all__ = ["dump_toml", "set_value"]

#: Tables of parameter changes ({ scale = f } values are written inline).
CHANGE_TABLES = tuple(c.section for c in (PLANT_CHANGES, CONTROLLER_CHANGES, ESTIMATOR_CHANGES,
                                          SENSOR_CHANGES))


def set_value(table: Mapping[str, Any], dotted: str, value: Any) -> dict[str, Any]:
    """Copy of ``table`` with ``dotted`` (e.g. ``"plant.Mb"``, ``"attitude.roll.amplitude_deg"``) set."""
    out = copy.deepcopy(dict(table))
    node = out
    parts = dotted.split(".")
    for p in parts[:-1]:
        nxt = node.get(p)
        if not isinstance(nxt, dict):
            nxt = {}
            node[p] = nxt
        node = nxt
    node[parts[-1]] = value
    return out


# --------------------------------------------------------------------------- writing


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ScenarioFileError(f"cannot write the non-finite number {v!r} to TOML")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(e) for e in v) + "]"
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_key(k)} = {_toml_value(e)}" for k, e in v.items()) + " }"
    raise ScenarioFileError(f"cannot write {type(v).__name__} to TOML")


def _key(k: str) -> str:
    return k if k.replace("_", "").replace("-", "").isalnum() else json.dumps(k)


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(e, Mapping) for e in v)


def _emit(table: Mapping[str, Any], prefix: str, lines: list[str]) -> None:
    scalars = {k: v for k, v in table.items() if not isinstance(v, Mapping) and not _is_table_array(v)}
    for k, v in scalars.items():
        lines.append(f"{_key(k)} = {_toml_value(v)}")
    for k, v in table.items():
        if isinstance(v, Mapping):
            name = f"{prefix}{_key(k)}"
            # a parameter change ({ scale = f }) is written inline
            if prefix.rstrip(".") in CHANGE_TABLES:
                continue
            lines += ["", f"[{name}]"]
            inner = {kk: vv for kk, vv in v.items()}
            if k in CHANGE_TABLES:
                for kk, vv in inner.items():
                    lines.append(f"{_key(kk)} = {_toml_value(vv)}")
            else:
                _emit(inner, f"{name}.", lines)
        elif _is_table_array(v):
            for row in v:
                lines += ["", f"[[{prefix}{_key(k)}]]"]
                _emit(row, f"{prefix}{_key(k)}.", lines)


def dump_toml(table: Mapping[str, Any], header: str = "") -> str:
    """TOML text of a scenario table (inverse of ``tomllib.loads`` for these files)."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    _emit(table, "", lines)
    return "\n".join(lines).lstrip("\n") + "\n"
