"""Where ``execute`` sends a Monte Carlo set (stand-ins for the engines, no cluster):
serially for ``workers == 0``; otherwise a LocalCluster of that many worker *processes*
(one thread each: the compiled libraries and their caches are per process, and a crashing
run must not take the caller down), no dashboard, whose workers the run may replace;
or the scheduler given, connected with its timeout."""

from __future__ import annotations

from contextlib import contextmanager
from types import SimpleNamespace

import distributed
import pytest

from ballbot_casadi.studies import montecarlo_report as MR

SRC = SimpleNamespace(scenario=SimpleNamespace(name="stand_in"))


@pytest.fixture
def engines(monkeypatch):
    seen = {}

    class Cluster:
        def __init__(self, **kw):
            seen["cluster"] = kw

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            seen["cluster_closed"] = True

    class Client:
        def __init__(self, cluster):
            seen["client_of"] = cluster

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return None

    @contextmanager
    def connect(address):
        seen["connect"] = address
        yield "remote-client"

    monkeypatch.setattr(distributed, "LocalCluster", Cluster)
    monkeypatch.setattr(distributed, "Client", Client)
    monkeypatch.setattr(MR, "connect", connect)
    monkeypatch.setattr(MR, "run_serial", lambda src, runs, sim, up: seen.update(serial=(src, sim)) or ["s"])

    def run_dask(src, runs, client, up, cluster=None):
        seen["dask"] = (client, cluster)
        return ["d"]

    monkeypatch.setattr(MR, "run_dask", run_dask)
    return seen


def test_a_local_cluster_of_processes(engines):
    assert MR.execute(SRC, [1, 2, 3], workers=3, quiet=True) == ["d"]
    assert engines["cluster"] == {"n_workers": 3, "threads_per_worker": 1, "processes": True,
                                  "dashboard_address": None}
    client, cluster = engines["dask"]
    assert engines["client_of"] is cluster and client is not None   # its workers may be replaced
    assert engines["cluster_closed"] is True and "serial" not in engines


def test_no_workers_runs_serially(engines):
    assert MR.execute(SRC, [1], workers=0, quiet=True, sim="sim") == ["s"]
    assert engines["serial"] == (SRC, "sim") and "cluster" not in engines


def test_a_scheduler_is_connected_not_started(engines):
    assert MR.execute(SRC, [1], scheduler="tcp://10.0.0.1:8786", workers=0, quiet=True) == ["d"]
    assert engines["connect"] == "tcp://10.0.0.1:8786" and engines["dask"] == ("remote-client", None)
    assert "cluster" not in engines and "serial" not in engines
