"""load_log's shape checks at their bounds (sim/log.py ``_check_shapes``): a log of one
row is read, none or a row count that differs between ``time`` and ``state``, a state of
11 columns or a 2-D time are refused with the whole message read back; a log without
``state`` and one whose path table is damaged are refused when loaded, not when used
(mutant classes: ``<`` for ``<=``, ``!=`` for ``==``, ``or`` for ``and``, a changed size)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import FileFormatError
from ballbot_casadi.sim.log import PATH_KEY, SimulationLog, load_log, save_log


def _saved(tmp_path, extra=None, **arrays):
    p = load_params()
    log = SimulationLog(arrays=arrays, scenario={"name": "s"}, params=p, ctrl_params=p, extra=extra or {})
    return save_log(log, tmp_path / "run.npz")


def test_a_one_row_log_is_read(tmp_path):
    back = load_log(_saved(tmp_path, time=np.zeros(1), state=np.full((1, 12), 0.5)))
    assert back["state"].shape == (1, 12) and back.diag_names == () and back.extra == {}


@pytest.mark.parametrize("t, x", [
    (np.zeros(0), np.zeros((0, 12))),      # N = 0
    (np.zeros(3), np.zeros((2, 12))),      # rows differ
    (np.zeros(2), np.zeros((2, 11))),      # a column short
    (np.zeros(2), np.zeros((2, 13))),      # a column over
    (np.zeros((2, 1)), np.zeros((2, 12))),  # 2-D time
    (np.zeros(2), np.zeros(24)),           # 1-D state
])
def test_a_damaged_log_is_refused_with_its_shapes(tmp_path, t, x):
    path = _saved(tmp_path, time=t, state=x)
    with pytest.raises(FileFormatError) as e:
        load_log(path)
    assert str(e.value) == (f"{path}: damaged log: time {t.shape} and state {x.shape}, expected "
                            "(N,) and (N, 12) with N >= 1")


@pytest.mark.parametrize("missing", ["time", "state"])
def test_a_log_without_time_or_state_is_not_a_log(tmp_path, missing):
    arrays = {"time": np.zeros(2), "state": np.zeros((2, 12))}
    arrays.pop(missing)
    path = _saved(tmp_path, **arrays)
    with pytest.raises(FileFormatError) as e:
        load_log(path)
    assert str(e.value) == f"{path}: not a ballbot simulation log (no time or state array)"


def test_a_damaged_path_table_is_refused_on_load(tmp_path):
    path = _saved(tmp_path, extra={PATH_KEY: {"xy": [[0.0, 0.0]]}}, time=np.zeros(2),
                  state=np.zeros((2, 12)))
    with pytest.raises(FileFormatError) as e:
        load_log(path)
    assert str(e.value).startswith(f"{path}: damaged path metadata: xy (1, 2), obstacles (0, 3)")
    good = _saved(tmp_path, extra={PATH_KEY: {"xy": [[0.0, 0.0], [1.0, 2.0]]}}, time=np.zeros(2),
                  state=np.zeros((2, 12)))
    assert load_log(good).extra[PATH_KEY]["xy"] == [[0.0, 0.0], [1.0, 2.0]]
