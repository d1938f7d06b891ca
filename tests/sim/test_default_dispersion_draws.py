"""The default Monte Carlo set of a file without ``[montecarlo]`` rows, drawn by hand from
its documented spread (``ballbot montecarlo --help``, dispersions.py): body mass +-5 % and
inertias +-10 % (1 sigma, relative), COM offset 5 mm in x and y and COM height 1 cm (1 sigma,
absolute), viscous frictions uniform on [0, 0.5], [0, 0.005], [0, 0.05], initial roll and
pitch uniform +-1 deg (issue 23: a changed spread, a relative flag flipped or two rows
swapped must show)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.scenario import parse_scenario
from ballbot_casadi.sim.scenario.dispersions import draw_runs


def test_default_set_values_follow_the_documented_spread_in_order():
    sf = parse_scenario({"name": "d", "duration_s": 0.1, "initial": {"roll_deg": 2.0}}, "d.toml")
    p = load_params()
    for i, run in enumerate(draw_runs(sf, 2, seed=5)):
        rng = np.random.default_rng([5, i])
        assert run["seed"] == int(rng.integers(0, 2**32))
        n = [rng.normal(0.0, sd) for sd in (0.05, 0.10, 0.10, 0.10, 0.005, 0.005, 0.01)]
        u = [rng.uniform(lo, hi) for lo, hi in ((0.0, 0.5), (0.0, 0.005), (0.0, 0.05),
                                                 (-1.0, 1.0), (-1.0, 1.0))]
        want = {
            "plant.Mb": p.Mb * (1 + n[0]), "plant.Jbx": p.Jbx * (1 + n[1]),
            "plant.Jby": p.Jby * (1 + n[2]), "plant.Jbz": p.Jbz * (1 + n[3]),
            "plant.com_x": p.com_x + n[4], "plant.com_y": p.com_y + n[5], "plant.l": p.l + n[6],
            "plant.Bvk": p.Bvk + u[0], "plant.Bvm": p.Bvm + u[1], "plant.Bvb": p.Bvb + u[2],
            "initial.roll_deg": 2.0 + u[3], "initial.pitch_deg": 0.0 + u[4],
        }
        assert list(run["values"]) == list(want)
        assert run["values"] == pytest.approx(want, rel=1e-15, abs=1e-15)
        # each drawn value is written into the run's own table, under its own key
        t = run["table"]
        assert t["plant"] == pytest.approx({k[6:]: v for k, v in want.items() if k[:6] == "plant."},
                                           rel=1e-15, abs=1e-15)
        assert t["initial"] == pytest.approx({"roll_deg": want["initial.roll_deg"],
                                              "pitch_deg": want["initial.pitch_deg"]}, rel=1e-15)

