"""A scheduler lost between a task finishing and its result being fetched: fetching the
result (or the task's exception) raises the comm's ``OSError`` (``ConnectionResetError``
in a fresh-clone run), which must become the lost scheduler's ``ClusterError`` with the
finished results (exit 3, partial save), not an error blamed on the user (exit 2).
Stand-in futures and ``distributed.wait``: no cluster, deterministic."""

from __future__ import annotations

import distributed
import pytest

from ballbot_casadi.errors import ClusterError
from studies import dask_cluster


class _Future:
    def __init__(self, key, status="finished", value=None, fail=None):
        self.key, self.status, self._value, self._fail = key, status, value, fail

    def result(self):
        if self._fail:
            raise self._fail
        return self._value

    def exception(self):
        if self._fail:
            raise self._fail
        return ValueError("task failed")


class _Client:
    def scheduler_info(self):
        return {"workers": {"w": {}}}


def _wait_in_order(pending, timeout=None, return_when=None):
    first = min(pending, key=lambda f: f.key)
    return {first}, set(pending) - {first}


@pytest.mark.parametrize("status", ["finished", "error"])
def test_a_result_that_cannot_be_fetched_is_a_lost_scheduler(monkeypatch, status):
    monkeypatch.setattr(distributed, "wait", _wait_in_order)
    futures = [_Future("a", value=10), _Future("b", value=11),
               _Future("c", status=status, fail=ConnectionResetError(104, "Connection reset by peer")),
               _Future("d", value=13)]
    done = []
    with pytest.raises(ClusterError, match=r"^lost the Dask scheduler \(ConnectionResetError\); "
                                           r"2 of 4 tasks had finished$") as e:
        dask_cluster.wait_all(futures, client=_Client(), on_done=done.append)
    assert e.value.finished == {0: 10, 1: 11} and done == [0, 1]
    assert e.value.exit_code == 3


def test_a_task_that_raised_is_still_the_callers_error(monkeypatch):
    monkeypatch.setattr(distributed, "wait", _wait_in_order)
    with pytest.raises(ValueError, match="task failed"):
        dask_cluster.wait_all([_Future("a", value=1), _Future("b", status="error")], client=_Client())
