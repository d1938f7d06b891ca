"""Monte Carlo runs of a scenario file: dispersions, per-run evaluation, serial or on Dask.

A scenario file's ``[montecarlo]`` table (:mod:`ballbot_casadi.sim.scenario`)
declares the dispersions; a file without one gets :data:`DEFAULT_DISPERSIONS`.  Run
``i`` of a set with seed ``s`` draws from ``numpy.random.default_rng([s, i])``: first its
sensor-noise seed, then one value per dispersion in the declared order.  The drawn
values are written into the run's own scenario table as plain values, so every run is a
complete scenario file of its own (rerunnable alone with ``ballbot simulate``) and its
result depends on nothing but that table: a Dask cluster returns exactly the serial
results.

Each worker builds its :class:`~ballbot_casadi.sim.closed_loop.ClosedLoop` once (kept
on the Dask worker object); ``ClosedLoop()`` compiles the library from its cache key
when the worker's build folder does not have it, so workers need no shared file system.
"""

from __future__ import annotations

import copy
import math
import time
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ballbot_casadi.analysis.cluster import wait_all
from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.core.specs import run_failure, spec_ok
from ballbot_casadi.errors import BallbotError, ScenarioError
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import ScenarioFile, parse_scenario

__all__ = ["DEFAULT_DISPERSIONS", "draw_runs", "evaluate_run", "evaluate_batch", "run_serial", "run_dask",
           "summarize", "dispersions_of"]

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
            if group == "plant":
                nominal = float(getattr(plant, key))
                v = nominal * (1 + draw) if d["relative"] else nominal + draw
                table.setdefault("plant", {})[key] = v
            else:
                nominal = float(table.get("initial", {}).get(key, 0.0))
                v = nominal * (1 + draw) if d["relative"] else nominal + draw
                table.setdefault("initial", {})[key] = v
            values[d["param"]] = v
        runs.append({"index": i, "seed": noise_seed, "values": values, "table": table})
    return runs


def _scalars(m: Mapping[str, Any]) -> dict[str, Any]:
    return {k: (float(v) if isinstance(v, (int, float, np.floating)) and not isinstance(v, bool) else v)
            for k, v in m.items() if isinstance(v, (bool, int, float, np.floating))}


def evaluate_run(table: Mapping[str, Any], specs: Sequence[Mapping[str, Any]],
                 sim: ClosedLoop | None = None) -> dict[str, Any]:
    """Run one scenario table and evaluate ``specs`` on its metrics.

    Returns ``ok`` (every spec met), ``spec_ok`` (per spec), ``metrics`` (scalars) and
    ``error`` (``None``, or why the table could not run).  On a Dask worker the
    :class:`ClosedLoop` is built once and kept on the worker.
    """
    if sim is None:
        sim = _worker_sim()
    try:
        sc = parse_scenario(table, f"run {table.get('name')}").scenario
        log = run_scenario(sc, sim)
    except BallbotError as exc:
        return {"ok": False, "spec_ok": [False] * len(specs), "metrics": {}, "error": str(exc),
                "failure": None}
    with np.errstate(all="ignore"):
        m = _scalars(run_metrics(log))
    oks = [spec_ok(m.get(s["metric"]), s["op"], s["threshold"]) for s in specs]
    failure = run_failure(m)  # a NaN run or a fall fails whatever the specs say
    return {"ok": all(oks) and failure is None, "spec_ok": oks, "metrics": m, "error": None,
            "failure": failure}


def _worker_sim() -> ClosedLoop:
    """The calling Dask worker's ClosedLoop (built on first use), or a new one outside Dask."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        return ClosedLoop()
    sim = getattr(worker, "_ballbot_closed_loop", None)
    if sim is None:
        sim = ClosedLoop()
        worker._ballbot_closed_loop = sim
    return sim


def _specs_or_default(source: ScenarioFile) -> list[dict[str, Any]]:
    if source.specs:
        return [dict(s) for s in source.specs]
    return [{"metric": "finite", "op": "==", "threshold": True, "source": "run completed", "thesis": ""}]


def run_serial(source: ScenarioFile, runs: Sequence[Mapping[str, Any]], sim: ClosedLoop | None = None,
               progress: Callable[[int], None] | None = None) -> list[dict[str, Any]]:
    """Evaluate the runs one after the other in this process."""
    sim = ClosedLoop() if sim is None else sim
    specs = _specs_or_default(source)
    out = []
    for r in runs:
        out.append(evaluate_run(r["table"], specs, sim))
        if progress:
            progress(1)
    return out


def evaluate_batch(tables: Sequence[Mapping[str, Any]], specs: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """:func:`evaluate_run` of several tables in one task (fewer, larger Dask tasks)."""
    sim = _worker_sim()
    return [evaluate_run(t, specs, sim) for t in tables]


def run_dask(source: ScenarioFile, runs: Sequence[Mapping[str, Any]], client: Any,
             progress: Callable[[int], None] | None = None, batch: int | None = None,
             lost_timeout_s: float | None = None) -> list[dict[str, Any]]:
    """Evaluate the runs on a ``distributed.Client`` (results in run order).

    Fails with :class:`~ballbot_casadi.errors.ClusterError` when the cluster has had no
    worker for ``lost_timeout_s`` (:func:`~ballbot_casadi.analysis.cluster.wait_all`).

    Runs go to the workers in batches of ``batch`` (default: about four batches per
    worker, so that scheduling costs little and the load still balances).
    """
    specs = _specs_or_default(source)
    if batch is None:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        batch = max(1, len(runs) // (4 * n_workers))
    chunks = [[r["table"] for r in runs[i:i + batch]] for i in range(0, len(runs), batch)]
    futures = client.map(evaluate_batch, chunks, specs=specs, pure=False)
    # never waits for ever: lost workers (none left) or killed tasks fail with ClusterError
    wait_all(futures, client, (lambda i: progress(len(chunks[i]))) if progress else None,
             lost_timeout_s)
    return [res for part in client.gather(futures) for res in part]


def summarize(source: ScenarioFile, runs: Sequence[Mapping[str, Any]],
              results: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Success rate, per-spec pass rates and metric statistics of a Monte Carlo set."""
    specs = _specs_or_default(source)
    n = len(results)
    ok = [r["ok"] for r in results]
    per_spec = [{**s, "pass_rate": float(np.mean([r["spec_ok"][i] for r in results])) if n else math.nan}
                for i, s in enumerate(specs)]
    keys = sorted({k for r in results for k, v in r["metrics"].items() if not isinstance(v, bool)})
    stats = {}
    for k in keys:
        vals = np.array([r["metrics"].get(k, math.nan) for r in results], float)
        fin = vals[np.isfinite(vals)]
        if fin.size:
            stats[k] = {"mean": float(np.mean(fin)), "std": float(np.std(fin)), "min": float(np.min(fin)),
                        "max": float(np.max(fin)), "p95": float(np.percentile(fin, 95))}
    dispersions, seed = dispersions_of(source)
    return {"n": n, "success_rate": float(np.mean(ok)) if n else math.nan, "n_failed": int(n - sum(ok)),
            "specs": per_spec, "metric_stats": stats, "dispersions": [dict(d) for d in dispersions],
            "seed": seed, "errors": [r["error"] for r in results if r["error"]],
            "failures": [r["failure"] for r in results if r.get("failure")],
            "generated": time.strftime("%Y-%m-%d %H:%M:%S")}
