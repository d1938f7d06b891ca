"""The package constants against their sources: thesis §7.1's six design specifications
read from the thesis text itself (each number parsed from its list item, so a changed
limit, a swapped key or a degree/radian slip shows), and the 200 Hz control period with
its 1 ms plant step."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import pytest

from ballbot_casadi.core.constants import N_SUB, THESIS_LIMITS, TS_CONTROL

THESIS = Path(os.environ.get("BALLBOT_REFERENCE_DIR",
                             Path(__file__).resolve().parents[3] / "shared" / "reference")
              ) / "thesis-ballbot-control-2020.txt"


def _section_7_1() -> str:
    text = THESIS.read_text()
    start = text.index("7.1 System characteristics and design specification\n\nThe ball-robot")
    return text[start:start + 2500]


@pytest.mark.skipif(not THESIS.is_file(), reason="thesis text not available")
def test_limits_are_the_numbers_of_thesis_section_7_1():
    sec = _section_7_1()
    items = {int(m.group(1)): m.group(2) for m in re.finditer(r"^(?:- )?(\d)\. (.*)$", sec, re.M)}
    assert sorted(items) == [1, 2, 3, 4, 5, 6]

    def number(i: int) -> float:
        return float(re.search(r"(\d+(?:\.\d+)?)\s*(?:m/s|rad/s|\^\{\\circ\})", items[i]).group(1))

    assert "translational velocity" in items[1] and "m/s" in items[1]
    assert "Linear acceleration" in items[2] and "m/s^2" in items[2]
    assert "heading velocity" in items[3] and "rad/s" in items[3]
    assert "Angular acceleration" in items[4] and "rad/s^2" in items[4]
    assert "Inclination limit" in items[5] and "circ" in items[5]
    assert "inclination less than" in items[6] and "circ}/s" in items[6]
    want = {"v_max": number(1), "a_max": number(2), "yaw_rate_max": number(3),
            "yaw_acc_max": number(4), "tilt_max": math.radians(number(5)),
            "tilt_rate_max": math.radians(number(6))}
    assert want == pytest.approx({"v_max": 0.5, "a_max": 1.0, "yaw_rate_max": 1.0,
                                  "yaw_acc_max": 10.0, "tilt_max": math.radians(5.0),
                                  "tilt_rate_max": math.radians(20.0)}, rel=1e-15)
    assert dict(THESIS_LIMITS) == pytest.approx(want, rel=1e-15)
    assert set(THESIS_LIMITS) == set(want)


def test_limits_by_hand_and_read_only():
    """Without the thesis text: the same six values by hand (SI units, radians)."""
    assert THESIS_LIMITS["v_max"] == 0.5 and THESIS_LIMITS["a_max"] == 1.0
    assert THESIS_LIMITS["yaw_rate_max"] == 1.0 and THESIS_LIMITS["yaw_acc_max"] == 10.0
    assert THESIS_LIMITS["tilt_max"] == pytest.approx(5.0 * math.pi / 180.0, rel=1e-15)
    assert THESIS_LIMITS["tilt_rate_max"] == pytest.approx(20.0 * math.pi / 180.0, rel=1e-15)
    with pytest.raises(TypeError):
        THESIS_LIMITS["v_max"] = 1.0  # type: ignore[index]


def test_control_period_is_200_hz_with_a_1_ms_plant_step():
    assert TS_CONTROL == pytest.approx(1.0 / 200.0, rel=1e-15)
    assert N_SUB == 5 and TS_CONTROL / N_SUB == pytest.approx(1e-3, rel=1e-12)
