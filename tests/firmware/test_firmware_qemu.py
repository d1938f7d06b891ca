"""The firmware library in QEMU (Cortex-M7) against the host: replay, precision, NaN readings."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.firmware.build import build_firmware
from ballbot_casadi.firmware.cost import max_frame
from ballbot_casadi.firmware.replay import (
    REPLAY_ATOL,
    record_log,
    replay_scenario,
    run_host,
    run_qemu,
)
from ballbot_casadi.firmware.sources import FirmwareValues
from ballbot_casadi.firmware.toolchain import ARM_CPU_FLAGS, INSTALL_HINT, missing_tools

pytestmark = [pytest.mark.firmware, pytest.mark.needs_cc,
              pytest.mark.skipif(bool(missing_tools()), reason=INSTALL_HINT)]

N = 200


@pytest.fixture(scope="module")
def rec():
    return record_log(replay_scenario(N, seed=1))


@pytest.fixture(scope="module")
def fw_double():
    return build_firmware(precision="double")


@pytest.fixture(scope="module")
def host(fw_double, rec):
    return run_host(fw_double, rec)


def test_host_replay_is_the_compiled_mission(rec, host):
    # same Function, same readings: the library on the host gives the mission's torques
    np.testing.assert_allclose(host.tau, rec.tau_mission, rtol=0, atol=1e-12)
    assert np.max(np.abs(rec.tau_mission)) > 0.1  # the sine needs real torque


def test_qemu_double_equals_host(fw_double, rec, host):
    q = run_qemu(fw_double, rec)
    np.testing.assert_allclose(q.tau, host.tau, rtol=0, atol=REPLAY_ATOL["double"])
    # the gyroscope drop-out (0.3 .. 0.35 s) and period 0 (no encoder count) predict only
    assert set(np.flatnonzero(q.rc == 1)) == {0, *range(60, 70)}
    assert q.rc.min() == 0
    # the instruction-count calibration: SysTick at 25 MHz, 1 instruction per ns
    assert q.instructions_per_tick == pytest.approx(40.0, rel=1e-3)
    # the step's stack high-water mark (painted stack): at least the library's largest frame
    # from -fstack-usage, and that frame is most of it (the call chain above it is shallow)
    frame = max_frame(fw_double)[1]
    assert 256 <= frame <= q.stack_bytes <= frame + 4096, (frame, q.stack_bytes)


def test_qemu_single_within_tolerance(rec, host):
    q = run_qemu(build_firmware(precision="single"), rec)
    err = np.max(np.abs(q.tau - host.tau))
    assert err <= REPLAY_ATOL["single"]
    assert err > 1e-9  # it is really float arithmetic
    assert q.real_bytes == 4


def test_changed_parameter_fails_the_comparison(fw_double, rec, host):
    params = dict(rec.values.params)
    params["k_bal"] = params["k_bal"] * 1.02
    changed = replace(rec, values=FirmwareValues(params, rec.values.c0))
    q = run_qemu(fw_double, changed)
    assert np.max(np.abs(q.tau - host.tau)) > 100 * REPLAY_ATOL["double"]


def test_soft_float_abi_library_does_not_link():
    flags = [f.replace("-mfloat-abi=hard", "-mfloat-abi=softfp") for f in ARM_CPU_FLAGS["double"]]
    with pytest.raises(BuildError, match="VFP register arguments"):
        build_firmware(precision="double", lib_cpu_flags=flags)


def test_nan_and_inf_readings_give_finite_torques(fw_double, rec):
    n = 40
    meas = rec.meas[:n].copy()
    meas[10:15, :] = np.nan          # every sensor missing
    meas[20, 0] = np.inf             # a broken accelerometer axis
    meas[25:30, 3:6] = np.nan        # gyroscope missing
    short = replace(rec, meas=meas, refs=rec.refs[:n], tau_mission=rec.tau_mission[:n])
    q = run_qemu(fw_double, short)
    h = run_host(fw_double, short)
    assert np.all(np.isfinite(q.tau))
    assert set(np.flatnonzero(q.rc == 1)) == {0, *range(10, 15), 20, *range(25, 30)}
    # the predict-only periods are the host step's
    np.testing.assert_allclose(q.tau, h.tau, rtol=0, atol=REPLAY_ATOL["double"])
    # and not the torques of the complete readings
    assert np.max(np.abs(q.tau[10:15] - rec.tau_mission[10:15])) > 1e-6
