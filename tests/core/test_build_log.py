"""Every compiler run can be logged ($BALLBOT_BUILD_LOG), and a library's C is compiled once.

The log is how the test suite's compile count and gcc CPU seconds are measured (one JSON
line per tool run); the generated C of a library is compiled to one object from which the
shared library is linked and the static archive is made.
"""

from __future__ import annotations

import hashlib
import json

import casadi as ca
import pytest

from ballbot_casadi.core import toolchain as tc

pytestmark = pytest.mark.needs_cc


def _functions() -> list[ca.Function]:
    x = ca.SX.sym("x", 2)
    return [ca.Function("ballbot_log_probe", [x], [ca.vertcat(2 * x[0] - x[1], x[0] * x[1])],
                        ["x"], ["y"])]


def _entries(log) -> list[dict]:
    return [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []


def test_a_library_is_compiled_once_and_every_tool_run_is_logged(tmp_path, monkeypatch):
    log = tmp_path / "builds.jsonl"
    monkeypatch.setenv("BALLBOT_BUILD_LOG", str(log))
    lib = tc.build_library("log_probe", _functions(), root=tmp_path)
    assert lib.status == "built"
    entries = _entries(log)
    want = hashlib.sha256(lib.source.read_bytes()).hexdigest()[:16]
    compiles = [e for e in entries if e["sources"]]
    # exactly one gcc run reads the generated C: the object both libraries are made of
    assert len(compiles) == 1
    assert compiles[0]["sources"] == {"log_probe.c": want}
    assert "-c" in compiles[0]["flags"] and "-fPIC" in compiles[0]["flags"]
    assert [e["tool"] for e in entries] == [compiles[0]["tool"], compiles[0]["tool"], "ar"]
    assert all(e["cpu_s"] >= 0.0 and e["wall_s"] >= 0.0 for e in entries)
    # the shared library (linked from that object) computes the function
    f = tc.load_library(lib, ["ballbot_log_probe"])["ballbot_log_probe"]
    assert ca.DM(f([3.0, 5.0])).full().ravel().tolist() == [1.0, 15.0]
    # a cached build runs no tool
    assert tc.build_library("log_probe", _functions(), root=tmp_path).status == "cached"
    assert len(_entries(log)) == len(entries)


def test_without_the_variable_nothing_is_logged(tmp_path, monkeypatch):
    monkeypatch.delenv("BALLBOT_BUILD_LOG", raising=False)
    monkeypatch.chdir(tmp_path)
    tc.build_library("log_probe", _functions(), root=tmp_path / "b")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]
