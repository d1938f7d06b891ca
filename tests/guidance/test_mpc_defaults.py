"""The MPC's default weights are pinned, and MpcConfig's table documents the same values."""

from __future__ import annotations

import dataclasses
import math
import re

from ballbot_casadi.guidance.mpc import MpcConfig

#: The shipped tuning (guidance/mpc.py, MpcConfig): a change of one is a deliberate
#: retuning and changes this list, the table in MpcConfig's docstring and the studies.
PINNED = {"w_lat": 400.0, "w_lon": 100.0, "w_speed": 20.0, "w_dds": 1.0, "w_dv": 20.0,
          "w_terminal": 2.0, "soft_penalty": 30.0, "obstacle_scale": 10.0,
          "obstacle_relax": 0.1}
#: Units of the Bryson column (an error of 1/sqrt(w) in these costs as much as 1).
UNITS = {"m", "m/s", "m/s^2"}


def _table() -> dict[str, tuple[float, str]]:
    """``field -> (default, 1/sqrt(w) column)`` read from MpcConfig's docstring table."""
    doc = MpcConfig.__doc__
    rule = re.compile(r"^\s*=+(\s+=+){3}\s*$")
    lines = doc.splitlines()
    edges = [i for i, ln in enumerate(lines) if rule.match(ln)]
    assert len(edges) == 3, "MpcConfig's docstring has one simple table (3 rules)"
    rows = {}
    for ln in lines[edges[1] + 1:edges[2]]:
        parts = ln.split()
        rows[parts[0]] = (float(parts[1]), " ".join(parts[-2:]) if parts[-1] != "-" else "-")
    return rows


def test_the_default_weights_are_pinned():
    cfg = MpcConfig()
    got = {k: getattr(cfg, k) for k in PINNED}
    assert got == PINNED
    # every weight-like field of the config is in the pinned list
    weights = {f.name for f in dataclasses.fields(MpcConfig)
               if f.name.startswith(("w_", "obstacle_")) or f.name == "soft_penalty"}
    assert weights == set(PINNED)


def test_the_docstring_table_names_the_same_values():
    table = _table()
    assert set(table) == set(PINNED)
    for name, (value, bryson) in table.items():
        assert value == PINNED[name], name
        if bryson != "-":
            num, unit = bryson.split()
            assert unit in UNITS, (name, unit)
            # the column is 1/sqrt(w), rounded to the printed digits
            digits = len(num.split(".")[1]) if "." in num else 0
            assert abs(float(num) - 1.0 / math.sqrt(value)) <= 0.5 * 10.0 ** -digits, name
