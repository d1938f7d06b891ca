"""Constants and marks shared by the guided firmware tests (test_firmware_mpc,
test_firmware_split); their fixtures are in conftest.py."""

from __future__ import annotations

from typing import Callable

import pytest

from ballbot_casadi.firmware.toolchain import INSTALL_HINT, missing_tools

#: Periods of the recorded run: 1 s, ten guidance samples.
N = 200
#: Control periods per guidance sample (10 Hz in the 200 Hz period).
EVERY = 20
#: Noise seed of the recorded run.
SEED = 1


def replayed(test: Callable) -> Callable:
    """Marks of a test that replays the recorded mission on a firmware build (host and
    QEMU): firmware, needs_cc, slow, skipped without the Cortex-M toolchain."""
    for mark in (pytest.mark.skipif(bool(missing_tools()), reason=INSTALL_HINT),
                 pytest.mark.slow, pytest.mark.needs_cc, pytest.mark.firmware):
        test = mark(test)
    return test
