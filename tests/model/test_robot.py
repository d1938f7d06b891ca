"""BallbotModel numeric API and its input validation."""

import numpy as np
import pytest

from ballbot_casadi import ShapeError, StateError, load_params
from ballbot_casadi.errors import BallbotTypeError
from ballbot_casadi.model.numeric import BallbotModel, make_state


@pytest.fixture(scope="module")
def model():
    return BallbotModel()


def test_api_shapes_and_values(model):
    x = make_state(roll=0.05, dx=0.1)
    assert model.ode(x, np.zeros(3)).shape == (12,)
    A, B = model.linearize(model.upright(), np.zeros(3))
    assert A.shape == (12, 12) and B.shape == (12, 3)
    f, g = model.affine(x)
    assert f.shape == (6,) and g.shape == (6, 3)
    e = model.energy(x)
    assert e.total == pytest.approx(e.kinetic + e.potential)
    assert e.potential == pytest.approx(model.params.Mb * model.params.g * model.params.l
                                        * np.cos(0.05), rel=1e-12)
    assert model.wheel_speeds(x).shape == (3,)
    assert set(model.functions) >= {"ode", "jac", "affine", "energy", "wheel_speeds"}
    assert model.params == load_params()


def test_accepts_column_vectors_and_lists(model):
    x = make_state(pitch=0.02)
    np.testing.assert_array_equal(model.ode(x.reshape(12, 1), [0, 0, 0]), model.ode(list(x), (0, 0, 0)))


@pytest.mark.parametrize("bad", [np.zeros(11), np.zeros((12, 2)), np.zeros(13)])
def test_wrong_shape(model, bad):
    with pytest.raises(ShapeError, match=r"shape \(12,\)"):
        model.ode(bad, np.zeros(3))


def test_wrong_tau_shape(model):
    with pytest.raises(ShapeError, match="tau"):
        model.ode(model.upright(), np.zeros(2))


def test_nan_state_and_tau(model):
    x = model.upright()
    x[6] = np.nan
    with pytest.raises(StateError, match="NaN"):
        model.ode(x, np.zeros(3))
    with pytest.raises(StateError, match="NaN or Inf"):
        model.ode(model.upright(), [0, np.inf, 0])
    with pytest.raises(StateError):
        model.energy(x)


def test_quaternion_norm_tolerance(model):
    x = model.upright()
    x[2] = 1 + 5e-7
    model.ode(x, np.zeros(3))  # within 1e-6: accepted
    x[2] = 1 + 2e-6
    with pytest.raises(StateError, match="norm"):
        model.ode(x, np.zeros(3))
    with pytest.raises(StateError, match="norm"):
        model.linearize(x, np.zeros(3))


def test_non_numeric_input(model):
    with pytest.raises(BallbotTypeError):
        model.ode(["a"] * 12, np.zeros(3))
    with pytest.raises(TypeError):
        BallbotModel(params={"Mb": 1})


def test_make_state_rates():
    x = make_state(yaw=0.4, omega_body=[0.1, -0.2, 0.3])
    q, dq = x[2:6], x[8:12]
    assert q @ dq == pytest.approx(0.0, abs=1e-16)  # tangent to the unit sphere
    from ballbot_casadi.model.kinematics import body_angular_velocity

    np.testing.assert_allclose(body_angular_velocity(q, dq), [0.1, -0.2, 0.3], atol=1e-15)
