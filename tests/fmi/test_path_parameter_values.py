"""The path-following controller FMU's path parameters, value by value (no FMU is built).

A straight line from (0, 0) to (2, 0) at 0.4 m/s with one obstacle and the robot
starting off the path at (0.5, 0.2): every table point, tangent, obstacle slot and
``path_s0`` is known by hand (points ``(2 i / (n - 1), 0)``, tangents ``(1, 0)``, the
start's projection ``s0 = 0.5``), so a swapped axis, an index off by one, a wrong slot or
a dropped obstacle changes a checked number.  Each refusal of :func:`path_law` and of
:func:`mpc_model_dependencies` is checked for its key and its one line.
"""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.control.velocity import VELOCITY_NKV
from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.fmi.controller.path import (
    S0_NAME,
    S0_TOL,
    TANGENT_TOL,
    V_MAX,
    mpc_model_dependencies,
    path_c_defines,
    path_law,
    path_parameter_descriptions,
    path_parameter_names,
    path_parameter_values,
)
from ballbot_casadi.guidance.path_table import PATH_SAMPLES
from ballbot_casadi.sim.path_following import velocity_loop_dependencies
from ballbot_casadi.sim.scenario.file import parse_scenario

BASE = {"name": "pline", "duration_s": 2.0, "cascade": True, "estimator": "ukf",
        "path": {"type": "line", "start": [0.0, 0.0], "end": [2.0, 0.0], "speed": 0.4},
        "obstacle": [{"x": 1.0, "y": 0.6, "r": 0.2}],
        "initial": {"x_m": 0.5, "y_m": 0.2}}


@pytest.fixture(scope="module")
def line():
    sc = parse_scenario(BASE).scenario
    law = path_law(sc)
    return sc, law, path_parameter_values(sc, law)


def test_names_follow_the_table_layout(line):
    _, law, _ = line
    names = path_parameter_names(law)
    n, m = PATH_SAMPLES, law.config.n_obstacles
    assert m >= 2  # the checks below need an empty slot after the used one
    assert names[:7] == ("path_length", "path_closed", "path_speed", "path_p0_x", "path_p0_y",
                         "path_p1_x", "path_p1_y")
    assert names[3 + 2 * n - 1] == f"path_p{n - 1}_y"
    assert names[3 + 2 * n:3 + 2 * n + 2] == ("path_t0_x", "path_t0_y")
    assert names[3 + 4 * n:3 + 4 * n + 4] == ("obstacle0_x", "obstacle0_y", "obstacle0_r",
                                              "obstacle1_x")
    assert names[-1] == f"obstacle{m - 1}_r"
    assert len(names) == 3 + 4 * n + 3 * m == len(set(names))


