"""Monte Carlo dispersions of a scenario file and the runs drawn from them.

A scenario file's ``[montecarlo]`` table declares the dispersions; a file without one
gets :data:`DEFAULT_DISPERSIONS`.  Run ``i`` of a set with seed ``s`` draws from
``numpy.random.default_rng([s, i])``: first its sensor-noise seed, then one value per
dispersion in the declared order.  The drawn values are written into the run's own
scenario table as plain values, so every run is a complete scenario file of its own
(rerunnable alone with ``ballbot simulate``) and its result depends on nothing but that
table.  Running the set is :mod:`ballbot_casadi.studies.montecarlo_runner`.
"""

from __future__ import annotations

import copy
from typing import Any, Mapping

import numpy as np

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario.file import ScenarioFile

__all__ = ["DEFAULT_DISPERSIONS", "dispersions_of", "draw_runs"]

#: Dispersions of a scenario file without a ``[montecarlo]`` table (documented in
#: ``ballbot montecarlo --help``): body mass +-5 % and inertias +-10 % (1 sigma, relative),
#: COM offset 5 mm (1 sigma) in x and y, COM height 1 cm, viscous frictions uniform from 0
#: to a few times a plausible value, initial tilt uniform +-1 deg in roll and pitch; every
#: run also gets its own sensor-noise seed.
DEFAULT_DISPERSIONS: tuple[Mapping[str, Any], ...] = (
    {"param": "plant.Mb", "dist": "normal", "sd": 0.05, "relative": True},
    {"param": "plant.Jbx", "dist": "normal", "sd": 0.10, "relative": True},
    {"param": "plant.Jby", "dist": "normal", "sd": 0.10, "relative": True},
    {"param": "plant.Jbz", "dist": "normal", "sd": 0.10, "relative": True},
    {"param": "plant.com_x", "dist": "normal", "sd": 0.005, "relative": False},
    {"param": "plant.com_y", "dist": "normal", "sd": 0.005, "relative": False},
    {"param": "plant.l", "dist": "normal", "sd": 0.01, "relative": False},
    {"param": "plant.Bvk", "dist": "uniform", "low": 0.0, "high": 0.5, "relative": False},
    {"param": "plant.Bvm", "dist": "uniform", "low": 0.0, "high": 0.005, "relative": False},
    {"param": "plant.Bvb", "dist": "uniform", "low": 0.0, "high": 0.05, "relative": False},
    {"param": "initial.roll_deg", "dist": "uniform", "low": -1.0, "high": 1.0, "relative": False},
    {"param": "initial.pitch_deg", "dist": "uniform", "low": -1.0, "high": 1.0, "relative": False},
)


def dispersions_of(source: ScenarioFile) -> tuple[tuple[Mapping[str, Any], ...], int]:
    """The file's dispersions and Monte Carlo seed (defaults when it declares none)."""
    mc = source.montecarlo
    if mc is None or not mc.get("dispersion"):
        return DEFAULT_DISPERSIONS, int(mc["seed"]) if mc else 0
    return tuple(mc["dispersion"]), int(mc["seed"])


def _draw(rng: np.random.Generator, d: Mapping[str, Any]) -> float:
    if d["dist"] == "normal":
        return float(rng.normal(0.0, d["sd"]))
    return float(rng.uniform(d["low"], d["high"]))


def _draw_course(rng: np.random.Generator, d: Mapping[str, Any], table: dict[str, Any],
                 group: str, key: str) -> dict[str, float]:
    """Random courses: ``path.waypoint_y_m`` moves every interior waypoint of a
    ``waypoints`` path sideways by its own draw; ``obstacle.x_m`` / ``obstacle.y_m`` move
    every ``[[obstacle]]`` row by its own draw (in the order of the rows)."""
    out: dict[str, float] = {}
    if group == "path":
        path = table.get("path", {})
        if path.get("type") != "waypoints":
            raise ScenarioError(f"{d['param']} disperses the waypoints of a [path] of type "
                                "'waypoints'", key="montecarlo.dispersion")
        pts = [list(map(float, p)) for p in path["waypoints"]]
        for j in range(1, len(pts) - 1):
            pts[j][1] += _draw(rng, d)
            out[f"path.waypoints[{j}].y_m"] = pts[j][1]
        path["waypoints"] = pts
        return out
    axis = {"x_m": "x", "y_m": "y"}[key]
    for j, row in enumerate(table.get("obstacle", [])):
        row[axis] = float(row[axis]) + _draw(rng, d)
        out[f"obstacle[{j}].{key}"] = row[axis]
    return out


def _clear_waypoints(table: dict[str, Any], margin: float = 0.05) -> None:
    """Move a drawn obstacle that covers a waypoint (or the start) away from it, radially
    to ``r + margin``: a random course must stay followable (deterministic, no draws)."""
    path = table.get("path", {})
    if path.get("type") != "waypoints":
        return
    init = table.get("initial", {})
    pts = [np.asarray(p, float) for p in path["waypoints"]]
    pts.append(np.array([init.get("x_m", 0.0), init.get("y_m", 0.0)]))
    for row in table.get("obstacle", []):
        c = np.array([row["x"], row["y"]], float)
        for p in pts:
            d = c - p
            n = float(np.linalg.norm(d))
            if n < row["r"] + margin:
                c = p + (d / n if n > 1e-9 else np.array([0.0, 1.0])) * (row["r"] + margin)
        row["x"], row["y"] = (float(v) for v in c)


def draw_runs(source: ScenarioFile, n: int, seed: int | None = None) -> list[dict[str, Any]]:
    """The ``n`` runs of a Monte Carlo set: ``index``, ``seed`` (sensor noise), ``values``
    (``{param: value}``) and ``table`` (the run's complete scenario table)."""
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        raise ScenarioError(f"number of Monte Carlo runs must be an int >= 1, got {n!r}")
    dispersions, file_seed = dispersions_of(source)
    seed = file_seed if seed is None else int(seed)
    base = copy.deepcopy(dict(source.table))
    base.pop("montecarlo", None)
    plant = source.scenario.plant_params()
    name = source.scenario.name
    runs = []
    for i in range(n):
        rng = np.random.default_rng([seed, i])
        noise_seed = int(rng.integers(0, 2**32))
        table = copy.deepcopy(base)
        table["name"] = f"{name}_mc{i:04d}"
        table["seed"] = noise_seed
        table["description"] = (f"Monte Carlo run {i} of {name} (set seed {seed}); "
                                + (source.scenario.description or ""))
        values: dict[str, float] = {}
        for d in dispersions:
            draw = _draw(rng, d)
            group, key = d["param"].split(".", 1)
            if group in ("path", "obstacle"):
                values.update(_draw_course(rng, d, table, group, key))
                continue
            if group == "plant":
                nominal = float(getattr(plant, key))
                v = nominal * (1 + draw) if d["relative"] else nominal + draw
                table.setdefault("plant", {})[key] = v
            else:
                nominal = float(table.get("initial", {}).get(key, 0.0))
                v = nominal * (1 + draw) if d["relative"] else nominal + draw
                table.setdefault("initial", {})[key] = v
            values[d["param"]] = v
        _clear_waypoints(table)
        runs.append({"index": i, "seed": noise_seed, "values": values, "table": table})
    return runs
