"""The flc_smc study (thesis §8.3): FLC against the V2019 SMC side by side."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ballbot_casadi.control import default_balance_gains
from ballbot_casadi.control.smc import SMC_GAIN_NAMES
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.studies.flc_smc import run_flc_smc_study, stiffness_ratio


def test_stiffness_ratio_of_the_boundary_layer_pd():
    # V2019 defaults: eta / eps = 6 / 0.5 = 12, K = 15; FLC K_p = 100
    assert stiffness_ratio() == pytest.approx(12 * 15 / 100, rel=1e-12)
    k = default_balance_gains("smc")
    k[SMC_GAIN_NAMES.index("eta2")] *= 2
    assert stiffness_ratio(k) == pytest.approx(3.6, rel=1e-12)
    assert stiffness_ratio(axis=2) == pytest.approx(3 / 0.2 * 6 / 25, rel=1e-12)


def test_flc_smc_study_differs_from_the_thesis_for_the_stated_reason(tmp_path):
    m = run_flc_smc_study(tmp_path, controllers=("flc", "smc", "sta"), sim=ClosedLoop())
    specs = {s["name"].split(" (")[0]: s for s in m["specs"]}
    thesis = specs["thesis: pitch error FLC / SMC"]
    # the thesis's order of magnitude is not reproduced (measured 1.8) ...
    assert not thesis["ok"] and 1.2 < thesis["value"] < 10
    # ... because the SMC is a stiffer PD: the ratio is the stiffness ratio (measured +1-2 %)
    for s in m["specs"]:
        if not s["thesis"]:
            assert s["ok"] and abs(s["value"]) <= 0.15
    assert m["passed"]
    # integral action gives the order of magnitude the thesis attributes to the SMC
    assert m["integral_action_ratio"]["sta"] >= 10
    np.testing.assert_allclose(m["ratio_flc_over_smc"]["ours"]["pitch"],
                               m["table"]["ours"]["flc"]["pitch_error_max_deg"]
                               / m["table"]["ours"]["smc"]["pitch_error_max_deg"], rtol=1e-12)
    text = (tmp_path / "report.md").read_text()
    assert "**differs**" in text and "Fig. 8.8" in text and "| sta | ours |" in text
    assert json.loads((tmp_path / "metrics.json").read_text())["passed"] is True
