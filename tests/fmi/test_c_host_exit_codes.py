"""The plain-C plant host (fmu/tools/host.c with fmi2_host.h): each failure has its own exit
status and message, as its usage line documents, and the benchmark field appears only when asked.

Statuses: 2 usage, 3 the binary cannot be loaded, 4 fmi2Instantiate refused, 5 the
initialisation refused, 6 a step refused, 7 a value not read (the plant behind a library
that breaks one rule, ``_broken_fmu``, for the failures a correct FMU never causes)."""

from __future__ import annotations

import json
import math
import os
import subprocess

import numpy as np
import pytest
from _broken_fmu import build_broken, build_not_an_fmu
from _fmu_support import Plant, plant_build, vr_table

from ballbot_casadi.fmi.build import build_tool

pytestmark = pytest.mark.needs_cc


def _host(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    b = plant_build()
    exe = build_tool(b, "host")
    return subprocess.run([str(exe), *[a.format(lib=b.binary, guid=b.guid) for a in args]],
                          capture_output=True, text=True, timeout=60,
                          env=None if env is None else {**os.environ, **env})


def test_too_few_arguments_print_the_usage_and_exit_2():
    res = _host("{lib}", "{guid}", "1", "0.005", "0", "0", "0")  # no roll0
    assert res.returncode == 2 and res.stdout == ""
    exe = build_tool(plant_build(), "host")
    assert res.stderr == (f"usage: {exe} lib guid n_steps step tau0 tau1 tau2 roll0 "
                          "[bench_reps]\n")   # names the program, not an argument


def test_a_missing_binary_exits_3_with_the_loader_message(tmp_path):
    res = _host(str(tmp_path / "none.so"), "{guid}", "1", "0.005", "0", "0", "0", "0")
    assert res.returncode == 3
    assert "dlopen failed" in res.stderr and res.stdout == ""
    res = _host(str(build_not_an_fmu(tmp_path)), "{guid}", "1", "0.005", "0", "0", "0", "0")
    assert (res.returncode, res.stdout, res.stderr) == (3, "", "missing symbol fmi2Instantiate\n")


def test_a_wrong_guid_exits_4_with_the_fmus_reason():
    res = _host("{lib}", "not-the-guid", "1", "0.005", "0", "0", "0", "0")
    assert (res.returncode, res.stdout) == (4, "")
    assert "GUID" in res.stderr.upper()   # the FMU's own log line says why
    assert res.stderr.endswith(f"{build_tool(plant_build(), 'host')}: fmi2Instantiate refused the FMU\n")


def test_a_refused_initialisation_exits_5():
    res = _host("{lib}", "{guid}", "1", "0.005", "nan", "0", "0", "0")  # NaN torque input
    assert res.returncode == 5, res.stderr
    assert "tau0" in res.stderr and res.stdout == ""
    assert res.stderr.endswith(f"{_exe()}: the initialisation was refused\n")


def test_a_refused_step_exits_6():
    res = _host("{lib}", "{guid}", "1", "-0.005", "0", "0", "0", "0")  # a negative step
    assert res.returncode == 6, res.stderr
    assert "fmi2DoStep" in res.stderr and "(status 3)" in res.stderr and res.stdout == ""
    assert res.stderr.endswith(f"{_exe()}: step 0 was refused\n")


@pytest.fixture(scope="module")
def broken(tmp_path_factory) -> str:
    return str(build_broken(tmp_path_factory.mktemp("broken_fmu")))


def _exe() -> str:
    return str(build_tool(plant_build(), "host"))


@pytest.mark.parametrize(("rule", "n", "ok", "status", "line"), [
    ("setreal", "3", "1", 5, "the initialisation was refused"),   # its second fmi2SetReal
    ("setreal", "3", "2", 6, "step 0 was refused"),
    ("setreal", "3", "4", 6, "step 2 was refused"),               # 2 at start, 2 steps
    ("getreal", "1", "0", 7, "the states were not read after step 0"),
    ("getreal", "0", "0", 7, "the outputs were not read"),        # no step: the outputs
    ("none", "3", "0", 0, ""),
])
def test_a_failure_after_instantiation_has_its_status_and_line(broken, rule, n, ok, status, line):
    """Through the plant behind a library that breaks one rule: each failure exits with its
    documented status, prints nothing on stdout and one line naming it (steps counted from
    0); the same library keeping every rule ("none") runs to the end."""
    res = _host(broken, "{guid}", n, "0.005", "0", "0", "0", "0",
                env={"BROKEN_RULE": rule, "SETREAL_OK": ok})
    if status == 0:
        assert res.returncode == 0 and json.loads(res.stdout)["t"] == pytest.approx(0.015, abs=1e-15)
    else:
        assert (res.returncode, res.stdout, res.stderr) == (status, "", f"{_exe()}: {line}\n")


def test_upright_at_rest_stays_there_and_the_repetitions_restart_from_it():
    """No torque from the upright rest state: an equilibrium, read back exactly; with
    repetitions each starts a fresh instance, so the end state is the same."""
    rest = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    for reps in ("0", "2"):
        res = _host("{lib}", "{guid}", "3", "0.005", "0", "0", "0", "0", reps)
        assert res.returncode == 0, res.stderr
        out = json.loads(res.stdout)
        assert out["t"] == pytest.approx(0.015, rel=0, abs=1e-15)
        assert out["x"] == rest
        assert 0.0 < out["step_us"] < 1e300  # measured: not the initial "none yet" value


def test_the_outputs_it_prints_are_the_fmus_outputs_in_order():
    """From roll0 = 0.05 rad, three steps without torque: the 15 continuous outputs the
    host prints (roll, pitch, yaw, wheel rates, IMU, encoders: value references from
    roll on) equal the same FMU's outputs read through fmpy after the same steps."""
    res = _host("{lib}", "{guid}", "3", "0.005", "0", "0", "0", "0.05")
    assert res.returncode == 0, res.stderr
    y = json.loads(res.stdout)["y"]
    table = vr_table()
    names = [n for n, v in sorted(table.items(), key=lambda kv: kv[1])
             if table["roll"] <= v < table["roll"] + 15]
    assert len(y) == len(names) == 15 and names[0] == "roll" and names[-1] == "enc2"
    p = Plant("cs", name="same")
    try:
        p.init(x0_q0=math.cos(0.025), x0_q1=math.sin(0.025), x0_q2=0.0, x0_q3=0.0)
        p.step(0.005, 3)
        np.testing.assert_allclose(y, p.get(*names), rtol=1e-14, atol=1e-300)
    finally:
        p.free()
    assert y[0] == pytest.approx(0.05, abs=1e-3)   # the roll it started from, barely moved
