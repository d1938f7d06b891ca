"""``ballbot animate`` on damaged or foreign npz files: one line, exit 2 (never exit 3)."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest

from ballbot_casadi import cli
from ballbot_casadi.core.params import load_params
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.log import load_log, save_log
from ballbot_casadi.sim.scenario import Scenario


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    path = tmp_path_factory.mktemp("log") / "run.npz"
    save_log(run_scenario(Scenario("s", duration=0.05), ClosedLoop()), path)
    return path


def _npz(path, **arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    path.write_bytes(buf.getvalue())
    return path


def _variant(good, tmp_path, kind):
    p = tmp_path / f"{kind}.npz"
    data = dict(np.load(good, allow_pickle=False))
    meta = json.loads(str(data["meta_json"]))
    raw = good.read_bytes()
    if kind == "empty":
        p.write_bytes(b"")
    elif kind == "random":
        p.write_bytes(np.random.default_rng(1).bytes(4096))
    elif kind == "truncated":
        p.write_bytes(raw[: len(raw) // 2])
    elif kind == "no_meta":
        _npz(p, **{k: v for k, v in data.items() if k != "meta_json"})
    elif kind == "bad_json":
        _npz(p, **{**data, "meta_json": np.array("{nope")})
    elif kind == "meta_missing_params":
        _npz(p, **{**data, "meta_json": np.array(json.dumps({k: v for k, v in meta.items() if k != "params"}))})
    elif kind == "meta_bad_param":
        meta["params"]["Mb"] = "heavy"
        _npz(p, **{**data, "meta_json": np.array(json.dumps(meta))})
    elif kind == "meta_list":
        _npz(p, **{**data, "meta_json": np.array("[1, 2]")})
    elif kind == "pickled":
        buf = io.BytesIO()
        np.savez(buf, **{**data, "state": np.array([object()], dtype=object)})
        p.write_bytes(buf.getvalue())
    elif kind == "state_shape":
        _npz(p, **{**data, "state": data["state"][:, :5]})
    elif kind == "time_2d":
        _npz(p, **{**data, "time": data["time"][:, None]})
    elif kind == "no_rows":
        _npz(p, **{**data, "time": data["time"][:0], "state": data["state"][:0]})
    elif kind == "not_npy_member":
        with zipfile.ZipFile(p, "w") as zf:
            zf.writestr("state.npy", b"garbage")
            zf.writestr("meta_json.npy", b"garbage")
    elif kind == "all_nan":
        _npz(p, **{**data, "state": np.full_like(data["state"], np.nan)})
    return p


KINDS = ["empty", "random", "truncated", "no_meta", "bad_json", "meta_missing_params", "meta_bad_param",
         "meta_list", "pickled", "state_shape", "time_2d", "no_rows", "not_npy_member", "all_nan"]


@pytest.mark.parametrize("kind", KINDS)
def test_damaged_npz_is_one_line_exit_2(good, tmp_path, capsys, kind):
    bad = _variant(good, tmp_path, kind)
    assert cli.main(["animate", str(bad), "-o", str(tmp_path / "a.gif"), "--max-frames", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("ballbot animate: error:"), err
    assert str(bad) in err or "finite" in err
    assert not (tmp_path / "a.gif").exists()


def test_the_good_log_still_loads(good):
    log = load_log(good)
    assert log["state"].shape == (log["time"].shape[0], 12) and log.params == load_params()
