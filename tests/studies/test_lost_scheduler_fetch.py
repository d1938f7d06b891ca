"""A scheduler lost between a task finishing and its result being fetched: fetching the
result (or the task's exception) raises the comm's ``OSError`` (``ConnectionResetError``
in a fresh-clone run), which must become the lost scheduler's ``ClusterError`` with the
finished results (exit 3, partial save), not an error blamed on the user (exit 2).
Stand-in futures and ``distributed.wait``: no cluster, deterministic."""

from __future__ import annotations

import distributed
import pytest
from _dask_standins import Client, Future

from ballbot_casadi.errors import ClusterError
from studies import dask_cluster


def _wait_in_order(pending, timeout=None, return_when=None):
    first = min(pending, key=lambda f: f.key)
    return {first}, set(pending) - {first}


@pytest.mark.parametrize("status", ["finished", "error"])
def test_a_result_that_cannot_be_fetched_is_a_lost_scheduler(monkeypatch, status):
    monkeypatch.setattr(distributed, "wait", _wait_in_order)
    futures = [Future("a", value=10), Future("b", value=11),
               Future("c", status=status, fetch_error=ConnectionResetError(104, "Connection reset by peer")),
               Future("d", value=13)]
    done = []
    with pytest.raises(ClusterError, match=r"^lost the Dask scheduler \(ConnectionResetError\); "
                                           r"2 of 4 tasks had finished$") as e:
        dask_cluster.wait_all(futures, client=Client(), on_done=done.append)
    assert e.value.finished == {0: 10, 1: 11} and done == [0, 1]
    assert e.value.exit_code == 3


def test_a_task_that_raised_is_still_the_callers_error(monkeypatch):
    monkeypatch.setattr(distributed, "wait", _wait_in_order)
    with pytest.raises(ValueError, match="task failed"):
        dask_cluster.wait_all([Future("a", value=1), Future("b", status="error")], client=Client())
