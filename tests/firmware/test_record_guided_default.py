"""``record_guided_log``'s default recording is the mission without guidance latency (the
non-split firmware's replay, which the ``firmware_mpc`` bench records with the default);
a split build's latency must be asked for by name."""

from __future__ import annotations

import inspect

from ballbot_casadi.bench import firmware as bench_firmware
from ballbot_casadi.firmware.replay import record_guided_log
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR


def test_the_default_recording_has_no_latency():
    sig = inspect.signature(record_guided_log)
    assert sig.parameters["latency"].default == 0
    assert sig.parameters["guidance"].default == "mpc"
    # two seconds of the figure-eight at 5 ms (20 guidance samples at 10 Hz), seed 1, the shipped filters
    assert (sig.parameters["n_periods"].default, sig.parameters["seed"].default) == (400, 1)
    assert sig.parameters["path"].default is None
    assert sig.parameters["estimator"].default == DEFAULT_ESTIMATOR
    src = inspect.getsource(bench_firmware)
    assert "rec = record_guided_log(n_periods)\n" in src  # the non-split bench relies on it
