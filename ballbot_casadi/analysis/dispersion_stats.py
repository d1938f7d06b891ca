"""Statistics of a Monte Carlo set: pure functions of its per-run results.

A result (:func:`ballbot_casadi.studies.montecarlo_runner.evaluate_run`) holds ``ok``,
``spec_ok`` (one per spec), the run's scalar ``metrics`` and ``error``;
:func:`summarize` turns a set of them into the success rate, per-spec pass rates and
metric statistics.  Nothing here runs a simulation.
"""

from __future__ import annotations

import math
import time
from typing import Any, Mapping, Sequence

import numpy as np

from ballbot_casadi.core.specs import specs_or_default
from ballbot_casadi.sim.scenario import ScenarioFile
from ballbot_casadi.sim.scenario.dispersions import dispersions_of

__all__ = ["summarize"]


def summarize(source: ScenarioFile, runs: Sequence[Mapping[str, Any]],
              results: Sequence[Mapping[str, Any]], seed: int | None = None) -> dict[str, Any]:
    """Success rate, per-spec pass rates and metric statistics of a Monte Carlo set.

    ``seed`` is the set seed the runs were drawn with (``None``: the file's, as
    :func:`~ballbot_casadi.sim.scenario.dispersions.draw_runs`)."""
    specs = specs_or_default(source.specs)
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
    dispersions, file_seed = dispersions_of(source)
    seed = file_seed if seed is None else int(seed)
    return {"n": n, "success_rate": float(np.mean(ok)) if n else math.nan, "n_failed": int(n - sum(ok)),
            "specs": per_spec, "metric_stats": stats, "dispersions": [dict(d) for d in dispersions],
            "seed": seed, "errors": [r["error"] for r in results if r["error"]],
            "failures": [r["failure"] for r in results if r.get("failure")],
            "generated": time.strftime("%Y-%m-%d %H:%M:%S")}
