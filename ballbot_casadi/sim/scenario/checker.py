"""Key-by-key checks of a scenario file's table: one message shape ``FILE: key 'a.b': reason``.

Every section of :mod:`ballbot_casadi.sim.scenario.sections` reads its part of a file
through a :class:`FileChecker`, so a wrong type or an impossible value names the file
and the dotted key the same way everywhere.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping

from ballbot_casadi.errors import ScenarioError, ScenarioFileError

__all__ = ["FileChecker"]

_NUM = (int, float)


class FileChecker:
    """Key-by-key validation with messages ``FILE: key 'a.b': reason``."""

    def __init__(self, where: str) -> None:
        self.where = where

    def fail(self, key: str, reason: str) -> ScenarioFileError:
        return ScenarioFileError(f"{self.where}: key '{key}': {reason}")

    def keyed(self, parse: Callable[..., Any], *args: Any) -> Any:
        """``parse(*args)``; its keyed :class:`ScenarioError` becomes a file error."""
        try:
            return parse(*args)
        except ScenarioError as exc:
            raise self.fail(exc.key or "scenario", exc.reason) from None

    def keys(self, table: Any, key: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()) -> dict:
        if not isinstance(table, Mapping):
            raise self.fail(key, f"expected a table, got {type(table).__name__}")
        for k in table:
            if k not in allowed:
                raise self.fail(f"{key}.{k}" if key else k,
                                f"unknown key; allowed here: {', '.join(allowed)}")
        for k in required:
            if k not in table:
                raise self.fail(f"{key}.{k}" if key else k, "missing (required)")
        return dict(table)

    def num(self, table: Mapping, key: str, full: str, default: Any = None, *, lo: float | None = None,
            hi: float | None = None, lo_open: bool = False) -> Any:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, _NUM) or isinstance(v, bool):
            raise self.fail(full, f"expected a number, got {v!r} ({type(v).__name__})")
        if not math.isfinite(v):
            raise self.fail(full, f"must be finite, got {v!r}")
        if lo is not None and (v <= lo if lo_open else v < lo):
            raise self.fail(full, f"must be {'>' if lo_open else '>='} {lo:g}, got {v!r}")
        if hi is not None and v > hi:
            raise self.fail(full, f"must be <= {hi:g}, got {v!r}")
        return float(v)

    def integer(self, table: Mapping, key: str, full: str, default: int, lo: int) -> int:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, int) or isinstance(v, bool) or v < lo:
            raise self.fail(full, f"expected an integer >= {lo}, got {v!r}")
        return int(v)

    def choice(self, table: Mapping, key: str, full: str, default: str, allowed: tuple[str, ...]) -> str:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, str) or v not in allowed:
            raise self.fail(full, f"allowed: {', '.join(allowed)}; got {v!r}")
        return v

    def text(self, table: Mapping, key: str, full: str, default: str = "") -> str:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, str):
            raise self.fail(full, f"expected a string, got {v!r}")
        return v

    def boolean(self, table: Mapping, key: str, full: str, default: bool) -> bool:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, bool):
            raise self.fail(full, f"expected true or false, got {v!r}")
        return v

    def rows(self, table: Mapping, key: str) -> list:
        v = table.get(key, [])
        if not isinstance(v, list) or not all(isinstance(r, Mapping) for r in v):
            raise self.fail(key, f"expected an array of tables ([[{key}]]), got {type(v).__name__}")
        return v

    def vector(self, table: Mapping, key: str, full: str, n: int | None = None) -> tuple[float, ...]:
        v = table.get(key, [])
        if not isinstance(v, list) or any(not isinstance(e, _NUM) or isinstance(e, bool) for e in v):
            raise self.fail(full, f"expected an array of numbers, got {v!r}")
        if n is not None and len(v) != n:
            raise self.fail(full, f"expected {n} numbers, got {len(v)}")
        if not all(math.isfinite(e) for e in v):
            raise self.fail(full, "numbers must be finite")
        return tuple(float(e) for e in v)

    def interval(self, row: Any, key: str, field: str) -> tuple[float, float]:
        """``(t_start_s, t_end_s)`` of a row that also requires ``field``; end after start."""
        self.keys(row, key, ("t_start_s", "t_end_s", field), ("t_start_s", "t_end_s", field))
        t0 = self.num(row, "t_start_s", f"{key}.t_start_s", lo=0.0)
        t1 = self.num(row, "t_end_s", f"{key}.t_end_s")
        if t1 <= t0:
            raise self.fail(f"{key}.t_end_s", f"must be after t_start_s ({t0:g}), got {t1:g}")
        return t0, t1
