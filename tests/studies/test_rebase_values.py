"""Rebasing a study on another robot: the scenario's own scale/add changes apply to the
NEW robot's values (hand-computed), not to the thesis's."""

from __future__ import annotations

import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.scenario import parse_scenario
from ballbot_casadi.studies.registry import rebase_on_params


def test_rebased_changes_apply_on_the_new_robots_values():
    thesis = load_params()
    robot = thesis.replace(Mb=thesis.Mb * 1.3, Jbz=thesis.Jbz * 0.7, com_x=-0.01, l=thesis.l * 1.1)
    sc = parse_scenario({"duration_s": 1.0,
                         "plant": {"Mb": {"scale": 1.1}, "com_x": {"add": 0.004}, "Jbx": {"set": 0.9}},
                         "controller_model": {"Jbz": {"scale": 2.0}}}).scenario
    re = rebase_on_params(sc, robot)
    p, c = re.plant_params(), re.controller_params()
    assert p.Mb == pytest.approx(thesis.Mb * 1.3 * 1.1, rel=1e-14)
    assert p.com_x == pytest.approx(-0.01 + 0.004, rel=1e-14)
    assert p.Jbx == 0.9                      # a set stays a set
    assert p.Jbz == pytest.approx(thesis.Jbz * 0.7, rel=1e-14)   # untouched by the scenario: the robot's
    assert p.l == pytest.approx(thesis.l * 1.1, rel=1e-14)
    assert c.Jbz == pytest.approx(thesis.Jbz * 0.7 * 2.0, rel=1e-14)
    assert c.Mb == pytest.approx(thesis.Mb * 1.3, rel=1e-14)      # the controller model: the robot
    assert c.com_x == pytest.approx(-0.01, rel=1e-14)
    # unchanged parameters stay the thesis's, and rebasing on the thesis itself is the identity
    assert p.Mk == thesis.Mk and c.Jbx == thesis.Jbx
    same = rebase_on_params(sc, thesis)
    assert same.plant_params() == sc.plant_params() and same.controller_params() == sc.controller_params()
