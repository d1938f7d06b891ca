"""How the benchmark groups set up what they time, with the engines replaced by recorders
(no timing is asserted): the Monte Carlo group's Dask clusters are 1 and 2 single-threaded
worker processes without a dashboard, its statistics come from the clock readings, and
the control group times the compiled closed loop."""

from __future__ import annotations

import pytest

from ballbot_casadi.bench import control as bench_control_mod
from ballbot_casadi.bench import montecarlo as bench_mc


class _Ctx:
    def __init__(self, log, kind, **kw):
        log.append((kind, kw))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


class _Clock:
    """perf_counter readings 0, 1, 2, ...: each timed section takes one second per reading."""

    def __init__(self, steps):
        self.t, self.steps = 0.0, iter(steps)

    def perf_counter(self):
        self.t += next(self.steps, 0.0)
        return self.t


@pytest.mark.parametrize("dask_differs", [False, True])
def test_montecarlo_group_clusters_and_statistics(monkeypatch, dask_differs):
    import distributed

    log = []
    monkeypatch.setattr(distributed, "LocalCluster", lambda **kw: _Ctx(log, "cluster", **kw))
    monkeypatch.setattr(distributed, "Client", lambda cluster: _Ctx(log, "client"))
    monkeypatch.setattr(bench_mc, "ClosedLoop", lambda: "SIM")
    monkeypatch.setattr(bench_mc, "run_serial", lambda source, runs, sim: [r["index"] for r in runs])
    monkeypatch.setattr(bench_mc, "run_dask", lambda source, runs, client: [r["index"] + dask_differs
                                                                             for r in runs])
    # serial: 4 s; one worker: 2 s; two workers: 1.25 s (between the readings of each section)
    monkeypatch.setattr(bench_mc, "time", _Clock([0.0, 4.0, 0.0, 2.0, 0.0, 1.25]))
    data = bench_mc.bench_montecarlo(n_runs=8, duration=0.5)
    clusters = [kw for kind, kw in log if kind == "cluster"]
    assert clusters == [dict(n_workers=k, threads_per_worker=1, processes=True, dashboard_address=None)
                        for k in (1, 2)]
    assert data["montecarlo_serial_runs_per_s"] == 8 / 4.0
    assert data["montecarlo_runs_per_s_1w"] == 8 / 2.0 and data["montecarlo_runs_per_s_2w"] == 8 / 1.25
    assert data["montecarlo_parallel_efficiency"] == pytest.approx((8 / 1.25) / (2 * 8 / 2.0), rel=1e-15)
    assert data["montecarlo_parallel_efficiency_target"] == 0.8
    assert data["montecarlo_dask_equals_serial"] == (0.0 if dask_differs else 1.0)
    assert (data["montecarlo_runs"], data["montecarlo_run_duration_s"]) == (8.0, 0.5)


def test_control_group_times_the_compiled_closed_loop(monkeypatch):
    seen = []

    class Stop(Exception):
        pass

    def closed_loop(**kw):
        seen.append(kw)
        raise Stop

    monkeypatch.setattr(bench_control_mod, "ClosedLoop", closed_loop)
    with pytest.raises(Stop):
        bench_control_mod.bench_control(n_calls=1, repeats=1)
    assert seen == [{"compiled": True}]
