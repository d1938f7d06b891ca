"""Stand-ins for ``distributed`` futures and clients, for tests of ``wait_all``'s
bookkeeping without a cluster."""

from __future__ import annotations

import itertools
from typing import Any

_KEYS = itertools.count()


class Future:
    """A finished task: ``value``, or the exception ``exc`` (status ``error``); fetching
    either raises ``fetch_error`` when given (the scheduler lost in between)."""

    def __init__(self, key: str | None = None, value: Any = None, exc: BaseException | None = None,
                 status: str | None = None, fetch_error: BaseException | None = None):
        self.key = key if key is not None else f"k{next(_KEYS)}"
        self.value, self.exc, self.fetch_error = value, exc, fetch_error
        self.status = status or ("error" if exc is not None else "finished")

    def result(self) -> Any:
        if self.fetch_error is not None:
            raise self.fetch_error
        return self.value

    def exception(self) -> BaseException:
        if self.fetch_error is not None:
            raise self.fetch_error
        return self.exc if self.exc is not None else ValueError("task failed")


class Client:
    """``scheduler_info()`` reports each of ``workers`` in turn, then the last for ever."""

    def __init__(self, workers: tuple[dict, ...] = ({"w": {}},)):
        self.workers = list(workers)

    def scheduler_info(self) -> dict:
        return {"workers": self.workers.pop(0) if len(self.workers) > 1 else self.workers[0]}
