"""Benchmark group ``montecarlo`` (``ballbot bench --only montecarlo``): Monte Carlo throughput.

Keys
----
``montecarlo_runs_per_s_1w``, ``montecarlo_runs_per_s_2w``
    Runs per second of 32 dispersed runs of the 20 s standing cascade with the COM
    offset (the ``com`` scenario file, 20 s) on a Dask ``LocalCluster`` of 1 and 2 worker
    processes, timed after every worker has built its closed loop (warm-up runs).
``montecarlo_parallel_efficiency``
    ``runs_per_s_2w / (2 runs_per_s_1w)``; target >= 0.8.
``montecarlo_serial_runs_per_s``
    The same runs in this process, without Dask (the overhead reference).
"""

from __future__ import annotations

import time
from importlib import resources
from pathlib import Path

from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.scenario import load_scenario_file, parse_scenario, set_value
from ballbot_casadi.sim.scenario.dispersions import draw_runs
from ballbot_casadi.studies.montecarlo_runner import run_dask, run_serial

__all__ = ["bench_montecarlo"]


def _source(duration: float):
    path = Path(str(resources.files("ballbot_casadi.studies") / "scenarios" / "com.toml"))
    base = load_scenario_file(path)
    return parse_scenario(set_value(dict(base.table), "duration_s", duration), str(path), "com")


def bench_montecarlo(n_runs: int = 32, duration: float = 20.0) -> dict[str, float]:
    """Run the ``montecarlo`` benchmark group (see the module docstring)."""
    from distributed import Client, LocalCluster

    source = _source(duration)
    runs = draw_runs(source, n_runs, seed=1)
    sim = ClosedLoop()
    run_serial(source, runs[:2], sim)  # warm-up: mission Functions of this length
    t0 = time.perf_counter()
    serial = run_serial(source, runs, sim)
    data = {"montecarlo_serial_runs_per_s": n_runs / (time.perf_counter() - t0)}
    for k in (1, 2):
        with LocalCluster(n_workers=k, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            run_dask(source, runs[: 2 * k], client)  # every worker builds its closed loop
            t0 = time.perf_counter()
            res = run_dask(source, runs, client)
            data[f"montecarlo_runs_per_s_{k}w"] = n_runs / (time.perf_counter() - t0)
        if res != serial:
            data["montecarlo_dask_equals_serial"] = 0.0
    data.setdefault("montecarlo_dask_equals_serial", 1.0)
    data["montecarlo_parallel_efficiency"] = (data["montecarlo_runs_per_s_2w"]
                                              / (2 * data["montecarlo_runs_per_s_1w"]))
    data["montecarlo_parallel_efficiency_target"] = 0.8
    data["montecarlo_runs"] = float(n_runs)
    data["montecarlo_run_duration_s"] = float(duration)
    return data
