"""The firmware with the matched VUKF adapting its acceleration walk (``ukf_adaptive``,
issue 22): its period on this PC in the closed loop and its Cortex-M7 build's host replay
equal the compiled mission with the same estimator; its state carries the walk estimate."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.firmware.build import build_firmware, default_scenario
from ballbot_casadi.firmware.closed_loop import run_firmware_scenario
from ballbot_casadi.firmware.replay import (
    REPLAY_ATOL,
    record_log,
    replay_scenario,
    run_host,
    run_qemu,
)
from ballbot_casadi.firmware.sources import firmware_function, scenario_values
from ballbot_casadi.firmware.toolchain import INSTALL_HINT, missing_tools
from ballbot_casadi.sim.closed_loop import run_scenario
from ballbot_casadi.sim.embedded import software_layout
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario

pytestmark = pytest.mark.needs_cc

EST = "ukf_adaptive"
#: The replayed periods (1 s: the walk's growing-memory start and its steady weighting).
N = 200


def test_the_firmware_state_carries_the_walk_and_starts_it_at_zero():
    f = firmware_function("flc", EST)
    layout = software_layout(f, EST)
    assert layout.size_of("walk") == 3
    c0 = scenario_values(f, default_scenario("flc", EST)).c0
    np.testing.assert_array_equal(c0[layout["walk"]], 0.0)  # the configured Qv is the prior
    assert f.numel_in(0) == software_layout(firmware_function("flc", "ukf"), "ukf").size + 3


def test_double_loop_with_the_adaptive_filter_is_the_compiled_mission():
    sc = load_scenario_file(resolve_scenario("full_sine")).scenario.replace(
        duration=1.0, estimator=EST)
    ref, got = run_scenario(sc), run_firmware_scenario(sc, "double")
    for k in ("state", "tau", "x_hat", "meas"):
        np.testing.assert_allclose(got[k], ref[k], rtol=0, atol=1e-9, err_msg=k)
    thesis = run_scenario(sc.replace(estimator="ukf"))  # and it is not the thesis's filter
    assert np.max(np.abs(ref["x_hat"] - thesis["x_hat"])) > 1e-5


@pytest.mark.firmware
@pytest.mark.skipif(bool(missing_tools()), reason=INSTALL_HINT)
def test_host_replay_and_qemu_of_the_adaptive_build_are_the_compiled_mission():
    rec = record_log(replay_scenario(N, seed=1, estimator=EST))
    fw = build_firmware(estimator=EST, precision="double")
    host = run_host(fw, rec)
    np.testing.assert_allclose(host.tau, rec.tau_mission, rtol=0, atol=1e-12)
    assert np.max(np.abs(rec.tau_mission)) > 0.1  # the sine needs real torque
    q = run_qemu(fw, rec)
    np.testing.assert_allclose(q.tau, host.tau, rtol=0, atol=REPLAY_ATOL["double"])
    # the gyroscope drop-out (0.3 .. 0.35 s) and period 0 (no encoder count) predict only
    assert set(np.flatnonzero(q.rc == 1)) == {0, *range(60, 70)}
