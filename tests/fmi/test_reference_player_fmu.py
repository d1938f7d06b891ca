"""The reference player FMU, built and stepped (fmpy): row k of its table from
t_k = startTime + k Ts until the next row (a step ending within GRID_TOL Ts of an instant
is at that instant), the last row held after the table's end, from any start time.

The table is the balance scenario's roll sine with a wheel disturbance, so consecutive rows
differ: a step that outputs the wrong row shows."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi.fmi.package import build_fmu_from_spec
from ballbot_casadi.fmi.reference_player.player import (
    GRID_TOL,
    MODEL_IDENTIFIER,
    OUTPUT_NAMES,
    reference_player_spec,
    reference_table,
)
from ballbot_casadi.sim.scenario.file import parse_scenario

pytestmark = pytest.mark.needs_cc

TS = 0.005
SC = parse_scenario({"name": "rfmu", "duration_s": 0.05, "estimator": "ukf",
                     "attitude": {"roll": {"type": "sine", "amplitude_deg": 3.0,
                                           "frequency_hz": 5.0}},
                     "torque_disturbance": [{"t_start_s": 0.02, "t_end_s": 0.03,
                                             "tau_nm": [0.5, 0.0, -0.25]}]}).scenario


class Player:
    """One fmpy Co-Simulation instance of the player."""

    def __init__(self, build, start: float) -> None:
        from fmpy.fmi2 import FMU2Slave

        spec = reference_player_spec(SC)
        self.vr = {v.name: v.vr for v in spec.variables}
        self.fmu = FMU2Slave(guid=build.guid, unzipDirectory=str(build.unzipped),
                             modelIdentifier=MODEL_IDENTIFIER, instanceName="ref")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=start)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def outputs(self) -> tuple[int, np.ndarray]:
        row = self.fmu.getInteger([self.vr["row"]])[0]
        return row, np.array(self.fmu.getReal([self.vr[n] for n in OUTPUT_NAMES]))

    def free(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture(scope="module")
def player_build(tmp_path_factory):
    return build_fmu_from_spec(reference_player_spec(SC), tmp_path_factory.mktemp("ref_fmu"))


@pytest.fixture(scope="module")
def table():
    t = reference_table(SC)
    assert t.shape == (10, len(OUTPUT_NAMES))
    assert np.all(np.abs(np.diff(t[:, 1])) > 1e-4)  # every row differs from the next
    return t


@pytest.mark.parametrize("start", [0.0, 2.5])
def test_each_step_outputs_the_row_of_its_end_and_holds_the_last(player_build, table, start):
    p = Player(player_build, start)
    row, y = p.outputs()
    assert row == 0
    np.testing.assert_array_equal(y, table[0])
    t, got = start, []
    for _ in range(14):  # four steps past the table's end
        p.fmu.doStep(t, TS)
        t = start + (len(got) + 1) * TS
        got.append(p.outputs())
    p.free()
    want = [min(k, 9) for k in range(1, 15)]
    assert [r for r, _ in got] == want
    for (_, y), k in zip(got, want):
        np.testing.assert_array_equal(y, table[k])


def test_a_step_within_the_grid_tolerance_ends_at_the_instant(player_build, table):
    p = Player(player_build, 0.0)
    t1, t2 = 3 * TS - 0.5 * GRID_TOL * TS, 5 * TS - 3 * GRID_TOL * TS
    p.fmu.doStep(0.0, t1)  # just short of t_3: row 3
    assert p.outputs()[0] == 3
    p.fmu.doStep(t1, t2 - t1)  # short of t_5 by more than the tolerance: row 4
    row, y = p.outputs()
    p.free()
    assert row == 4
    np.testing.assert_array_equal(y, table[4])


def test_a_long_step_past_the_end_holds_the_last_row(player_build, table):
    p = Player(player_build, 1.0)
    p.fmu.doStep(1.0, 1.0)  # 200 periods in one step
    row, y = p.outputs()
    p.free()
    assert row == 9
    np.testing.assert_array_equal(y, table[9])
