"""The firmware's 200 Hz example (``example_main.c``) run on the host (``example_host.c``):
SysTick registers as variables, each idle wait one timer interrupt.  With its board stubs
(at rest: gravity on the accelerometer's z axis, no rotation, failed encoders) and the
library's defaults, the robot it drives is upright and at rest, so its estimate is too and
its torques are nearly zero; the timer is set to 200 Hz on a 400 MHz core and a period
that overran is counted once."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.toolchain import compiler_command
from ballbot_casadi.firmware.build import FW_CFLAGS, build_firmware
from ballbot_casadi.firmware.toolchain import INSTALL_HINT, missing_tools

pytestmark = [pytest.mark.needs_cc, pytest.mark.skipif(bool(missing_tools()), reason=INSTALL_HINT)]

TICKS = 200  # 1 s
OVERRUN_AT = 17
HARNESS = Path(__file__).with_name("example_host.c")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    b = build_firmware(precision="double")
    exe = tmp_path_factory.mktemp("example") / "example_host"
    src = b.folder / "src"
    subprocess.run([*compiler_command(), *FW_CFLAGS, "-I", str(b.include), "-I", str(src),
                    f"-DEXAMPLE_TICKS={TICKS}", f"-DEXAMPLE_OVERRUN_AT={OVERRUN_AT}", "-o", str(exe),
                    str(HARNESS), *(str(src / n) for n in ("ballbot_fw.c", "ballbot_fw_cg.c",
                                                          "ballbot_fw_defaults.c")), "-lm"],
                   check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True, timeout=60)
    return json.loads(out.stdout)


def test_the_example_sets_a_200_hz_systick_on_a_400_mhz_core(run):
    assert (run["rvr"], run["cvr"], run["csr"]) == (400_000_000 // 200 - 1, 0, 0b111)
    assert run["overruns"] == 1  # the one period whose COUNTFLAG was set
    assert (run["period"], run["faults"]) == (TICKS, 0)


def test_the_example_balances_at_rest_in_the_velocity_cascade(run):
    assert run["cascade"] == 1.0
    x = np.array(run["x_hat"])
    np.testing.assert_allclose(x[STATE["q"]], [1.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(x[STATE["dq"]], 0.0, rtol=0, atol=1e-7)
    np.testing.assert_allclose(x[[STATE.index("dx"), STATE.index("dy")]], 0.0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(run["q_ref_used"], [1.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(run["tau_cmd"], 0.0, rtol=0, atol=1e-5)
    assert run["rejections"] == [0, 0, 0, 0] and run["repairs"] == [0]


def test_the_board_stubs_read_a_robot_at_rest_with_failed_encoders(run):
    """Every entry the stubs hand the step is written: gravity on the accelerometer's z axis
    only, no rotation, the three encoders NaN (failed)."""
    assert run["acc"] == [0.0, 0.0, 9.81] and run["gyro"] == [0.0, 0.0, 0.0]
    assert run["enc_nan"] == [1, 1, 1]
