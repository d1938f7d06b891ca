"""Replay glue without the cross toolchain: the recorded mission's definition, the log's
period count and the replay program's output format (header, rows, extra columns)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.firmware import replay as R
from ballbot_casadi.firmware.sources import FirmwareValues
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR


def test_replay_scenario_is_the_documented_mission():
    sc = R.replay_scenario(80, seed=7)
    assert sc.duration == pytest.approx(80 * TS_CONTROL, rel=1e-12)
    assert sc.seed == 7 and sc.controller == "flc" and sc.estimator == DEFAULT_ESTIMATOR
    assert R.replay_scenario(80, estimator="ukf").estimator == "ukf"  # the thesis's filters
    assert R.replay_scenario(1).duration == pytest.approx(TS_CONTROL, rel=1e-12)  # the shortest
    assert sc.attitude["roll"] == {"type": "sine", "amplitude_deg": 3.0, "frequency_hz": 0.5}
    assert tuple(sc.sensor_dropouts) == ((0.3, 0.35, "gyro"),)
    for bad in (0, -3, 2.0, "10"):
        with pytest.raises(ScenarioError, match="n_periods"):
            R.replay_scenario(bad)


def test_recorded_log_counts_periods_by_rows():
    n = 13
    rec = R.RecordedLog(np.zeros((n, 9)), np.zeros((n, 15)), False,
                        FirmwareValues({}, np.zeros(4)), np.zeros((n, 3)))
    assert rec.n == n
    assert rec.v_ref_mission is None


def _write(path, n, extra, header_n=None, drop=0):
    hdr = [n if header_n is None else header_n, 1536, 11.0, 200001.0, 41000, 8, extra, 256, 2]
    rows = np.arange(n * (5 + extra), dtype=float).reshape(n, 5 + extra)
    rows[:, 4] = np.arange(n) % 2  # return codes
    data = np.concatenate([hdr, rows.ravel()])[: (len(hdr) + rows.size) - drop]
    path.write_bytes(data.astype("<f8").tobytes())
    return rows


@pytest.mark.parametrize("extra", [0, 3, 4])
def test_output_file_is_read_row_by_row(tmp_path, extra):
    n = 6
    rows = _write(tmp_path / "out.bin", n, extra)
    res = R._read_output(tmp_path / "out.bin", n)
    np.testing.assert_array_equal(res.tau, rows[:, :3])
    np.testing.assert_array_equal(res.ticks, rows[:, 3])
    np.testing.assert_array_equal(res.rc, np.arange(n) % 2)
    assert res.rc.dtype.kind == "i"
    assert (res.stack_bytes, res.ctx_bytes, res.real_bytes) == (1536, 41000, 8)
    assert res.calib_ticks == 11.0 and res.calib_instructions == 200001.0
    assert res.instructions_per_tick == pytest.approx(200001.0 / 11.0)
    # extra columns: up to 3 velocity references, then the background sample's ticks
    assert res.v_ref.shape == (n, min(extra, 3))
    np.testing.assert_array_equal(res.v_ref, rows[:, 5:8])
    np.testing.assert_array_equal(res.bg_ticks, rows[:, 8] if extra > 3 else np.zeros(n))
    assert (res.bg_stack_bytes, res.guidance_late) == (256, 2)
    assert R.OUT_HEADER == 9


def test_a_short_or_mislabelled_output_is_a_build_error(tmp_path):
    _write(tmp_path / "a.bin", 5, 0, drop=1)
    with pytest.raises(BuildError, match="stopped early"):
        R._read_output(tmp_path / "a.bin", 5)
    _write(tmp_path / "b.bin", 5, 0, header_n=4)
    with pytest.raises(BuildError, match="stopped early"):
        R._read_output(tmp_path / "b.bin", 5)


def test_a_command_fails_exactly_on_a_nonzero_exit(tmp_path):
    import sys
    R._run([sys.executable, "-c", "pass"], tmp_path, "the host check", 60.0)  # exit 0: no error
    for code in (1, 3):
        with pytest.raises(BuildError, match=rf"^the host check failed \(exit {code}\): boom$"):
            R._run([sys.executable, "-c", f"import sys; sys.stderr.write('boom\\n'); sys.exit({code})"],
                   tmp_path, "the host check", 60.0)
