"""MpcConfig's non-weight defaults against where they are documented: the horizon of the
module docstring (N = 20, dt = 0.1 s), the ADMM parameters of qp_admm (OSQP's defaults),
the §7.1 limits (a copy per configuration), the move blocks and constraint nodes, the
margins (test_mpc_defaults pins the weights)."""

from __future__ import annotations

import re

import pytest

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.guidance import mpc as M
from ballbot_casadi.guidance import qp_admm
from ballbot_casadi.guidance.mpc import FIRST_SAMPLE_QPS, MpcConfig


def test_horizon_defaults_are_the_documented_ones():
    m = re.search(r"default N = (\d+), dt = ([\d.]+) s: a ([\d.]+) s horizon", M.__doc__)
    N, dt, horizon = int(m.group(1)), float(m.group(2)), float(m.group(3))
    c = MpcConfig()
    assert (c.N, c.dt) == (N, dt) == (20, 0.1)
    assert c.N * c.dt == pytest.approx(horizon, rel=1e-12)
    assert sum(c.blocks) == c.N and c.blocks == (1, 1, 1, 1, 2, 2, 2, 2, 4, 4)
    assert c.nodes == (1, 2, 3, 4, 6, 8, 10, 12, 16, 20) and c.nodes[-1] == c.N
    assert c.n_obstacles == 5 and FIRST_SAMPLE_QPS == 5


def test_admm_defaults_are_osqps():
    m = re.search(r"OSQP's defaults: ([\d.e-]+), ([\d.e-]+), ([\d.e-]+)\)", qp_admm.admm_graph.__doc__)
    rho, sigma, alpha = (float(v) for v in m.groups())
    c = MpcConfig()
    assert (c.rho, c.sigma, c.alpha) == (rho, sigma, alpha) == (0.1, 1e-6, 1.6)
    assert c.iterations == 60 and c.solver == "admm" and c.solver_options == {}


def test_limits_margins_and_a_fresh_copy_per_configuration():
    a, b = MpcConfig(), MpcConfig()
    assert a.limits == dict(THESIS_LIMITS)
    assert a.limits is not b.limits and a.solver_options is not b.solver_options
    a.limits["v_max"] = 9.0
    assert b.limits["v_max"] == THESIS_LIMITS["v_max"] == 0.5
    assert (a.margin, a.acc_margin, a.tilt_acc_max, a.clearance) == (0.9, 0.8, 2.0, 0.15)
