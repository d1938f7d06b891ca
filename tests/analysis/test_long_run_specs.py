"""Long runs: the shipped quaternion-norm spec scales with the run length.

The estimate's norm error grows ~6e-12 per simulated hour (measured over 10 h with the
UKFs); a fixed ``quat_norm_max_dev <= 1e-12`` failed within the first hour of a soak.
"""

from __future__ import annotations

import pytest

from ballbot_casadi.analysis.estimates import QUAT_NORM_MIN_HOURS, quat_norm_dev_per_hour
from ballbot_casadi.core.specs import Spec, evaluate_specs
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import shipped_scenarios


def test_per_hour_rate_by_hand():
    assert quat_norm_dev_per_hour(6e-11, 36000.0) == pytest.approx(6e-12, rel=1e-12)
    assert quat_norm_dev_per_hour(3e-12, 1800.0) == pytest.approx(6e-12, rel=1e-12)
    # a short run counts as one minute: its rounding floor is not a drift
    assert quat_norm_dev_per_hour(1e-15, 1.0) == pytest.approx(1e-15 / QUAT_NORM_MIN_HOURS, rel=1e-12)
    assert quat_norm_dev_per_hour(1e-15, 0.0) == pytest.approx(6e-14, rel=1e-12)


def _quat_specs():
    specs = [Spec.from_row(r) for r in load_scenario_file(shipped_scenarios()["full_sine"]).specs
             if r["metric"].startswith("quat_norm")]
    assert specs
    return specs


@pytest.mark.parametrize("hours", [1.0, 10.0, 100.0])
def test_shipped_norm_spec_holds_a_soak_with_the_measured_drift(hours):
    dev = 6e-12 * hours  # the measured growth
    metrics = {"quat_norm_max_dev": dev, "quat_norm_dev_per_hour": quat_norm_dev_per_hour(dev, 3600 * hours)}
    assert all(r["ok"] for r in evaluate_specs(_quat_specs(), metrics)), metrics


def test_shipped_norm_spec_still_catches_a_filter_that_loses_the_norm():
    dev = 1e-9  # in a 20 s run
    metrics = {"quat_norm_max_dev": dev, "quat_norm_dev_per_hour": quat_norm_dev_per_hour(dev, 20.0)}
    assert not all(r["ok"] for r in evaluate_specs(_quat_specs(), metrics))
