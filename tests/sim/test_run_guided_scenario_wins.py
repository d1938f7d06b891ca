"""run_guided with a ``scenario`` runs the scenario as it says: its estimator and seed,
not the ``estimator`` / ``seed`` arguments, which only build the stand-in scenario of a
bare path (after-batch survivor: ``scenario is None and estimator != "true"`` with ``or``
replaced the given scenario's estimator)."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.guidance.paths import line_path
from ballbot_casadi.sim.guided import pursuit_law, run_guided
from ballbot_casadi.sim.path_following import path_scenario


def test_the_given_scenario_keeps_its_estimator_and_seed():
    path = line_path((0.0, 0.0), (1.0, 0.0))
    sc = path_scenario(path, 0.1)
    assert sc.estimator == "true"
    plain = run_guided(path, pursuit_law(), 0.1, scenario=sc)
    # an estimator no loop runs: only read if the arguments replaced the scenario's
    other = run_guided(path, pursuit_law(), 0.1, estimator="vukf", seed=7, scenario=sc)
    assert "x_hat" not in plain and "x_hat" not in other
    assert set(other) == set(plain)
    for key in plain:
        np.testing.assert_array_equal(other[key], plain[key], err_msg=key)
    assert abs(plain["state"][-1, 0]) > 1e-3  # it moved (first backwards, under the body)
