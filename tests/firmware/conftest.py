"""Shared set-up of the guided firmware tests (test_firmware_mpc, test_firmware_split): the
guided figure-eight recorded once per guidance latency from the compiled mission, its
firmware build and the host replay, session-scoped so each is made once per run."""

from __future__ import annotations

from functools import lru_cache

import pytest

from ballbot_casadi.firmware.build import build_firmware
from ballbot_casadi.firmware.replay import record_guided_log, run_host
from ballbot_casadi.firmware.sources import SPLIT_LATENCY

from _guided_support import N, SEED


class GuidedSetup:
    """Per guidance ``latency``: the recorded mission (``rec``: the figure-eight with noise
    and the UKFs, :data:`N` periods, seed :data:`SEED`), the firmware built with the MPC
    (``fw``: the split build for a latency > 0) and its host replay of ``rec`` (``host``)."""

    @lru_cache(maxsize=None)
    def rec(self, latency: int = 0):
        return record_guided_log(N, seed=SEED, latency=latency)

    @lru_cache(maxsize=None)
    def fw(self, latency: int = 0):
        return build_firmware(precision="double", guidance="mpc", latency=latency)

    @lru_cache(maxsize=None)
    def host(self, latency: int = 0):
        return run_host(self.fw(latency), self.rec(latency))


@pytest.fixture(scope="session")
def guided() -> GuidedSetup:
    return GuidedSetup()


@pytest.fixture(scope="session")
def rec(guided):
    """The guided mission without latency (the MPC's result applied in its own period)."""
    return guided.rec(0)


@pytest.fixture(scope="session")
def fw(guided):
    return guided.fw(0)


@pytest.fixture(scope="session")
def host(guided):
    return guided.host(0)


@pytest.fixture(scope="session")
def split_rec(guided):
    """The guided mission with latency SPLIT_LATENCY, which the split build replays."""
    return guided.rec(SPLIT_LATENCY)


@pytest.fixture(scope="session")
def split_fw(guided):
    return guided.fw(SPLIT_LATENCY)


@pytest.fixture(scope="session")
def split_host(guided):
    return guided.host(SPLIT_LATENCY)
