"""``run_dask``'s batching read back on a stand-in client (issue 23, test strength): about four
batches per worker, at least one run a batch, the results in run order, the progress counted in
runs, and a lost cluster's finished batches mapped back to run positions."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ballbot_casadi.errors import ClusterError
from ballbot_casadi.studies import montecarlo_runner as R


class _Client:
    def __init__(self, n_workers):
        self.workers = {f"w{i}": {} for i in range(n_workers)}
        self.chunks = None

    def scheduler_info(self):
        return {"workers": self.workers}

    def map(self, fn, chunks, specs, pure):
        assert fn is R.evaluate_batch and pure is False and specs == [{"metric": "m", "op": "<=", "threshold": 1.0}]
        self.chunks = chunks
        return list(chunks)


def _runs(n):
    return [{"table": {"i": i}} for i in range(n)]


SOURCE = SimpleNamespace(specs=[{"metric": "m", "op": "<=", "threshold": 1.0}])


def _in_order(futures, client, on_done, lost_timeout_s, resubmit, cluster):
    assert on_done is None or [on_done(i) for i in range(len(futures))]
    return [[10 * t["i"] for t in chunk] for chunk in futures]


@pytest.mark.parametrize("n_workers, n_runs, sizes", [
    (2, 17, [2] * 8 + [1]),          # 17 // (4 * 2) = 2 runs a batch
    (1, 3, [1, 1, 1]),               # 3 // 4 = 0: still one run a batch
    (0, 9, [2] * 4 + [1]),           # no worker known yet counts as one
])
def test_about_four_batches_per_worker(monkeypatch, n_workers, n_runs, sizes):
    monkeypatch.setattr(R, "wait_all", _in_order)
    client, seen = _Client(n_workers), []
    res = R.run_dask(SOURCE, _runs(n_runs), client, progress=seen.append)
    assert [len(c) for c in client.chunks] == sizes
    assert [t["i"] for c in client.chunks for t in c] == list(range(n_runs))
    assert res == [10 * i for i in range(n_runs)]
    assert seen == sizes


def test_an_explicit_batch_wins(monkeypatch):
    monkeypatch.setattr(R, "wait_all", _in_order)
    client = _Client(2)
    assert R.run_dask(SOURCE, _runs(7), client, batch=3) == [10 * i for i in range(7)]
    assert [len(c) for c in client.chunks] == [3, 3, 1]


def test_a_lost_cluster_names_its_finished_runs_by_position(monkeypatch):
    def lose(futures, *a, **k):
        raise ClusterError("lost the Dask scheduler; 2 of 4 tasks had finished",
                           finished={0: ["a0", "a1"], 2: ["c0", "c1"]})

    monkeypatch.setattr(R, "wait_all", lose)
    with pytest.raises(ClusterError, match=r"^lost the Dask scheduler; 2 of 4 batches \(4 runs\) had finished$") as e:
        R.run_dask(SOURCE, _runs(7), _Client(1), batch=2)
    assert e.value.finished == {0: "a0", 1: "a1", 4: "c0", 5: "c1"}
