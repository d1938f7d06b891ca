"""The plain-C controller host (fmu/tools/controller_host.c): the failures a correct
controller FMU never causes, through its binary behind a library that breaks one rule
(``_broken_fmu``). Each exits with its documented status (3 a binary without the FMI
functions, 5 initialisation, 6 a period, 7 non-finite torques), prints nothing on stdout
and one line naming it (periods counted from 0). Usage (2) and a wrong GUID (4) are tested
with the FMU itself in test_controller_fmu.py."""

from __future__ import annotations

import json
import os
import subprocess

import pytest
from _broken_fmu import build_broken, build_not_an_fmu
from _controller_support import controller_build

from ballbot_casadi.fmi.build import build_tool

pytestmark = pytest.mark.needs_cc


@pytest.fixture(scope="module")
def broken(tmp_path_factory) -> str:
    return str(build_broken(tmp_path_factory.mktemp("broken_controller"), controller_build()))


@pytest.mark.parametrize(("rule", "ok", "status", "line"), [
    ("init", "0", 5, "the initialisation failed"),
    ("getreal", "0", 6, "period 0 failed"),          # the torques not read
    ("setreal", "3", 6, "period 3 failed"),          # the readings of the fourth period refused
    ("nanreal", "0", 7, "non-finite torques after 5 periods"),
    ("none", "0", 0, ""),
])
def test_a_failure_after_instantiation_has_its_status_and_line(broken, rule, ok, status, line):
    b = controller_build()
    exe = str(build_tool(b, "controller_host"))
    res = subprocess.run([exe, broken, b.guid, "5", "0"], capture_output=True, text=True, timeout=60,
                         env={**os.environ, "BROKEN_RULE": rule, "SETREAL_OK": ok})
    if status == 0:
        assert res.returncode == 0, res.stderr
        assert json.loads(res.stdout)["t"] == pytest.approx(5 * 0.005, abs=1e-15)
    else:
        assert (res.returncode, res.stdout, res.stderr) == (status, "", f"{exe}: {line}\n")


def test_a_binary_without_the_fmi_functions_exits_3_naming_the_first_missing(tmp_path):
    b = controller_build()
    res = subprocess.run([str(build_tool(b, "controller_host")), str(build_not_an_fmu(tmp_path)),
                          b.guid, "5", "0"], capture_output=True, text=True, timeout=60)
    assert (res.returncode, res.stdout, res.stderr) == (3, "", "missing symbol fmi2Instantiate\n")
