"""The register of behaviour-setting numbers: every number (or flag, or tuple or table of
numbers) a module of the package or the studies defines at top level or a class defines
as an attribute, and every number or flag a function or method takes by default, read back generically and compared with the
reviewed register ``constants_register.json``.

Tolerances, tunings, sizes, limits and defaults set what the code does as much as its
logic does; most have their own behaviour tests, and this register catches the rest: an
edit to any of them (a slipped digit, a flipped default) shows as a failing test and, when
made on purpose, as a reviewed diff of the register (re-pin with
``BALLBOT_PIN_CONSTANTS=1``).  A new constant or default must be registered the same way."""

from __future__ import annotations

import importlib
import inspect
import json
import math
import numbers
import os
import pkgutil
import re
from collections.abc import Mapping
from pathlib import Path

REGISTER = Path(__file__).parent / "constants_register.json"
PACKAGES = ("ballbot_casadi", "ballbot_casadi.studies")
#: the other names of an unpacking assignment (``A, B = 1.0, 2.0``) before and after one
_BEFORE, _AFTER = r"(?:[A-Za-z_]\w*\s*,\s*)*", r"(?:\s*,\s*[A-Za-z_]\w*)*\s*"


def _numeric(v) -> bool:
    if isinstance(v, (bool, numbers.Number)):
        return True
    if isinstance(v, (tuple, list)) and v:
        return all(_numeric(x) for x in v)
    if isinstance(v, Mapping) and v:
        return all(isinstance(k, str) for k in v) and all(_numeric(x) for x in v.values())
    return False


def _plain(v):
    """A JSON form that keeps the type and every bit (floats by ``repr``)."""
    if isinstance(v, bool):
        return v
    if isinstance(v, numbers.Integral):
        return int(v)
    if isinstance(v, numbers.Real):
        f = float(v)
        return repr(f) if math.isfinite(f) else str(f)
    if isinstance(v, numbers.Complex):
        return repr(complex(v))
    if isinstance(v, Mapping):
        return {k: _plain(x) for k, x in v.items()}
    return [_plain(x) for x in v]


def _modules() -> list[str]:
    names = []
    for pkg_name in PACKAGES:
        pkg = importlib.import_module(pkg_name)
        names += [pkg_name, *(m.name for m in pkgutil.walk_packages(pkg.__path__, pkg_name + ".")
                              if not m.name.endswith("__main__"))]
    return sorted(set(names))


def register() -> dict:
    out: dict = {}
    for name in _modules():
        mod = importlib.import_module(name)
        src = Path(mod.__file__).read_text(encoding="utf-8")
        for key, v in vars(mod).items():
            if key.startswith("__"):
                continue
            funcs = []
            if inspect.isfunction(v) and v.__module__ == name:
                funcs = [(key, v)]
            elif inspect.isclass(v) and v.__module__ == name:
                funcs = [(f"{key}.{a}", getattr(f, "__func__", f)) for a, f in vars(v).items()
                         if inspect.isfunction(getattr(f, "__func__", f))]  # static and class methods too
                fields = getattr(v, "__dataclass_fields__", {})  # their defaults: in __init__
                out.update({f"{name}:{key}.{a}": _plain(c) for a, c in vars(v).items()
                            if not a.startswith(("__", "_is_")) and a not in fields  # typing's flags
                            and _numeric(c)})
            elif _numeric(v) and re.search(rf"^{_BEFORE}{re.escape(key)}{_AFTER}(:[^=\n]*)?=(?!=)",
                                           src, re.M):
                out[f"{name}:{key}"] = _plain(v)  # defined here (alone or unpacked), not imported
            for qual, f in funcs:
                try:
                    params = inspect.signature(f).parameters.values()
                except (TypeError, ValueError):
                    continue
                d = {p.name: _plain(p.default) for p in params
                     if p.default is not inspect.Parameter.empty and _numeric(p.default)}
                if d:
                    out[f"{name}:{qual}()"] = d
    return out


def test_the_behaviour_setting_numbers_are_the_registered_ones():
    got = register()
    if os.environ.get("BALLBOT_PIN_CONSTANTS") == "1":
        REGISTER.write_text(json.dumps(got, indent=1, sort_keys=True, ensure_ascii=False) + "\n",
                            encoding="utf-8")
    want = json.loads(REGISTER.read_text(encoding="utf-8"))
    assert sorted(set(got) - set(want)) == [], "not registered (re-pin with BALLBOT_PIN_CONSTANTS=1)"
    assert sorted(set(want) - set(got)) == [], "registered but gone"
    changed = {k: (want[k], got[k]) for k in want if got[k] != want[k]}
    assert changed == {}, "changed (registered, now)"


def test_the_register_reads_what_it_claims():
    reg = json.loads(REGISTER.read_text(encoding="utf-8"))
    # a module constant, a tuple, a table, a function default, a dataclass field default
    assert reg["ballbot_casadi.core.validation:QUAT_TOL"] == "1e-06"
    assert reg["ballbot_casadi.analysis.heading:HEADING_CHUNK"] == 2000
    assert reg["ballbot_casadi.bench:BENCH_TAU"] == ["0.2", "-0.1", "0.3"]
    assert reg["ballbot_casadi.bench.control:bench_control()"] == {"n_calls": 100000, "repeats": 3}
    # both names of an unpacking assignment (the FLC's tilt and yaw weights)
    assert (reg["ballbot_casadi.control.flc:_W_TILT"], reg["ballbot_casadi.control.flc:_W_YAW"]) == (
        "10.0", "5.0")
    assert not any(k.endswith(":TS_CONTROL") and not k.startswith("ballbot_casadi.core.constants:")
                   for k in reg)  # imported names are not registered twice
