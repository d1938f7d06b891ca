"""Dask clusters that may not answer or may lose their workers: never wait for ever.

* :func:`check_scheduler_address`: a ``--scheduler`` string is ``PROTOCOL://HOST:PORT``
  (one line, exit 2 otherwise), checked before anything runs;
* :func:`connect`: a ``distributed.Client`` to that address within
  :data:`CONNECT_TIMEOUT_S`, whatever answers there (nothing, a server that accepts
  and stays silent, an HTTP server) -- otherwise one line, exit 2;
* :func:`wait_all`: the futures of a run, with progress, failing with
  :class:`~ballbot_casadi.errors.ClusterError` (exit 3) when the cluster has had no
  worker for :data:`LOST_WORKERS_TIMEOUT_S` (lost workers that the nanny did not
  replace), or a task was lost with its workers (``KilledWorker``).
"""

from __future__ import annotations

import re
import threading
import time
from typing import Any, Callable, Sequence

from ballbot_casadi.errors import ArgumentError, ClusterError

__all__ = ["check_scheduler_address", "connect", "wait_all", "CONNECT_TIMEOUT_S",
           "LOST_WORKERS_TIMEOUT_S", "SCHEDULER_PROTOCOLS"]

#: Seconds to wait for a scheduler to answer.
CONNECT_TIMEOUT_S = 20.0
#: Seconds a run may go on with no worker in the cluster before it fails.
LOST_WORKERS_TIMEOUT_S = 60.0
#: Protocols of a ``--scheduler`` address.
SCHEDULER_PROTOCOLS = ("tcp", "tls", "ws", "wss")
_ADDRESS = re.compile(r"^([a-z]+)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9][A-Za-z0-9._-]*):([0-9]{1,5})$")
_POLL_S = 1.0


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


def wait_all(futures: Sequence[Any], client: Any, on_done: Callable[[int], None] | None = None,
             lost_timeout_s: float | None = None) -> None:
    """Wait until every future is finished, calling ``on_done(index)`` as each finishes.

    Raises
    ------
    ClusterError
        The cluster had no worker for ``lost_timeout_s`` (default
        :data:`LOST_WORKERS_TIMEOUT_S`) while runs were pending, or a task was lost with
        its workers; the message says how many tasks had finished.
    """
    from distributed import wait

    lost_timeout_s = LOST_WORKERS_TIMEOUT_S if lost_timeout_s is None else lost_timeout_s
    index = {f.key: i for i, f in enumerate(futures)}
    pending = set(futures)
    no_workers_since: float | None = None
    while pending:
        try:
            done, pending = wait(pending, timeout=_POLL_S, return_when="FIRST_COMPLETED")
        except TimeoutError:
            done = set()
        for f in done:
            if f.status == "error":
                exc = f.exception()
                if type(exc).__name__ == "KilledWorker":
                    raise ClusterError(f"Dask workers died running task {index[f.key]}; "
                                       f"{len(futures) - len(pending) - 1} of {len(futures)} tasks "
                                       "had finished, nothing was written") from None
            if on_done:
                on_done(index[f.key])
        if not pending:
            break
        workers = client.scheduler_info().get("workers", {})
        now = time.monotonic()
        if workers:
            no_workers_since = None
        elif no_workers_since is None:
            no_workers_since = now
        elif now - no_workers_since > lost_timeout_s:
            raise ClusterError(f"the Dask cluster has had no worker for {lost_timeout_s:g} s: "
                               f"{len(futures) - len(pending)} of {len(futures)} tasks had "
                               "finished, nothing was written; rerun (--workers 0 runs serially)")
