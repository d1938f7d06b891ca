"""``replace_closed_workers`` on a stand-in ``LocalCluster``: only the closed, closing or
failed workers (dask's ``Status.<name>``, or a bare name) are dropped from the workers and
the spec, at most ``budget`` of them in the cluster's order, and the cluster is scaled back
to the spec's size; a worker without a status, a running one, a spent budget or a cluster
it cannot repair is left alone."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

import ballbot_casadi.studies.dask_cluster as DC


class Cluster:
    def __init__(self, statuses):
        self.workers = {f"w{i}": (SimpleNamespace() if s is None else SimpleNamespace(status=s))
                        for i, s in enumerate(statuses)}
        self.worker_spec = {name: {"cls": "Nanny"} for name in self.workers}
        self.scaled = []

    def scale(self, n):
        self.scaled.append(n)


STATUSES = ["Status.running", "Status.closed", None, "closing", "Status.failed", "Status.closing_gracefully"]


@pytest.mark.parametrize("budget, dropped", [(5, ["w1", "w3", "w4"]), (2, ["w1", "w3"]), (1, ["w1"])])
def test_only_closed_workers_are_replaced_within_the_budget(budget, dropped):
    c = Cluster(STATUSES)
    assert DC.replace_closed_workers(c, budget) == len(dropped)
    kept = [n for n in (f"w{i}" for i in range(len(STATUSES))) if n not in dropped]
    assert list(c.workers) == kept and list(c.worker_spec) == kept
    assert c.scaled == [len(STATUSES)]


@pytest.mark.parametrize("cluster, budget", [
    (Cluster(["Status.running", None, "Status.closing_gracefully"]), 3),   # none closed
    (Cluster(["Status.closed"]), 0),                                        # budget spent
    (SimpleNamespace(workers=[], worker_spec={}), 3),                       # not a LocalCluster
    (SimpleNamespace(workers={"w0": SimpleNamespace(status="closed")}), 3),  # no spec
])
def test_nothing_is_done_when_nothing_can_be(cluster, budget):
    before = (dict(getattr(cluster, "workers", {}) or {}) if isinstance(cluster.workers, dict) else None)
    assert DC.replace_closed_workers(cluster, budget) == 0
    if before is not None:
        assert dict(cluster.workers) == before
    assert getattr(cluster, "scaled", []) == []
