"""Every compiler run can be logged ($BALLBOT_BUILD_LOG), and a library's C is compiled once.

The log is how the test suite's compile count and gcc CPU seconds are measured (one JSON
line per tool run); the generated C of a library is compiled to one object from which the
shared library is linked and the static archive is made.
"""

from __future__ import annotations

import hashlib
import json
import time

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
    t0 = time.perf_counter()
    lib = tc.build_library("log_probe", _functions(), root=tmp_path)
    elapsed = time.perf_counter() - t0
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
    # each tool's wall time is a part of the build's: together at most the build's own
    assert 0.0 < sum(e["wall_s"] for e in entries) <= elapsed + 0.0015 * len(entries)
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


def _line(what: str, tool: str, sources: dict, cpu: float, flags=("-O3",)) -> str:
    return json.dumps({"what": what, "tool": tool, "sources": sources, "flags": list(flags),
                       "cpu_s": cpu, "wall_s": 2 * cpu, "pid": 1}) + "\n"


def test_the_summary_counts_compiles_and_names_the_same_sources_compiled_again(tmp_path):
    log = tmp_path / "builds.jsonl"
    old = _line("compiling old", "gcc", {"o.c": "00"}, 100.0)
    log.write_text(old + _line("compiling a", "gcc", {"a.c": "aa"}, 20.0, ("-c",))
                   + _line("linking a (shared)", "gcc", {}, 0.5, ("-shared",))
                   + _line("archiving a", "ar", {}, 0.1)
                   + _line("compiling the FMU", "gcc", {"a.c": "aa", "f.c": "ff"}, 30.0)
                   + _line("compiling the FMU again", "gcc", {"f.c": "ff", "a.c": "aa"}, 31.0, ("-O2",))
                   + _line("cross-compiling a.c", "arm-none-eabi-gcc", {"a.c": "aa"}, 25.0)
                   + _line("compiling a (other C)", "gcc", {"a.c": "ab"}, 19.0)
                   + '{"what": "torn li\n')  # a writer killed mid-line: skipped
    s = tc.build_log_summary(log, offset=len(old.encode()))  # the lines before a run skipped
    assert s["compiles"] == 5
    assert s["cpu_s"] == pytest.approx(20.0 + 30.0 + 31.0 + 25.0 + 19.0, abs=1e-9)
    # same tool and the same sources (flags aside) twice; another compiler or other C is not
    assert s["repeated"] == [("compiling the FMU", 2, 61.0)]
    assert tc.build_log_summary(log)["compiles"] == 6


def test_a_logged_line_holds_the_child_cpu_and_wall_seconds_to_the_millisecond(tmp_path):
    """Each entry's seconds are the child CPU used since the run began and the wall time
    given, rounded to 1 ms (a hand-built rusage: user 1.2 s and system 0.3 s before)."""
    src = tmp_path / "m.c"
    src.write_text("int m;\n")
    before = tc.resource.getrusage(tc.resource.RUSAGE_CHILDREN)
    fields = {k: getattr(before, k) for k in dir(before) if k.startswith("ru_")}
    fields.update(ru_utime=before.ru_utime - 1.2, ru_stime=before.ru_stime - 0.3)
    cpu0 = type("R", (), fields)()
    log = tmp_path / "sub" / "log.jsonl"
    tc._log_tool(log, ["/usr/bin/gcc", "-c", "-O3", "-Iinc", "-o", "m.o", str(src)],
                 "compiling m", cpu0, 0.12345)
    (entry,) = _entries(log)
    assert entry["wall_s"] == 0.123  # rounded to 1 ms, not 0.1235
    assert entry["cpu_s"] == pytest.approx(1.5, abs=1.5e-3)
    assert entry["tool"] == "gcc" and entry["what"] == "compiling m"
    assert entry["flags"] == ["-c", "-O3"]  # include and output flags left out
    assert entry["sources"] == {"m.c": hashlib.sha256(b"int m;\n").hexdigest()[:16]}


def test_the_log_may_name_a_folder_not_made_yet(tmp_path, monkeypatch):
    """``$BALLBOT_BUILD_LOG`` in folders that do not exist yet: they are made, and a second
    run appends to the same file."""
    log = tmp_path / "new" / "deeper" / "builds.jsonl"
    monkeypatch.setenv("BALLBOT_BUILD_LOG", str(log))
    tc.run_tool(["true", "-v"], "probing")
    tc.run_tool(["true"], "probing again")
    assert [(e["what"], e["tool"], e["flags"]) for e in _entries(log)] == [
        ("probing", "true", ["-v"]), ("probing again", "true", [])]
