"""sim/log.py: a run's log saved to .npz and read back unchanged; a foreign file is refused."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import FileFormatError
from ballbot_casadi.sim.log import SimulationLog, load_log, save_log


def _log() -> SimulationLog:
    rng = np.random.default_rng(17)
    p = load_params()
    arrays = {"time": np.arange(6) * 0.005, "state": rng.normal(size=(6, 12)),
              "diag": rng.normal(size=(5, 2)), "valid": np.ones((5, 3))}
    return SimulationLog(arrays=arrays, scenario={"name": "t", "x0": [0.0] * 12}, params=p,
                         ctrl_params=p.replace(Mb=p.Mb * 1.1), diag_names=("a", "b"),
                         extra={"note": "x", "n": 3})


def test_save_and_load_round_trip_bit_for_bit(tmp_path):
    log = _log()
    path = save_log(log, tmp_path / "sub" / "deeper" / "run")  # folders made, suffix added
    assert path == tmp_path / "sub" / "deeper" / "run.npz" and path.is_file()
    back = load_log(path)
    assert back.keys() == log.keys()
    for k in log.keys():
        assert back[k].dtype == log[k].dtype and back[k].tobytes() == log[k].tobytes(), k
    assert back.scenario == log.scenario and back.extra == log.extra
    assert back.params == log.params and back.ctrl_params == log.ctrl_params
    assert back.ctrl_params.Mb == pytest.approx(load_params().Mb * 1.1, rel=1e-15)
    assert back.diag_names == ("a", "b")
    assert "state" in back and "nope" not in back
    assert log.save(tmp_path / "b.npz") == tmp_path / "b.npz"


def test_a_foreign_npz_is_not_a_log(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, x=np.zeros(3))
    with pytest.raises(FileFormatError, match="not a ballbot simulation log"):
        load_log(path)
