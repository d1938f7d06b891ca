"""The sensor models refuse a model Function they cannot call with one line naming what
they need: a state equation that is not a Function of (x, tau, p), or of other sizes; a
wheel-speed map of other sizes; the two with different parameter vectors."""

from __future__ import annotations

import casadi as ca
import pytest

from ballbot_casadi.errors import BallbotTypeError
from ballbot_casadi.model.dynamics import make_ode, make_wheel_speeds
from ballbot_casadi.model.sensors import make_imu, make_sensors, make_wheel_angle_ode

ODE_LINE = r"^ode must be a CasADi Function \(x, tau, p\) -> xdot$"


def _f(sizes_in, size_out, name="f"):
    args = [ca.SX.sym(f"a{i}", n) for i, n in enumerate(sizes_in)]
    return ca.Function(name, args, [ca.SX.zeros(size_out) + sum(ca.sum1(a) for a in args)])


@pytest.mark.parametrize("build", [make_sensors, make_imu])
@pytest.mark.parametrize("ode, message", [
    ("ode", ODE_LINE),
    (_f([12, 3], 12), ODE_LINE),                         # no parameter input
    (_f([11, 3, 5], 12), r"^ode must map x \(12\), tau \(3\), p -> xdot \(12\), got sizes 11, 3$"),
    (_f([12, 2, 5], 12), r"^ode must map x \(12\), tau \(3\), p -> xdot \(12\), got sizes 12, 2$"),
    (_f([12, 3, 5], 11), r"^ode must map x \(12\), tau \(3\), p -> xdot \(12\), got sizes 12, 3$"),
])
def test_a_state_equation_it_cannot_call(build, ode, message):
    with pytest.raises(BallbotTypeError, match=message):
        build(ode)


def test_the_wheel_angle_model_needs_matching_functions():
    ode, ws = make_ode(), make_wheel_speeds()
    with pytest.raises(BallbotTypeError, match=r"^wheel_speeds must be a CasADi Function \(x \(12\), p\) "
                                               r"-> dphi \(3\)"):
        make_wheel_angle_ode(ode, _f([12, ode.size1_in(2)], 2))
    with pytest.raises(BallbotTypeError, match=r"^ode and wheel_speeds take parameter vectors of "
                                               r"different sizes$"):
        make_wheel_angle_ode(ode, _f([12, ode.size1_in(2) + 1], 3))
    f = make_wheel_angle_ode(ode, ws)
    assert (f.size1_in(0), f.size1_out(0)) == (15, 15)


def _ws(n_p, extra_in=0, n_out=1, nx=12, n_dphi=3):
    x, p = ca.SX.sym("x", nx), ca.SX.sym("p", n_p)
    more = [ca.SX.sym(f"e{i}") for i in range(extra_in)]
    return ca.Function("ws", [x, p, *more], [ca.SX.zeros(n_dphi) + ca.sum1(x)] * n_out)


@pytest.mark.parametrize("change", [{"extra_in": 1}, {"n_out": 2}, {"nx": 13}, {"n_dphi": 4}])
def test_each_wrong_part_of_a_wheel_speed_map_is_refused_on_its_own(change):
    ode = make_ode()
    with pytest.raises(BallbotTypeError, match=r"^wheel_speeds must be a CasADi Function \(x \(12\), "
                                               r"p\) -> dphi \(3\), e\.g\. make_model_functions"):
        make_wheel_angle_ode(ode, _ws(ode.size1_in(2), **change))
    assert make_wheel_angle_ode(ode, _ws(ode.size1_in(2))).size1_out(0) == 15
