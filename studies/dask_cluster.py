"""Dask clusters that may not answer or may lose their workers: never wait for ever.

* :func:`check_scheduler_address`: a ``--scheduler`` string is ``PROTOCOL://HOST:PORT``
  (one line, exit 2 otherwise), checked before anything runs;
* :func:`connect`: a ``distributed.Client`` to that address within
  :data:`CONNECT_TIMEOUT_S`, whatever answers there (nothing, a server that accepts
  and stays silent, an HTTP server) -- otherwise one line, exit 2;
* :func:`wait_all`: the results of a run's futures, with progress.  Lost workers are
  replaced: a killed worker process by its nanny, a closed nanny of our own
  ``LocalCluster`` by :func:`replace_closed_workers` (at most
  :data:`MAX_WORKER_REPLACEMENTS` per run), and a task lost with its workers
  (``KilledWorker``) is resubmitted (at most :data:`MAX_TASK_RESUBMITS` times).  When that
  is impossible -- no worker for :data:`LOST_WORKERS_TIMEOUT_S`, a bound reached, the
  scheduler gone -- it fails with :class:`~ballbot_casadi.errors.ClusterError` (exit 3)
  carrying the results finished so far (``finished``), which the caller saves.
"""

from __future__ import annotations

import logging
import re
import threading
import time
from concurrent.futures import CancelledError
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Sequence

from ballbot_casadi.errors import ArgumentError, ClusterError

__all__ = ["check_scheduler_address", "connect", "wait_all", "replace_closed_workers", "quiet_dask_logs",
           "CONNECT_TIMEOUT_S", "LOST_WORKERS_TIMEOUT_S", "MAX_TASK_RESUBMITS",
           "MAX_WORKER_REPLACEMENTS", "SCHEDULER_PROTOCOLS"]

#: Seconds to wait for a scheduler to answer.
CONNECT_TIMEOUT_S = 20.0
#: Seconds a run may go on with no worker in the cluster before it fails.
LOST_WORKERS_TIMEOUT_S = 60.0
#: Times one task lost with its workers (``KilledWorker``) is submitted again.
MAX_TASK_RESUBMITS = 2
#: Closed workers of a ``LocalCluster`` replaced by new ones in one run.
MAX_WORKER_REPLACEMENTS = 8
#: Protocols of a ``--scheduler`` address.
SCHEDULER_PROTOCOLS = ("tcp", "tls", "ws", "wss")
_ADDRESS = re.compile(r"^([a-z]+)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9][A-Za-z0-9._-]*):([0-9]{1,5})$")
_POLL_S = 1.0


@contextmanager
def quiet_dask_logs() -> Iterator[None]:
    """Silence the ``distributed`` loggers of this process while the block runs: their
    warnings (workers removed, restarted, tasks recomputed) are handled here, and the
    command line reports a failure in one line of its own."""
    names = ["distributed"] + [n for n in logging.root.manager.loggerDict if n.startswith("distributed.")]
    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def check_scheduler_address(address: str) -> str:
    """``address`` if it reads ``PROTOCOL://HOST:PORT`` (protocols
    :data:`SCHEDULER_PROTOCOLS`, port 1..65535).

    Raises
    ------
    ArgumentError
        Saying what the address should look like.
    """
    m = _ADDRESS.match(address) if isinstance(address, str) else None
    if m is None or m.group(1) not in SCHEDULER_PROTOCOLS or not 1 <= int(m.group(3)) <= 65535:
        raise ArgumentError(f"--scheduler {address!r}: expected PROTOCOL://HOST:PORT with protocol "
                            f"{', '.join(SCHEDULER_PROTOCOLS)} and port 1..65535, e.g. "
                            "tcp://127.0.0.1:8786")
    return address


def connect(address: str, timeout_s: float | None = None) -> Any:
    """A ``distributed.Client`` connected to the scheduler at ``address``.

    The client is created in a helper thread that is given ``timeout_s`` (default
    :data:`CONNECT_TIMEOUT_S`) plus a few seconds: a peer that accepts the connection and
    never answers cannot hang the caller.

    Raises
    ------
    ArgumentError
        A malformed address, or nothing at it answered as a Dask scheduler in time.
    """
    from distributed import Client

    check_scheduler_address(address)
    timeout_s = CONNECT_TIMEOUT_S if timeout_s is None else timeout_s
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["client"] = Client(address, timeout=f"{timeout_s}s")
        except BaseException as exc:  # noqa: BLE001 - reported below (MemoryError from HTTP, ...)
            box["error"] = exc

    thread = threading.Thread(target=target, name="ballbot-dask-connect", daemon=True)
    thread.start()
    thread.join(timeout_s + 5.0)
    if "client" in box:
        return box["client"]
    exc = box.get("error")
    why = "no answer" if exc is None else (f"{type(exc).__name__}: {str(exc).splitlines()[0]}"
                                           if str(exc).strip() else type(exc).__name__)
    raise ArgumentError(f"--scheduler {address}: no Dask scheduler answered within {timeout_s:g} s "
                        f"({why}); start one with 'dask scheduler' or leave --scheduler out")


