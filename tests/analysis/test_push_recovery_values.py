"""Push recovery at the end of a log (issue 23, a fresh-batch survivor): a tilt outside
the band at the second-to-last sample recovers at the last one; outside at the last
sample never recovers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballbot_casadi.analysis.metrics import push_metrics


def _log(tilts_deg):
    n = len(tilts_deg)
    x = np.zeros((n, 12))
    half = np.radians(np.asarray(tilts_deg, float)) / 2
    x[:, 2], x[:, 3] = np.cos(half), np.sin(half)
    return {"time": 0.01 * np.arange(n), "state": x}


def test_outside_at_the_second_to_last_sample_recovers_at_the_last():
    m = push_metrics(_log([0.0, 0.0, 2.0, 0.5, 0.05]), t_push=0.01, band_deg=0.1)
    assert m["recovery_time_s"] == pytest.approx(0.04 - 0.01, abs=1e-15)
    assert m["push_max_tilt_deg"] == pytest.approx(2.0, rel=1e-12)


def test_outside_at_the_last_sample_never_recovers():
    assert push_metrics(_log([0.0, 2.0, 0.05, 0.5]), t_push=0.01)["recovery_time_s"] == math.inf
    assert push_metrics(_log([0.0, 0.05, 0.05, 0.05]), t_push=0.01)["recovery_time_s"] == 0.0
