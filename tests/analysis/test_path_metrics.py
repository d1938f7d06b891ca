"""Path metrics against hand-computed values on constructed trajectories: a line followed
too slowly with a known lateral offset (RMS, settled RMS with a sample on the 2 s
boundary, maximum, longitudinal lag, clearance, progress), a decimated log, and a
figure-eight followed at a constant offset through its crossing (the projection keeps its
branch) and completed within the run's time."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.analysis.path_metrics import SAMPLE_EVERY, path_metrics
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.guidance.paths import path_from_spec

TS = 0.005


def _log(xy: np.ndarray, t: np.ndarray, path: dict, obstacles=(), log_every: int = 1):
    x = np.zeros((t.size, STATE.size))
    x[:, STATE["q"]] = [1.0, 0.0, 0.0, 0.0]
    x[:, 0:2] = xy
    return SimpleNamespace(scenario={"path": path, "obstacles": [list(o) for o in obstacles]},
                           arrays={"state": x, "time": t}, extra={"log_every": log_every})


def _slow_line(duration: float = 6.0):
    """x = 0.4 t along a 4 m line at 0.5 m/s; y = 0.2 m before 2 s, 0.3 m at the 2 s
    sample, 0.1 m after it."""
    n = int(round(duration / TS)) + 1
    t = np.round(np.arange(n) * TS, 12)
    y = np.where(t < 2.0, 0.2, 0.1)
    y[t == 2.0] = 0.3
    return np.column_stack([0.4 * t, y]), t


LINE = {"type": "line", "start": [0.0, 0.0], "end": [4.0, 0.0], "speed": 0.5}


def test_line_followed_too_slowly_with_a_known_offset():
    xy, t = _slow_line()
    m = path_metrics(_log(xy, t, LINE, obstacles=[(2.0, 1.0, 0.3)]))
    assert SAMPLE_EVERY == 20  # samples every 0.1 s: 20 before 2 s, the 2 s one, 40 after
    assert m["path_lateral_rms_m"] == pytest.approx(np.sqrt((20 * 0.04 + 0.09 + 40 * 0.01) / 61),
                                                    abs=1e-6)
    assert m["path_lateral_rms_settled_m"] == pytest.approx(np.sqrt((0.09 + 40 * 0.01) / 41),
                                                            abs=1e-6)
    assert m["path_lateral_max_m"] == pytest.approx(0.3, abs=1e-6)
    # reference progress 0.5 t, progress 0.4 t: lag 0.1 t, largest at 6 s
    assert m["path_longitudinal_lag_max_m"] == pytest.approx(0.6, abs=1e-6)
    # nearest approach to the obstacle at x = 2 (t = 5 s, y = 0.1): 0.9 - 0.3
    assert m["path_min_clearance_m"] == pytest.approx(0.6, abs=1e-9)
    assert m["path_collision"] == 0.0
    assert m["path_completed"] == 0.0
    assert m["path_progress_fraction"] == pytest.approx(2.4 / 4.0, abs=1e-6)


@pytest.mark.parametrize("short_of_end, done", [(0.0, 1.0), (0.09, 1.0), (0.11, 0.0), (0.5, 0.0)])
def test_an_open_path_counts_as_completed_within_0_1_m_of_its_end(short_of_end, done):
    n = int(round(10.0 / TS)) + 1
    t = np.round(np.arange(n) * TS, 12)
    xy = np.column_stack([np.minimum(0.55 * t, 4.0 - short_of_end), np.zeros(n)])
    assert path_metrics(_log(xy, t, LINE))["path_completed"] == done


def test_a_run_to_the_end_of_an_open_path_is_completed():
    n = int(round(10.0 / TS)) + 1
    t = np.round(np.arange(n) * TS, 12)
    xy = np.column_stack([np.minimum(0.55 * t, 4.0), np.zeros(n)])
    m = path_metrics(_log(xy, t, LINE))
    # ahead of the reference 0.5 t all the way (the end reached at 7.27 s, the reference
    # there at 8 s): the lag is never positive, 0 at the start and from 8 s on
    assert m["path_longitudinal_lag_max_m"] == pytest.approx(0.0, abs=1e-6)
    assert m["path_completed"] == 1.0
    assert m["path_progress_fraction"] == pytest.approx(1.0, abs=1e-6)
    # an obstacle the ball centre runs through: clearance negative, a collision
    hit = path_metrics(_log(xy, t, LINE, obstacles=[(2.75, 0.05, 0.1)]))  # x = 2.75 at 5 s
    assert hit["path_min_clearance_m"] == pytest.approx(-0.05, abs=1e-9)
    assert hit["path_collision"] == 1.0
    # touching counts: an obstacle whose edge the ball centre meets exactly (clearance 0)
    k = int(np.argmin(np.abs(t - 5.0)))
    touch = path_metrics(_log(xy, t, LINE, obstacles=[(xy[k, 0], 0.25, 0.25)]))
    assert touch["path_min_clearance_m"] == 0.0 and touch["path_collision"] == 1.0


def test_a_decimated_log_gives_the_same_metrics():
    xy, t = _slow_line()
    full = path_metrics(_log(xy, t, LINE, obstacles=[(2.0, 1.0, 0.3)]))
    dec = path_metrics(_log(xy[::4], t[::4], LINE, obstacles=[(2.0, 1.0, 0.3)], log_every=4))
    for k, v in full.items():
        assert dec[k] == pytest.approx(v, abs=1e-9), k


def test_a_log_without_its_decimation_counts_as_every_period_logged():
    """A log from elsewhere (no ``extra``, or no ``log_every`` in it) holds every period."""
    xy, t = _slow_line()
    full = path_metrics(_log(xy, t, LINE, obstacles=[(2.0, 1.0, 0.3)]))
    bare = _log(xy, t, LINE, obstacles=[(2.0, 1.0, 0.3)])
    for extra in ({}, None):
        if extra is None:
            del bare.extra
        else:
            bare.extra = extra
        assert path_metrics(bare) == full


def test_figure_eight_at_a_constant_offset_keeps_its_branch_through_the_crossing():
    spec = {"type": "figure_eight", "length": 4.0, "width": 2.0, "speed": 0.5}
    path = path_from_spec(spec)
    n = int(round(16.0 / TS)) + 1
    t = np.round(np.arange(n) * TS, 12)
    s = 1.0 + 0.5 * t  # starts off the crossing (s = 0), where the branch is ambiguous
    assert s[0] < path.length / 2 < s[-1] < path.length  # through the crossing, not a lap
    tan = path.tangent(s)
    normal = np.column_stack([-tan[:, 1], tan[:, 0]])
    xy = path.point(s) + 0.05 * normal
    m = path_metrics(_log(xy, t, spec))
    # at the crossing the branches are perpendicular: the offset point lies on the other
    # branch, which a whole-path projection would take (lateral error 0, progress jumps)
    assert m["path_lateral_rms_m"] == pytest.approx(0.05, abs=1e-4)
    assert m["path_lateral_max_m"] == pytest.approx(0.05, abs=1e-4)
    assert abs(m["path_longitudinal_lag_max_m"]) < 1e-3
    # a closed path is completed when the progress of the run's time is reached (8 m
    # at 0.5 m/s in 16 s), not only after a whole lap
    assert m["path_completed"] == 1.0
    assert m["path_progress_fraction"] == pytest.approx(8.0 / path.length, abs=1e-3)


def test_a_run_starting_along_an_open_path_completes_when_it_reaches_the_end():
    """The robot starts 0.3 m along the line and drives to its end: the path was followed
    to its end (the progress, counted from the start, is only 3.7 m of the 4 m)."""
    n = int(round(10.0 / TS)) + 1
    t = np.round(np.arange(n) * TS, 12)
    xy = np.column_stack([np.minimum(0.3 + 0.5 * t, 4.0), np.zeros(n)])
    m = path_metrics(_log(xy, t, LINE))
    assert m["path_completed"] == 1.0
    assert m["path_progress_fraction"] == pytest.approx(3.7 / 4.0, abs=1e-6)
    short = path_metrics(_log(xy[t <= 6.0], t[t <= 6.0], LINE))  # 3.3 m: 0.7 m short of the end
    assert short["path_completed"] == 0.0


@pytest.mark.parametrize("rate, done", [(0.5, 1.0), (0.495, 1.0), (0.49, 0.0), (0.25, 0.0)])
def test_a_closed_path_is_completed_only_with_the_progress_its_time_asks_for(rate, done):
    """16 s at 0.5 m/s ask for 8 m of a figure-eight (less than a lap), 0.1 m less will
    do: 7.92 m (0.495 m/s) is enough, 7.84 m (0.49 m/s) and 4 m are not."""
    spec = {"type": "figure_eight", "length": 4.0, "width": 2.0, "speed": 0.5}
    path = path_from_spec(spec)
    t = np.round(np.arange(int(round(16.0 / TS)) + 1) * TS, 12)
    s = 1.0 + rate * t
    m = path_metrics(_log(path.point(s), t, spec))
    assert m["path_completed"] == done
    assert m["path_progress_fraction"] == pytest.approx(rate * 16.0 / path.length, abs=1e-3)


def test_path_errors_of_a_single_position_and_from_the_first_one():
    """One position: its own projection (the search starts there); a second one 1.5 m on
    along the line: followed on from the first."""
    from ballbot_casadi.analysis.path_metrics import path_errors

    line = path_from_spec(dict(LINE))
    s, lat = path_errors(line, np.array([[1.5, -0.25]]))
    assert s == pytest.approx([1.5], abs=1e-9) and lat == pytest.approx([0.25], abs=1e-9)
    s, lat = path_errors(line, np.array([[1.5, -0.25], [3.0, 0.1]]))
    assert s == pytest.approx([1.5, 3.0], abs=1e-9) and lat == pytest.approx([0.25, 0.1], abs=1e-9)
