"""``record_guided_log``'s default recording is the mission without guidance latency (the
non-split firmware's replay, which the ``firmware_mpc`` bench records with the default);
a split build's latency must be asked for by name."""

from __future__ import annotations

import inspect

from ballbot_casadi.bench import firmware as bench_firmware
from ballbot_casadi.firmware.replay import record_guided_log


def test_the_default_recording_has_no_latency():
    sig = inspect.signature(record_guided_log)
    assert sig.parameters["latency"].default == 0
    assert sig.parameters["guidance"].default == "mpc"
    src = inspect.getsource(bench_firmware)
    assert "rec = record_guided_log(n_periods)\n" in src  # the non-split bench relies on it
