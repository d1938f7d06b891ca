"""The linearisation's results are values: OperatingPoint and LinearModel refuse assignment
(frozen dataclasses), so a caller cannot change a shared model's matrices or its limits."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ballbot_casadi.model.linearization import LinearModel, OperatingPoint


def test_operating_point_and_linear_model_are_frozen():
    op = OperatingPoint(x=np.arange(12.0), tau=np.array([0.1, -0.2, 0.3]), residual=1e-12)
    lin = LinearModel(op, np.eye(12), np.ones((12, 3)), np.zeros((12, 10)), np.eye(10),
                      np.ones((10, 3)), 0.0, 0.25, 8.0)
    for obj, field in ((lin, "A"), (lin, "tau_max"), (lin, "beta"), (op, "x"), (op, "tau")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(obj, field, np.zeros(1))
    assert lin.tau_max == 8.0 and lin.beta == 0.25 and op.tau[1] == -0.2
