"""Running a Monte Carlo set: each run simulated and evaluated, serially or on Dask.

The runs are drawn by :func:`ballbot_casadi.sim.scenario.dispersions.draw_runs`: every
run is a complete scenario table whose result depends on nothing but that table, so a
Dask cluster returns exactly the serial results.  The statistics of a set are
:func:`ballbot_casadi.analysis.dispersion_stats.summarize` (pure functions of the
results); the study around it (report, plots, worst runs) is
:mod:`ballbot_casadi.studies.montecarlo_report`.

Each worker builds its :class:`~ballbot_casadi.sim.closed_loop.ClosedLoop` once (kept
on the Dask worker object); ``ClosedLoop()`` compiles the library from its cache key
when the worker's build folder does not have it, so workers need no shared file system.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.core.specs import run_failure, spec_ok, specs_or_default
from ballbot_casadi.errors import BallbotError, ClusterError
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.guided import run_path_scenario
from ballbot_casadi.sim.scenario import ScenarioFile, parse_scenario
from ballbot_casadi.studies.dask_cluster import wait_all

__all__ = ["evaluate_run", "evaluate_batch", "run_serial", "run_dask"]


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
        log = run_path_scenario(sc) if sc.path else run_scenario(sc, sim)
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


def run_serial(source: ScenarioFile, runs: Sequence[Mapping[str, Any]], sim: ClosedLoop | None = None,
               progress: Callable[[int], None] | None = None) -> list[dict[str, Any]]:
    """Evaluate the runs one after the other in this process."""
    sim = ClosedLoop() if sim is None else sim
    specs = specs_or_default(source.specs)
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
             lost_timeout_s: float | None = None, cluster: Any = None) -> list[dict[str, Any]]:
    """Evaluate the runs on a ``distributed.Client`` (results in run order).

    Lost workers are replaced and lost tasks resubmitted
    (:func:`~ballbot_casadi.studies.dask_cluster.wait_all`; ``cluster`` is our own
    ``LocalCluster``, whose closed workers are replaced).  When that is impossible it fails
    with :class:`~ballbot_casadi.errors.ClusterError` whose ``finished`` maps the position
    of each run that had finished (in ``runs``) to its result.

    Runs go to the workers in batches of ``batch`` (default: about four batches per
    worker, so that scheduling costs little and the load still balances).
    """
    specs = specs_or_default(source.specs)
    if batch is None:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        batch = max(1, len(runs) // (4 * n_workers))
    chunks = [[r["table"] for r in runs[i:i + batch]] for i in range(0, len(runs), batch)]
    futures = client.map(evaluate_batch, chunks, specs=specs, pure=False)
    try:
        parts = wait_all(futures, client, (lambda i: progress(len(chunks[i]))) if progress else None,
                         lost_timeout_s,
                         resubmit=lambda i: client.submit(evaluate_batch, chunks[i], specs=specs, pure=False),
                         cluster=cluster)
    except ClusterError as exc:
        finished = {i * batch + k: res for i, part in (exc.finished or {}).items()
                    for k, res in enumerate(part)}
        raise ClusterError(str(exc).replace("tasks had finished", f"batches ({len(finished)} runs) "
                                            "had finished"), finished=finished) from None
    return [res for part in parts for res in part]