def test_values_of_a_straight_line_with_one_obstacle(line):
    _, law, v = line
    n, m = PATH_SAMPLES, law.config.n_obstacles
    assert (v["path_length"], v["path_closed"], v["path_speed"]) == \
        pytest.approx((2.0, 0.0, 0.4), abs=1e-12)
    px = [v[f"path_p{i}_x"] for i in range(n)]
    py = [v[f"path_p{i}_y"] for i in range(n)]
    np.testing.assert_allclose(px, 2.0 * np.arange(n) / (n - 1), rtol=0, atol=1e-9)
    np.testing.assert_allclose(py, 0.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose([v[f"path_t{i}_x"] for i in range(n)], 1.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose([v[f"path_t{i}_y"] for i in range(n)], 0.0, rtol=0, atol=1e-9)
    assert (v["obstacle0_x"], v["obstacle0_y"], v["obstacle0_r"]) == (1.0, 0.6, 0.2)
    assert all(v[f"obstacle{j}_{c}"] == 0.0 for j in range(1, m) for c in "xyr")
    # the projection of the start (0.5, 0.2) onto the line
    assert v[S0_NAME] == pytest.approx(0.5, abs=1e-6)
    assert list(v) == [*path_parameter_names(law), S0_NAME]


def test_the_start_projection_follows_the_robots_start_along_and_across():
    sc = parse_scenario({**BASE, "initial": {"x_m": 1.5, "y_m": -0.3}}).scenario
    v = path_parameter_values(sc)
    assert v[S0_NAME] == pytest.approx(1.5, abs=1e-6)
    sc = parse_scenario({**BASE, "path": {"type": "line", "start": [0.0, 0.0],
                                          "end": [0.0, 2.0], "speed": 0.3},
                         "obstacle": [], "initial": {"x_m": 0.1, "y_m": 0.7}}).scenario
    v = path_parameter_values(sc)
    assert v[S0_NAME] == pytest.approx(0.7, abs=1e-6)
    assert (v["path_t0_x"], v["path_t0_y"]) == pytest.approx((0.0, 1.0), abs=1e-9)
    assert (v["path_p1_x"], v["path_p1_y"]) == pytest.approx((0.0, 2.0 / (PATH_SAMPLES - 1)),
                                                             abs=1e-9)
    assert v["path_speed"] == pytest.approx(0.3, abs=1e-12)
    assert v["obstacle0_r"] == 0.0


def test_descriptions_and_units_name_the_entry(line):
    _, law, _ = line
    d = path_parameter_descriptions(law)
    n = PATH_SAMPLES
    assert d["path_p3_y"] == (f"path table point 3 of {n} (equal arc-length steps), y", "m")
    assert d["path_p12_x"][0].startswith("path table point 12 of")
    assert d["path_t5_x"] == ("unit tangent of the path at table point 5, x", "1")
    assert d["obstacle1_r"] == ("circular obstacle 1: radius (0: no obstacle)", "m")
    assert d["obstacle0_x"] == ("circular obstacle 0: centre x", "m")
    assert d["obstacle0_y"] == ("circular obstacle 0: centre y", "m")
    assert d["path_length"][1] == "m" and d["path_closed"][1] == "1"
    assert d["path_speed"][1] == "m/s" and str(V_MAX) in d["path_speed"][0]
    assert d[S0_NAME][1] == "m"
    assert set(d) == {*path_parameter_names(law), S0_NAME}


def test_c_defines_are_the_table_sizes_and_tolerances(line):
    _, law, _ = line
    c = path_c_defines(law)
    assert c == {"PATH_SAMPLES": PATH_SAMPLES, "PATH_OBSTACLES": law.config.n_obstacles,
                 "V_MAX": repr(float(THESIS_LIMITS["v_max"])), "S0_TOL": "0.01",
                 "TANGENT_TOL": "1e-06"}
    assert (S0_TOL, TANGENT_TOL) == (0.01, 1e-6)
    # written into C as counts (array sizes): "50", never "50.0"
    assert type(c["PATH_SAMPLES"]) is int and type(c["PATH_OBSTACLES"]) is int


def test_mpc_dependencies_and_their_size_checks():
    p, k = np.ones(len(PARAM_NAMES)), np.ones(VELOCITY_NKV)
    dep = velocity_loop_dependencies()
    assert mpc_model_dependencies(p, k, 0.1) == (dep.params, dep.gains)
    assert mpc_model_dependencies(p.reshape(1, -1), k.reshape(-1, 1), 1e-9)[0] == dep.params
    for bad in ((p[:-1], k, 0.1), (p, k[:-1], 0.1), (p, k, 0.0), (p, k, -0.1),
                (p, k, float("nan"))):
        with pytest.raises(ShapeError, match=f"p_ctrl must have {len(PARAM_NAMES)} entries "
                                             f"and k_vel {VELOCITY_NKV}"):
            mpc_model_dependencies(*bad)


@pytest.mark.parametrize("change, key, text", [
    ({"path": None}, "path", "has no [path]"),
    ({"guidance": "pursuit"}, "guidance", "got guidance = 'pursuit'; allowed: mpc"),
    ({"controller": "smc"}, "controller", "got 'smc'"),
    ({"guidance_latency": 2}, "guidance_latency", "guidance_latency = 2; allowed: 0"),
    ({"estimator": "true"}, "estimator", "got 'true'"),
])
def test_each_refusal_names_its_key(change, key, text):
    raw = {k: v for k, v in {**BASE, "obstacle": [], **change}.items() if v is not None}
    sc = parse_scenario(raw).scenario
    with pytest.raises(ScenarioError) as exc:
        path_law(sc)
    assert exc.value.key == key and text in str(exc.value) and "\n" not in str(exc.value)


def test_a_good_path_scenario_gives_the_mpc_law(line):
    sc, law, _ = line
    assert law.config is not None and law.name == path_law(sc).name
