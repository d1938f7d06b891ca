"""An external ``--scheduler`` lost mid-run (issue 23, faults): the run does not hang,
the finished runs are saved (``montecarlo.json`` partial, the missing indices listed), one
line on stderr, exit 3.

The test starts its own scheduler and one worker as separate processes (``python -m
distributed.cli.dask_scheduler`` / ``dask_worker``), lets the first run finish and then
SIGKILLs the scheduler process.  The same through ``wait_all`` with tasks that only sleep
runs in the default suite; the whole command (the worker builds its simulation first) is
``slow``."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from contextlib import contextmanager
from typing import Iterator

import pytest

from ballbot_casadi import cli
from ballbot_casadi.errors import ClusterError
from ballbot_casadi.studies import dask_cluster
from ballbot_casadi.studies import montecarlo_report
from ballbot_casadi.studies.registry import shipped_scenarios

N = 6


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_workers(address: str, n: int, timeout_s: float) -> None:
    from distributed import Client

    with Client(address, timeout="20s") as client:
        client.wait_for_workers(n, timeout=timeout_s)


@contextmanager
def _external_cluster() -> Iterator[tuple[str, subprocess.Popen]]:
    """A scheduler and one single-threaded worker, each its own process group:
    (address, scheduler process).  Both are killed on exit."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    sched = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                              "--port", str(port), "--no-dashboard"], **quiet)
    worker = None
    try:
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:  # the scheduler listens
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
                break
            except OSError:
                time.sleep(0.2)
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                   "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                                   "--death-timeout", "5"], **quiet)
        _wait_for_workers(address, 1, 60.0)
        yield address, sched
    finally:
        for p in (worker, sched):
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            if p is not None:
                p.wait(timeout=10)


def test_wait_all_turns_a_lost_scheduler_into_a_cluster_error_with_the_finished_results():
    """The client cancels every pending future when the scheduler goes (distributed raises
    ``FuturesCancelledError`` from ``wait``): a ClusterError naming the scheduler, with the
    result that had finished, within seconds -- not an internal error, not a hang."""
    from distributed import Client

    with _external_cluster() as (address, sched), Client(address, timeout="20s") as client:
        futures = [client.submit(time.sleep, d, pure=False) for d in (0.05, 30.0, 30.0)]
        killed: list[float] = []

        def kill_after_first(i: int) -> None:
            os.kill(sched.pid, signal.SIGKILL)
            killed.append(time.monotonic())

        with dask_cluster.quiet_dask_logs(), pytest.raises(ClusterError, match=r"lost the Dask scheduler") as e:
            dask_cluster.wait_all(futures, client, kill_after_first, lost_timeout_s=60.0)
        assert time.monotonic() - killed[0] < 30.0  # no hang (the tasks left sleep 30 s each)
    assert e.value.finished == {0: None}
    assert "1 of 3 tasks had finished" in str(e.value)


@pytest.mark.slow  # ~35 s: the external worker builds its ClosedLoop before the first run
def test_a_scheduler_killed_mid_run_saves_the_finished_runs_one_line_exit_3(tmp_path, capsys, monkeypatch):
    with _external_cluster() as (address, sched):
        real_run_dask = montecarlo_report.run_dask
        killed: list[float] = []

        def run_dask_then_kill_scheduler(source, runs, client, progress=None, **kw):
            def progress_and_kill(k):
                progress(k)
                if not killed:  # after the first finished run the scheduler process goes
                    os.kill(sched.pid, signal.SIGKILL)
                    killed.append(time.monotonic())
            return real_run_dask(source, runs, client, progress_and_kill, batch=1, **kw)

        monkeypatch.setattr(montecarlo_report, "run_dask", run_dask_then_kill_scheduler)
        scen = tmp_path / "z.toml"
        scen.write_text(shipped_scenarios()["zero"].read_text())
        out = tmp_path / "mc"
        argv = ["montecarlo", str(scen), "--n", str(N), "--scheduler", address, "--quiet", "--seed", "5",
                "--set", "duration_s=0.3", "--min-success", "0", "--out", str(out)]
        assert cli.main(argv) == 3
        assert killed and time.monotonic() - killed[0] < 60.0  # no hang
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and err.startswith("ballbot montecarlo: error:"), err
        assert "scheduler" in err and "partial" in err and "--resume" in err
        doc = json.loads((out / "montecarlo.json").read_text())
        assert doc["partial"] is True and doc["n_planned"] == N
        done = [r["index"] for r in doc["runs"]]
        assert 1 <= len(done) < N and sorted(done + doc["missing"]) == list(range(N))
