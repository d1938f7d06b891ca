"""A stand-in for the ``time`` module of a benchmark: ``perf_counter`` and ``thread_time``
advance by the next scripted step (seconds) at each second read (the stop read of a
start/stop pair), from an arbitrary start (an elapsed time is a difference of reads, never
a read)."""

from __future__ import annotations


class Clock:
    def __init__(self, wall, cpu=()):
        self.wall, self.cpu = [float(w) for w in wall], [float(c) for c in cpu]
        self.tw, self.tc = 0.5, 0.25
        self.reads = 0

    def perf_counter(self):
        self.reads += 1
        if self.reads % 2 == 0:  # the stop read of a pair: advance by the next step
            self.tw += self.wall.pop(0) if self.wall else 0.0
        return self.tw

    def thread_time(self):
        if self.reads % 2 == 0:
            self.tc += self.cpu.pop(0) if self.cpu else 0.0
        return self.tc
