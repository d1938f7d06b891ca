"""Lost Dask workers: replaced, or the run stops with what it has saved (issue 23).

* a worker process killed mid-run is restarted by its nanny, a closed worker of our own
  ``LocalCluster`` is replaced: every result arrives, identical to the serial run;
* a task whose worker dies every time it runs it is resubmitted a bounded number of
  times, then the run stops (``ClusterError``) with the other results;
* all workers gone and none may be replaced: ``ballbot montecarlo`` writes the finished
  runs (``montecarlo.json`` marked partial, the missing indices listed), says so in one
  line, exits 3; ``--resume`` then runs only the missing ones and gives the full set.
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time

import pytest

from ballbot_casadi import cli
from ballbot_casadi.errors import ClusterError
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.scenario import load_scenario_file, parse_scenario, set_value
from ballbot_casadi.sim.scenario.dispersions import draw_runs
from ballbot_casadi.studies import dask_cluster
from ballbot_casadi.studies import montecarlo_report
from ballbot_casadi.studies.montecarlo_runner import run_dask, run_serial
from ballbot_casadi.studies.registry import shipped_scenarios
from ballbot_casadi.studies.study import jsonable

N = 6
DURATION = 0.3


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop()


def _source():
    sf = load_scenario_file(shipped_scenarios()["zero"])
    return parse_scenario(set_value(dict(sf.table), "duration_s", DURATION), "short", "zero")


def test_killed_and_closed_workers_are_replaced_and_results_equal_serial(sim):
    from distributed import Client, LocalCluster

    source = _source()
    runs = draw_runs(source, N, 5)
    serial = run_serial(source, runs, sim)
    events: list[str] = []
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as lc, Client(lc) as client:
        pids = client.run(os.getpid)

        def progress(k: int) -> None:
            events.append("done")
            if len(events) == 1:  # SIGKILL one worker process: its nanny restarts it
                os.kill(next(iter(pids.values())), signal.SIGKILL)
                events.append("killed")
            elif len(events) == 3:  # close the other worker with its nanny: we replace it
                name, w = list(lc.workers.items())[-1]
                lc.sync(w.close)
                events.append("closed")

        res = run_dask(source, runs, client, progress, batch=1, lost_timeout_s=60.0, cluster=lc)
        deadline = time.monotonic() + 60.0  # the replacement may still be starting
        while len(client.scheduler_info()["workers"]) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        assert len(client.scheduler_info()["workers"]) == 2  # back to full strength
    assert "killed" in events and "closed" in events
    assert jsonable(res) == jsonable(serial)  # bit for bit, in run order


def _poison(x: int, marker: str) -> int:
    """Kill the worker running it when x is odd; x * x otherwise."""
    if x % 2:
        with open(marker, "a") as f:
            f.write("x")
        os._exit(1)
    return x * x


@pytest.mark.slow  # three worker restarts, ~25 s
def test_a_task_that_kills_its_workers_is_resubmitted_then_stops_the_run_with_the_others(tmp_path):
    import dask
    from distributed import Client, LocalCluster

    marker = tmp_path / "deaths"
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                         dashboard_address=None) as lc, Client(lc) as client:
        # the two good tasks finish first (Dask may otherwise run the poison before them and
        # exhaust its resubmissions while one of them is still pending: a race, not the rule)
        futures = [client.submit(_poison, x, str(marker), pure=False) for x in (0, 2)]
        client.gather(futures)
        futures.append(client.submit(_poison, 1, str(marker), pure=False))
        with pytest.raises(ClusterError, match=r"died running task 2 \(3 submissions\); 2 of 3 tasks") as e:
            dask_cluster.wait_all(
                futures, client, lost_timeout_s=60.0, cluster=lc,
                resubmit=lambda i: client.submit(_poison, (0, 2, 1)[i], str(marker), pure=False))
    assert e.value.finished == {0: 0, 1: 4}
    assert marker.read_text() == "x" * (1 + dask_cluster.MAX_TASK_RESUBMITS)


def test_all_workers_lost_saves_a_partial_set_exit_3_and_resume_completes_it(tmp_path, capsys, monkeypatch, sim):
    monkeypatch.setattr(dask_cluster, "MAX_WORKER_REPLACEMENTS", 0)
    monkeypatch.setattr(dask_cluster, "LOST_WORKERS_TIMEOUT_S", 2.0)
    real_run_dask = montecarlo_report.run_dask
    closed = threading.Event()

    def run_dask_then_lose_all(source, runs, client, progress=None, cluster=None, **kw):
        def progress_and_kill(k):
            progress(k)
            if not closed.is_set():  # after the first finished run every worker goes
                closed.set()
                for w in list(cluster.workers.values()):
                    cluster.sync(w.close)
        return real_run_dask(source, runs, client, progress_and_kill, cluster=cluster, batch=1, **kw)

    monkeypatch.setattr(montecarlo_report, "run_dask", run_dask_then_lose_all)
    scen = tmp_path / "z.toml"
    scen.write_text((shipped_scenarios()["zero"]).read_text())
    out = tmp_path / "mc"
    argv = ["montecarlo", str(scen), "--n", str(N), "--workers", "2", "--quiet", "--seed", "5",
            "--set", f"duration_s={DURATION}", "--min-success", "0", "--out", str(out)]
    assert cli.main(argv) == 3
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("ballbot montecarlo: error:"), err
    assert "no worker for 2 s" in err and "partial" in err and "--resume" in err
    doc = json.loads((out / "montecarlo.json").read_text())
    assert doc["partial"] is True and doc["n_planned"] == N
    done = [r["index"] for r in doc["runs"]]
    assert 1 <= len(done) < N and sorted(done + doc["missing"]) == list(range(N))
    assert f"missing runs {montecarlo_report._ranges(doc['missing'])}" in err
    assert "**partial**" in (out / "report.md").read_text()
    # the finished runs are exactly the serial ones
    source = _source()
    runs = draw_runs(source, N, 5)
    serial = run_serial(source, runs, sim)
    for r in doc["runs"]:
        assert r["metrics"] == jsonable(serial[r["index"]]["metrics"])
    # --resume runs only the missing ones (serially here) and completes the set
    ran: list[int] = []
    real_execute = montecarlo_report.execute

    def counting_execute(source, runs, *a, **kw):
        ran.extend(r["index"] for r in runs)
        return real_execute(source, runs, *a, **kw)

    monkeypatch.setattr(montecarlo_report, "execute", counting_execute)
    argv[argv.index("--workers") + 1] = "0"
    assert cli.main(argv + ["--resume"]) == 0
    assert ran == doc["missing"]
    full = json.loads((out / "montecarlo.json").read_text())
    assert full["partial"] is False and full["missing"] == [] and full["n"] == N
    assert [r["index"] for r in full["runs"]] == list(range(N))
    assert [r["ok"] for r in full["runs"]] == [s["ok"] for s in serial]
    # a different set in the same folder is refused, not mixed in
    assert cli.main(argv[:argv.index("--seed") + 1] + ["6"] + argv[argv.index("--seed") + 2:] + ["--resume"]) == 2
    assert "another Monte Carlo set" in capsys.readouterr().err
