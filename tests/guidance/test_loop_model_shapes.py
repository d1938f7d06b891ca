"""The MPC's prediction model (``LoopModel``) refuses a wrong shape in one line naming the
matrix, whichever builder made it: the sampled loop, the full-order and the shape model all
give 14 x 14 / 14 x 2 dynamics and two rows per output."""

from __future__ import annotations

import re

import numpy as np
import pytest

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.guidance.prediction import LOOP_OUTPUTS, NXL, LoopModel


def _parts():
    A, B = np.eye(NXL), np.zeros((NXL, 2))
    C = {k: np.zeros((2, NXL)) for k in LOOP_OUTPUTS}
    D = {k: np.zeros((2, 2)) for k in LOOP_OUTPUTS}
    return A, B, C, D


def test_the_outputs_are_named_once():
    assert LOOP_OUTPUTS == ("v", "tilt", "tilt_rate", "acc", "tilt_acc")
    A, B, C, D = _parts()
    assert LoopModel(A, B, C, D, 0.1).dt == 0.1


@pytest.mark.parametrize("which, key, shape, text", [
    ("A", None, (NXL, NXL - 1), "A must be 14x14, got (14, 13)"),
    ("B", None, (NXL, 3), "B must be 14x2, got (14, 3)"),
    ("C", "tilt", (1, NXL), "C['tilt'] must be 2x14, got (1, 14)"),
    ("D", "tilt", (1, 2), "D['tilt'] must be 2x2, got (1, 2)"),
    ("D", "tilt_acc", (2, 3), "D['tilt_acc'] must be 2x2, got (2, 3)"),
])
def test_a_wrong_shape_is_refused_by_name(which, key, shape, text):
    A, B, C, D = _parts()
    parts = {"A": A, "B": B, "C": C, "D": D}
    if key is None:
        parts[which] = np.zeros(shape)
    else:
        parts[which][key] = np.zeros(shape)
    with pytest.raises(ShapeError, match=rf"^the loop model's {re.escape(text)}$"):
        LoopModel(parts["A"], parts["B"], parts["C"], parts["D"], 0.1)


def test_a_missing_output_or_a_bad_step_is_refused():
    A, B, C, D = _parts()
    del C["acc"]
    with pytest.raises(ShapeError, match=r"outputs must be \['v', 'tilt', 'tilt_rate', 'acc', "
                                         r"'tilt_acc'\], got C \['tilt', 'tilt_acc', 'tilt_rate', 'v'\]"):
        LoopModel(A, B, C, D, 0.1)
    A, B, C, D = _parts()
    for dt in (0.0, -0.1, float("nan")):
        with pytest.raises(ShapeError, match="dt must be > 0 s"):
            LoopModel(A, B, C, D, dt)
