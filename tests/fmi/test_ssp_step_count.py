"""How many fixed steps an SSP run takes (ballbot_casadi.fmi.masters.ssp_run._steps): the
duration or stop - start time over the step, a whole number within a relative 1e-9, at most
MAX_STEPS = 720000 from the SSP's own stop time unless allowed (issue 23: the tolerance scaled
the wrong way, and the bounds, were never pinned)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from ballbot_casadi.errors import FileFormatError, ScenarioError
from ballbot_casadi.fmi.masters.ssp_run import _steps
from ballbot_casadi.fmi.system.ssp_check import MAX_STEPS

SSP = Path("run.ssp")


def _system(step, stop_time=None, start_time=0.0):
    return SimpleNamespace(step=step, stop_time=stop_time, start_time=start_time)


def test_max_steps_is_720000():
    assert MAX_STEPS == 720_000


def test_the_stop_time_counts_from_the_start_time():
    assert _steps(SSP, _system(0.25, stop_time=2.0, start_time=0.5), None, False) == 6


@pytest.mark.parametrize("duration, n", [(3000.0000005, 3000), (7.0, 7), (0.5, None)])
def test_the_whole_number_tolerance_is_relative_to_the_duration(duration, n):
    # 5e-7 s off a 3000 s run is inside 1e-9 * 3000 s; half a step is never a whole number
    if n is None:
        with pytest.raises(ScenarioError) as e:
            _steps(SSP, _system(1.0), duration, False)
        assert str(e.value) == "duration 0.5 s must be a positive multiple of the step 1.0 s"
    else:
        assert _steps(SSP, _system(1.0), duration, False) == n


def test_a_duration_beyond_the_tolerance_is_refused():
    with pytest.raises(ScenarioError, match=r"^duration 3000\.00001 s must be a positive multiple"):
        _steps(SSP, _system(1.0), 3000.00001, False)


def test_the_step_limit_applies_to_the_ssps_own_stop_time_only():
    assert _steps(SSP, _system(0.5, stop_time=MAX_STEPS * 0.5), None, False) == MAX_STEPS
    with pytest.raises(ScenarioError) as e:
        _steps(SSP, _system(0.5, stop_time=(MAX_STEPS + 1) * 0.5), None, False)
    assert str(e.value) == (f"run.ssp: its stop time asks for {MAX_STEPS + 1} steps of 0.5 s "
                            f"(360000 s), more than {MAX_STEPS}; give --duration, or "
                            "--allow-long to run it all")
    assert _steps(SSP, _system(0.5, stop_time=(MAX_STEPS + 1) * 0.5), None, True) == MAX_STEPS + 1
    assert _steps(SSP, _system(0.5), (MAX_STEPS + 1) * 0.5, False) == MAX_STEPS + 1


def test_no_fixed_step_is_a_file_format_error():
    with pytest.raises(FileFormatError, match="has no fixed step"):
        _steps(SSP, _system(None, stop_time=1.0), None, False)
