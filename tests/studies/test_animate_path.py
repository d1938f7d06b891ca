"""``ballbot animate`` of a path run: the log carries the path table and the obstacles
(round trip through the npz), the first frame draws the path line and one disc per
obstacle, damaged path metadata is one line with exit 2."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from ballbot_casadi import cli  # noqa: E402
from ballbot_casadi.errors import FileFormatError  # noqa: E402
from ballbot_casadi.guidance.paths import path_from_spec  # noqa: E402
from ballbot_casadi.sim.guided import PATH_LOG_SPACING, run_path_scenario  # noqa: E402
from ballbot_casadi.sim.log import PATH_KEY, load_log, log_path, save_log  # noqa: E402
from ballbot_casadi.sim.scenario.file import parse_scenario  # noqa: E402
from ballbot_casadi.studies.animate import OBSTACLE_GID, PATH_GID, animation_scene  # noqa: E402

PATH = {"type": "line", "start": [0.0, 0.0], "end": [3.0, 0.0], "speed": 0.4}
OBSTACLES = [{"x": 1.5, "y": 0.6, "r": 0.2}, {"x": 2.5, "y": -0.7, "r": 0.3}]


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    sc = parse_scenario({"duration_s": 0.3, "cascade": True, "guidance": "pursuit", "path": PATH,
                         "obstacle": OBSTACLES}, "line").scenario
    return save_log(run_path_scenario(sc), tmp_path_factory.mktemp("path") / "run.npz")


def test_the_log_round_trip_carries_the_path_and_the_obstacles(saved):
    xy, obs = log_path(load_log(saved))
    n = int(np.ceil(3.0 / PATH_LOG_SPACING)) + 1
    assert xy.shape == (n, 2)
    np.testing.assert_allclose(xy[[0, -1]], [[0.0, 0.0], [3.0, 0.0]], rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.diff(xy[:, 0]), 3.0 / (n - 1), rtol=0, atol=1e-9)  # arc length
    np.testing.assert_allclose(xy[:, 1], 0.0, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(obs, [[1.5, 0.6, 0.2], [2.5, -0.7, 0.3]])
    ref = path_from_spec(dict(PATH))
    np.testing.assert_allclose(xy, ref.point(np.linspace(0, ref.length, n)), rtol=0, atol=1e-12)


def test_the_first_frame_draws_the_path_line_and_the_obstacles(saved):
    fig, draw, idx = animation_scene(load_log(saved), "run")
    try:
        draw(int(idx[0]))
        ax = fig.axes[0]
        lines = [ln for ln in ax.lines if ln.get_gid() == PATH_GID]
        assert len(lines) == 1
        lx, ly, lz = lines[0].get_data_3d()
        np.testing.assert_allclose([lx[0], lx[-1]], [0.0, 3.0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(ly, 0.0, atol=1e-12)
        np.testing.assert_allclose(lz, 0.0, atol=0)
        discs = [p for p in ax.patches if p.get_gid() == OBSTACLE_GID]
        assert len(discs) == 2
        for d, ob in zip(discs, OBSTACLES):  # the drawn outline lies on the obstacle's circle
            vx, vy, vz = np.asarray(d._segment3d, float)[::3].T  # the Bezier's on-curve points
            np.testing.assert_allclose(np.hypot(vx - ob["x"], vy - ob["y"]), ob["r"], rtol=1e-9)
            np.testing.assert_allclose(vz, 0.0, atol=0)
        xl, yl = ax.get_xlim(), ax.get_ylim()  # the whole course in view
        assert xl[0] < 0.0 and xl[1] > 3.0 and yl[0] < -1.0 and yl[1] > 0.8
    finally:
        plt.close(fig)


def test_a_run_without_a_path_draws_none(tmp_path):
    from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
    from ballbot_casadi.sim.scenario import Scenario

    log = run_scenario(Scenario("s", duration=0.05), ClosedLoop())
    assert log_path(log) is None
    fig, draw, idx = animation_scene(log)
    try:
        draw(int(idx[0]))
        ax = fig.axes[0]
        assert not [ln for ln in ax.lines if ln.get_gid() == PATH_GID] and not ax.patches
    finally:
        plt.close(fig)


@pytest.mark.parametrize("damage", [
    {"xy": [[0.0, 0.0]]},  # one point
    {"xy": [[0.0, 0.0], [float("nan"), 1.0]]},
    {"xy": [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]]},
    {"xy": [[0.0, 0.0], [1.0, 0.0]], "obstacles": [[1.0, 1.0]]},
    {"xy": [[0.0, 0.0], [1.0, 0.0]], "obstacles": [[1.0, 1.0, -0.2]]},
    {"xy": "line"},
    {"obstacles": []},
    [1, 2],
])
def test_damaged_path_metadata_is_one_line_exit_2(saved, tmp_path, capsys, damage):
    data = dict(np.load(saved, allow_pickle=False))
    meta = json.loads(str(data["meta_json"]))
    meta["extra"][PATH_KEY] = damage
    bad = tmp_path / "bad.npz"
    np.savez(bad, **{**data, "meta_json": np.array(json.dumps(meta))})
    with pytest.raises(FileFormatError, match="path metadata"):
        load_log(bad)
    rc = cli.main(["animate", str(bad), "-o", str(tmp_path / "a.gif")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "path metadata" in err and "\n" not in err
    assert not (tmp_path / "a.gif").exists()
