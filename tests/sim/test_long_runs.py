"""Long runs: segmented missions equal one call bit for bit; decimated logs keep every m-th row."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.studies.registry import study_scenarios


@pytest.fixture(scope="module")
def sim() -> ClosedLoop:
    return ClosedLoop(compiled=True)


@pytest.mark.parametrize("estimator", ["true", "ukf"])
def test_segments_equal_one_call(sim, estimator):
    sc = study_scenarios("velocity", "flc")[-1].replace(duration=6.0, estimator=estimator, seed=3,
                                                        pushes=((2.5, 1.0, 0.0, 0.0),))
    one = run_scenario(sc, sim)
    seg = run_scenario(sc, sim, segment_periods=317)  # segment edges not aligned with anything
    assert set(seg.keys()) == set(one.keys())
    for key in one.keys():
        np.testing.assert_array_equal(seg[key], one[key], err_msg=key)


def test_decimated_log_keeps_every_mth_period_and_the_final_state(sim):
    sc = study_scenarios("sine", "flc")[0].replace(duration=3.0, estimator="ukf", seed=1)
    full = run_scenario(sc, sim)
    dec = run_scenario(sc, sim, log_every=10, segment_periods=250)
    n = sc.n_periods
    np.testing.assert_array_equal(dec["state"][:-1], full["state"][:n:10])
    np.testing.assert_array_equal(dec["state"][-1], full["state"][-1])
    np.testing.assert_array_equal(dec["tau"], full["tau"][::10])
    np.testing.assert_array_equal(dec["x_hat"], full["x_hat"][::10])
    np.testing.assert_allclose(dec["time"][:-1], full["time"][:n:10], rtol=0, atol=1e-12)
    assert dec["time"][-1] == pytest.approx(3.0) and dec.extra["log_every"] == 10
    # the log shrinks by the decimation factor
    assert dec["state"].nbytes < full["state"].nbytes / 9


def test_bad_log_options(sim):
    sc = study_scenarios("zero", "flc")[0].replace(duration=0.1)
    for kw in ({"log_every": 0}, {"segment_periods": -3}, {"log_every": 1.5}):
        with pytest.raises(ScenarioError, match="int >= 1"):
            run_scenario(sc, sim, **kw)


def test_decimation_counts_periods_from_the_run_start_across_unaligned_segments(sim):
    """Segments of 12 periods and every 7th period kept: the kept periods are 0, 7, 14, ...
    of the whole run (the count carries over the segment edges 12, 24, ..., which are not
    multiples of 7), so the log equals the one-call log decimated."""
    sc = study_scenarios("sine", "flc")[0].replace(duration=0.5)
    full = run_scenario(sc, sim)
    dec = run_scenario(sc, sim, log_every=7, segment_periods=12)
    n = sc.n_periods
    assert n == 100 and dec["state"].shape[0] == len(range(0, n, 7)) + 1 == 16
    np.testing.assert_array_equal(dec["state"][:-1], full["state"][:n:7])
    np.testing.assert_array_equal(dec["state"][-1], full["state"][-1])
    np.testing.assert_array_equal(dec["tau"], full["tau"][::7])
    np.testing.assert_allclose(dec["time"], [*(0.005 * k for k in range(0, n, 7)), 0.5], rtol=0, atol=1e-12)
