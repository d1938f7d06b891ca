"""The path-following controller FMU's checks of its path parameters at their boundaries:
each limit's own value is accepted and the nearest value beyond it refused with one logged
line naming what was wrong (``ctrl_path_check`` in fmu/controller/controller_path.c).  The
same scenario as tests/fmi/test_controller_path_fmu.py, so the same cached build."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from fmpy import extract

from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.fmi.controller.controller import controller_spec, controller_values
from ballbot_casadi.fmi.controller.path import S0_TOL, TANGENT_TOL, V_MAX, path_law
from ballbot_casadi.fmi.masters.adapter import FmuSlave
from ballbot_casadi.fmi.package import build_fmu_from_spec
from ballbot_casadi.guidance.path_table import PATH_SAMPLES
from ballbot_casadi.sim.guided import guided_software
from ballbot_casadi.sim.scenario.file import parse_scenario

pytestmark = [pytest.mark.needs_cc, pytest.mark.fmi_extra]

#: tests/fmi/test_controller_path_fmu.py's scenario (closed figure-eight from its start).
SCENARIO = {"name": "sil_path_fig8", "duration_s": 5.0, "cascade": True, "estimator": "ukf",
            "seed": 3, "guidance": "mpc",
            "path": {"type": "figure_eight", "length": 4.0, "width": 2.0, "speed": 0.5},
            "obstacle": [{"x": 0.848, "y": 0.865, "r": 0.1}, {"x": 0.0, "y": -3.0, "r": 0.2}]}


@functools.lru_cache(maxsize=None)
def _scenario():
    return parse_scenario(SCENARIO).scenario


@functools.lru_cache(maxsize=None)
def _fmu():
    sc = _scenario()
    return build_fmu_from_spec(controller_spec(path=sc), build_root() / "fmu" / "path" / sc.name).fmu


@functools.lru_cache(maxsize=None)
def _values():
    sc = _scenario()
    law = path_law(sc)
    return controller_values(sc, guided_software(law, "ukf"), law)


@pytest.fixture(scope="module")
def unzipped(tmp_path_factory):
    return extract(str(_fmu()), unzipdir=str(tmp_path_factory.mktemp("bounds")))


def _init(unzipped, **over):
    """Errors logged by the FMU initialised with the build values changed by ``over``."""
    logs = []
    slave = FmuSlave(unzipped, "ctrl", logger=lambda status, category, msg: logs.append((status, msg)))
    try:
        slave.setup(0.0, {**_values(), **over})
        slave.exit_initialization()
    except Exception:  # noqa: BLE001 - the refusal is judged from the log
        pass
    return [m for s, m in logs if s >= 3]


def test_the_limits_are_the_documented_values():
    """path_s0 within 1 cm of the projection (the table's ~1 cm spacing), tangents unit within
    1e-6, speed up to the thesis §7.1 v_max of 0.5 m/s: by hand, since the C checks take
    these constants from the same module."""
    assert (S0_TOL, TANGENT_TOL, V_MAX) == (0.01, 1e-6, 0.5)


def test_every_limit_itself_is_accepted(unzipped):
    """At once: the speed at v_max, an open path, an obstacle of radius 0 over the start (no
    obstacle), a tangent's norm off by half the tolerance, the start 0.9 S0_TOL along the
    path from the robot (the robot starts at the figure-eight's start, arc length 0)."""
    v = _values()
    assert v["path_s0"] == pytest.approx(0.0, abs=1e-6)
    f = 1 + 0.5 * TANGENT_TOL
    assert _init(unzipped, path_speed=V_MAX, path_closed=0.0, obstacle1_x=v["path_p0_x"],
                 obstacle1_y=v["path_p0_y"], obstacle1_r=0.0, path_t5_x=f * v["path_t5_x"],
                 path_t5_y=f * v["path_t5_y"], path_s0=0.9 * S0_TOL) == []


def test_path_s0_on_a_closed_path_its_length_is_its_start(unzipped):
    """Arc length 0 and L are the same point of a closed path; beyond [0, L] is refused."""
    L = _values()["path_length"]
    assert _init(unzipped, path_s0=L) == []
    errors = _init(unzipped, path_s0=L + 1e-9)
    assert len(errors) == 1 and "must be in [0, path_length" in errors[0], errors


@pytest.mark.parametrize("over, needle", [
    ({"path_speed": float(np.nextafter(V_MAX, np.inf))}, "need a length > 0, closed 0 or 1"),
    ({"path_s0": 1.5 * S0_TOL}, "must be the start's projection on the path"),
    ({"path_t5_x": "2tol"}, "path_t5 = ["),
    ({"obstacle1_x": "p0+0.05", "obstacle1_r": 0.1}, "covers the path's start (path_p0)"),
])
def test_the_nearest_value_beyond_a_limit_is_refused(unzipped, over, needle):
    v = _values()
    over = dict(over)
    if over.get("path_t5_x") == "2tol":
        f = 1 + 2 * TANGENT_TOL
        over.update(path_t5_x=f * v["path_t5_x"], path_t5_y=f * v["path_t5_y"])
        needle = "path_t5 = [%g, %g] must be a unit vector (norm 1 within %g)" % (
            over["path_t5_x"], over["path_t5_y"], TANGENT_TOL)  # C's %g: the sample's own x, y
    if over.get("obstacle1_x") == "p0+0.05":  # the disc's edge 5 cm beyond the start
        over.update(obstacle1_x=v["path_p0_x"] + 0.05, obstacle1_y=v["path_p0_y"])
    errors = _init(unzipped, **over)
    assert len(errors) == 1 and needle in errors[0] and "\n" not in errors[0], errors


# Each refusal of ctrl_path_check, one branch at a time, with the message's numbers: the
# closed flag, length and speed, a negative radius, an obstacle over the path's END (the
# table's last point moved away from the start, so start and end differ), over the robot's
# START (the robot 0.3 m off the path, the obstacle clear of it), path_s0 below 0; a
# non-finite entry is refused by the shared layer when it is set, naming the variable.
LAST = PATH_SAMPLES - 1


def _case(name):
    v = _values()
    p0 = (v["path_p0_x"], v["path_p0_y"])
    far = (p0[0] + 1.0, p0[1] - 1.5)
    return {
        # the shared layer refuses a non-finite value when it is set, naming the variable
        "nan_point": ({"path_p3_y": float("nan")}, "'path_p3_y' (vr"),
        "nan_obstacle": ({"obstacle1_r": float("inf")}, "'obstacle1_r' (vr"),
        "length": ({"path_length": 0.0}, "path_length = 0, path_closed = 1, path_speed = 0.5"),
        "closed": ({"path_closed": 0.5}, "path_closed = 0.5, path_speed = 0.5: need a length"),
        "speed0": ({"path_speed": 0.0}, "path_speed = 0: need a length > 0, closed 0 or 1 and "
                                        "a speed in (0, 0.5] m/s"),
        "radius": ({"obstacle1_r": -0.1}, "obstacle1_r = -0.1 must be >= 0 (0: no obstacle)"),
        "end": ({f"path_p{LAST}_x": far[0], f"path_p{LAST}_y": far[1], "obstacle1_x": far[0],
                 "obstacle1_y": far[1] + 0.05, "obstacle1_r": 0.1},
                "obstacle1 (radius 0.1 m at [%g, %g]) covers the path's end [%g, %g]"
                % (far[0], far[1] + 0.05, far[0], far[1])),
        "robot": ({"x0_y": p0[1] + 0.3, "obstacle1_x": p0[0], "obstacle1_y": p0[1] + 0.35,
                   "obstacle1_r": 0.1},
                  "covers the robot's start (x0_x, x0_y) [%g, %g]" % (p0[0], p0[1] + 0.3)),
        "s0_negative": ({"path_s0": -1e-9}, "path_s0 = -1e-09 must be in [0, path_length = %g]"
                        % v["path_length"]),
    }[name]


@pytest.mark.parametrize("name", ["nan_point", "nan_obstacle", "length", "closed", "speed0",
                                  "radius", "end", "robot", "s0_negative"])
def test_each_path_check_refuses_with_its_own_line(unzipped, name):
    over, needle = _case(name)
    errors = _init(unzipped, **over)
    assert len(errors) == 1 and needle in errors[0] and "\n" not in errors[0], (errors, needle)


def test_the_s0_tolerance_measures_from_the_nearest_table_point(unzipped):
    """The robot 0.3 m off the path beside its start: path_s0 at the start's projection is
    accepted; 0.2 m farther along the path puts the start farther than the nearest table
    point plus S0_TOL, and the message gives the nearest table point's distance."""
    v = _values()
    x0 = np.array([v["x0_x"], v["path_p0_y"] + 0.3])
    pts = np.array([[v[f"path_p{i}_x"], v[f"path_p{i}_y"]] for i in range(PATH_SAMPLES)])
    best = float(np.min(np.hypot(*(pts - x0).T)))
    s0 = float(_scenario().route.build().project(x0))
    assert _init(unzipped, x0_y=x0[1], path_s0=s0) == []
    errors = _init(unzipped, x0_y=x0[1], path_s0=s0 + 0.2)
    assert len(errors) == 1 and "the nearest path point is %g m away" % best in errors[0], errors


def test_the_s0_refusal_gives_the_start_distance_in_both_axes(unzipped):
    """path_s0 at a table sample's own arc length puts the start exactly on that sample: the
    refusal gives its distance from the robot, hypot(dx, dy), with dx != dy (the robot 0.3 m
    off the path, the sample 20 samples beyond the nearest)."""
    v = _values()
    x0 = np.array([v["x0_x"], v["path_p0_y"] + 0.3])
    pts = np.array([[v[f"path_p{i}_x"], v[f"path_p{i}_y"]] for i in range(PATH_SAMPLES)])
    dist = np.hypot(*(pts - x0).T)
    i = int(np.argmin(dist)) + 20
    dx, dy = pts[i] - x0
    assert abs(abs(dx) - abs(dy)) > 0.05 and dist[i] > dist.min() + S0_TOL  # the case separates
    errors = _init(unzipped, x0_y=x0[1], path_s0=i * v["path_length"] / (PATH_SAMPLES - 1))
    assert len(errors) == 1 and "puts the start %g m from the robot" % dist[i] in errors[0], errors