def replace_closed_workers(cluster: Any, budget: int) -> int:
    """Start new workers in place of the closed ones of a ``LocalCluster`` (a worker process
    killed is restarted by its nanny; a nanny that closed is not), at most ``budget``.

    Returns the number of workers started (0 when none was closed, the budget is spent, or
    the cluster cannot be repaired this way).
    """
    workers = getattr(cluster, "workers", None)
    spec = getattr(cluster, "worker_spec", None)
    if budget <= 0 or not isinstance(workers, dict) or not isinstance(spec, dict):
        return 0
    closed = [name for name, w in workers.items()
              if str(getattr(w, "status", "")).rsplit(".", 1)[-1] in ("closed", "closing", "failed")]
    closed = closed[:budget]
    if not closed:
        return 0
    wanted = len(spec)
    for name in closed:
        workers.pop(name, None)
        spec.pop(name, None)
    cluster.scale(wanted)
    return len(closed)


def _lost(message: str, results: dict[int, Any], n: int) -> ClusterError:
    return ClusterError(f"{message}; {len(results)} of {n} tasks had finished", finished=dict(results))


def _fetch(get: Callable[[], Any], results: dict[int, Any], n: int) -> Any:
    """A finished future's result or exception, which is fetched from the scheduler: a
    scheduler lost in between (``ConnectionResetError``, ``CommClosedError``) is the lost
    scheduler's :class:`ClusterError`, not the caller's error."""
    try:
        return get()
    except OSError as exc:
        raise _lost(f"lost the Dask scheduler ({type(exc).__name__})", results, n) from None


def wait_all(futures: Sequence[Any], client: Any, on_done: Callable[[int], None] | None = None,
             lost_timeout_s: float | None = None, resubmit: Callable[[int], Any] | None = None,
             cluster: Any = None) -> list[Any]:
    """The results of ``futures`` (in their order), calling ``on_done(index)`` as each finishes.

    Parameters
    ----------
    resubmit
        ``resubmit(index)`` submits task ``index`` again (a new future); a task lost with
        its workers (``KilledWorker``) is resubmitted up to :data:`MAX_TASK_RESUBMITS`
        times.  Without it such a task stops the run.
    cluster
        Our own ``LocalCluster``: its closed workers are replaced
        (:func:`replace_closed_workers`, :data:`MAX_WORKER_REPLACEMENTS` in all).

    Raises
    ------
    ClusterError
        The cluster had no worker for ``lost_timeout_s`` (default
        :data:`LOST_WORKERS_TIMEOUT_S`) while tasks were pending, a task was lost more
        often than allowed, or the scheduler went away; ``finished`` holds the results
        of the tasks that had finished (by index).  A task that raised is re-raised.
    """
    from distributed import wait

    lost_timeout_s = LOST_WORKERS_TIMEOUT_S if lost_timeout_s is None else lost_timeout_s
    n = len(futures)
    index = {f.key: i for i, f in enumerate(futures)}
    resubmits = [0] * n
    replacements = 0
    results: dict[int, Any] = {}
    pending = set(futures)
    no_workers_since: float | None = None
    while pending:
        try:
            done, pending = wait(pending, timeout=_POLL_S, return_when="FIRST_COMPLETED")
        except TimeoutError:
            done = set()
        except OSError as exc:  # the scheduler went away (CommClosedError, ...)
            raise _lost(f"lost the Dask scheduler ({type(exc).__name__})", results, n) from None
        except CancelledError as exc:  # the client cancels every pending future when it loses the scheduler
            raise _lost(f"lost the Dask scheduler (pending tasks cancelled: {type(exc).__name__})",
                        results, n) from None
        for f in done:
            i = index.pop(f.key)
            if f.status == "cancelled":
                raise _lost(f"the Dask scheduler cancelled task {i} (scheduler lost?)", results, n)
            if f.status == "error":
                exc = _fetch(f.exception, results, n)
                if type(exc).__name__ != "KilledWorker":
                    raise exc  # a bug in the task itself: the caller's internal error
                if resubmit is None or resubmits[i] >= MAX_TASK_RESUBMITS:
                    raise _lost(f"Dask workers died running task {i} "
                                f"({resubmits[i] + 1} submissions)", results, n)
                resubmits[i] += 1
                g = resubmit(i)
                index[g.key] = i
                pending.add(g)
                continue
            results[i] = _fetch(f.result, results, n)
            if on_done:
                on_done(i)
        if not pending:
            break
        if cluster is not None:
            replacements += replace_closed_workers(cluster, MAX_WORKER_REPLACEMENTS - replacements)
        try:
            workers = client.scheduler_info().get("workers", {})
        except OSError as exc:
            raise _lost(f"lost the Dask scheduler ({type(exc).__name__})", results, n) from None
        now = time.monotonic()
        if workers:
            no_workers_since = None
        elif no_workers_since is None:
            no_workers_since = now
        elif now - no_workers_since > lost_timeout_s:
            spent = (f" ({replacements} replaced, at most {MAX_WORKER_REPLACEMENTS})"
                     if cluster is not None else "")
            raise _lost(f"the Dask cluster has had no worker for {lost_timeout_s:g} s{spent}",
                        results, n)
    return [results[i] for i in range(n)]
