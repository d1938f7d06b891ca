"""wait_all's bookkeeping on stand-in futures (no cluster): results in submission order
whatever order they finish in, progress per task, a task lost with its workers resubmitted
at most MAX_TASK_RESUBMITS times and then the run stopped with what had finished, a task's
own error re-raised, a cancelled task or a lost scheduler reported as a lost cluster, and
a cluster without workers for longer than the timeout stopped (by the clock, not a
count of polls)."""

from __future__ import annotations

from concurrent.futures import CancelledError

import distributed
import pytest
from _dask_standins import Client, Future

import ballbot_casadi.studies.dask_cluster as DC
from ballbot_casadi.errors import ClusterError


class KilledWorker(Exception):  # matched by name, as distributed's own
    pass


@pytest.fixture
def waits(monkeypatch):
    """``distributed.wait`` finishing one future per call, in the order of ``plan``."""
    plan: list = []
    polls = []

    def wait(pending, timeout, return_when):
        polls.append(1)
        if len(polls) > 50:   # a stand-in run is a few polls: more is a hang
            pytest.fail("wait_all kept polling after the planned futures")
        step = plan.pop(0) if plan else None
        if isinstance(step, BaseException):
            raise step
        if step is None:
            raise TimeoutError
        return {step}, set(pending) - {step}

    monkeypatch.setattr(distributed, "wait", wait)
    return plan


def test_results_in_submission_order_with_progress(waits):
    a, b, c = Future(value=1), Future(value=2), Future(value=3)
    waits += [c, a, None, b]             # finish out of order, one empty poll between
    done = []
    assert DC.wait_all([a, b, c], Client(), on_done=done.append) == [1, 2, 3]
    assert done == [2, 0, 1]


def test_a_lost_task_is_resubmitted_then_the_run_stops_with_the_finished(waits):
    a, b = Future(value="a"), Future(exc=KilledWorker())
    again = [Future(exc=KilledWorker()) for _ in range(DC.MAX_TASK_RESUBMITS)]
    waits += [a, b, *again]
    asked = []

    def resubmit(i):
        asked.append(i)
        return again[len(asked) - 1]

    with pytest.raises(ClusterError, match=rf"^Dask workers died running task 1 \({DC.MAX_TASK_RESUBMITS + 1} "
                                           r"submissions\); 1 of 2 tasks had finished$") as exc:
        DC.wait_all([a, b], Client(), resubmit=resubmit)
    assert asked == [1] * DC.MAX_TASK_RESUBMITS and exc.value.finished == {0: "a"}


def test_a_resubmitted_task_that_finishes_counts(waits):
    a, b, b2 = Future(exc=KilledWorker()), Future(value=7), Future(value=5)
    waits += [a, b, b2]
    assert DC.wait_all([a, b], Client(), resubmit=lambda i: b2) == [5, 7]


def test_without_resubmit_a_lost_task_stops_the_run(waits):
    a = Future(exc=KilledWorker())
    waits += [a]
    with pytest.raises(ClusterError, match=r"^Dask workers died running task 0 \(1 submissions\); "
                                           r"0 of 1 tasks had finished$"):
        DC.wait_all([a], Client())


@pytest.mark.parametrize("error", [ZeroDivisionError("in the task"), RuntimeError("in the task")])
def test_a_tasks_own_error_is_raised_as_is(waits, error):
    a = Future(exc=error)
    waits += [a]
    asked = []
    with pytest.raises(type(error), match="in the task"):
        DC.wait_all([a], Client(), resubmit=lambda i: asked.append(i) or Future(value=0))
    assert asked == []   # not resubmitted: only a task lost with its workers is


@pytest.mark.parametrize("step, message", [
    ("cancel", r"^the Dask scheduler cancelled task 1 \(scheduler lost\?\); 1 of 2 tasks had finished$"),
    (ConnectionResetError(), r"^lost the Dask scheduler \(ConnectionResetError\); 1 of 2 tasks had finished$"),
    (CancelledError(), r"^lost the Dask scheduler \(pending tasks cancelled: CancelledError\); 1 of 2 "
                       r"tasks had finished$"),
])
def test_a_lost_scheduler_stops_the_run_with_the_finished(waits, step, message):
    a, b = Future(value=1), Future(value=2, status="cancelled" if step == "cancel" else None)
    waits += [a, b if step == "cancel" else step]
    with pytest.raises(ClusterError, match=message) as exc:
        DC.wait_all([a, b], Client())
    assert exc.value.finished == {0: 1}


def test_no_worker_for_longer_than_the_timeout(waits, monkeypatch):
    clock = iter([0.0, 5.0, 10.0, 10.5, 20.0, 30.0, 30.5, 100.0])
    monkeypatch.setattr(DC.time, "monotonic", lambda: next(clock))
    a = Future(value=1)
    # a worker is back at 10 s, so the count restarts at 10.5 s: exactly 20 s at 30.5 s is
    # not yet more than 20 s, 89.5 s at 100 s is
    client = Client([{}, {}, {"w": 1}, {}, {}, {}])
    with pytest.raises(ClusterError, match=r"^the Dask cluster has had no worker for 20 s; 0 of 1 tasks "
                                           r"had finished$"):
        DC.wait_all([a], client, lost_timeout_s=20.0)
    assert list(clock) == []   # it stopped at the last poll, not before


def test_worker_replacements_share_one_budget_per_run(waits, monkeypatch):
    """With a LocalCluster each poll replaces closed workers from what is left of
    MAX_WORKER_REPLACEMENTS: 8 at first, then 8 minus those replaced so far; a cluster
    that stays without workers names the count in its message."""
    budgets = []
    replaced = iter([3, 0, 5, 0, 0, 0])
    monkeypatch.setattr(DC, "replace_closed_workers", lambda cluster, budget: budgets.append(budget)
                        or next(replaced))
    clock = iter([0.0, 1.0, 2.0, 3.0, 50.0])
    monkeypatch.setattr(DC.time, "monotonic", lambda: next(clock))
    a = Future(value=1)
    with pytest.raises(ClusterError, match=r"^the Dask cluster has had no worker for 20 s "
                                           r"\(8 replaced, at most 8\); 0 of 1 tasks had finished$"):
        DC.wait_all([a], Client([{}]), cluster=object(), lost_timeout_s=20.0)
    assert DC.MAX_WORKER_REPLACEMENTS == 8
    assert budgets == [8, 5, 5, 0, 0]
