"""Fixed-step explicit Runge-Kutta integration of a CasADi ODE Function.

The ODE stays a *called* Function inside the step (never inlined), so generated C
contains one copy of the dynamics however many stages and sub-steps are taken.
"""

from __future__ import annotations

import casadi as ca

from ballbot_casadi.errors import BallbotTypeError

__all__ = ["make_rk4", "make_rk4_n"]


def _check_ode(ode: ca.Function) -> tuple[int, int, int]:
    if not isinstance(ode, ca.Function) or ode.n_in() != 3 or ode.n_out() != 1:
        raise BallbotTypeError("ode must be a CasADi Function (x, u, p) -> xdot")
    return ode.size1_in(0), ode.size1_in(1), ode.size1_in(2)


def make_rk4(ode: ca.Function) -> ca.Function:
    """One classical RK4 step ``ballbot_rk4(x, tau, p, h) -> x_next`` (tau held constant).

    Parameters
    ----------
    ode
        ``(x, tau, p) -> xdot``, e.g. ``make_model_functions()["ode"]``.
    """
    nx, nu, np_ = _check_ode(ode)
    x, u, p, h = ca.MX.sym("x", nx), ca.MX.sym("tau", nu), ca.MX.sym("p", np_), ca.MX.sym("h")
    k1 = ode(x, u, p)
    k2 = ode(x + h / 2 * k1, u, p)
    k3 = ode(x + h / 2 * k2, u, p)
    k4 = ode(x + h * k3, u, p)
    xn = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function("ballbot_rk4", [x, u, p, h], [xn], ["x", "tau", "p", "h"], ["x_next"])


def make_rk4_n(ode: ca.Function, n: int) -> ca.Function:
    """``n`` RK4 steps of size ``h/n``: ``ballbot_rk4_<n>(x, tau, p, h) -> x_next``.

    Built with ``Function.fold`` so the generated code loops over one step Function.
    """
    if not isinstance(n, int) or n < 1:
        raise BallbotTypeError(f"number of sub-steps must be an int >= 1, got {n!r}")
    step = make_rk4(ode)
    nx, nu, np_ = _check_ode(ode)
    x, u, p, h = ca.MX.sym("x", nx), ca.MX.sym("tau", nu), ca.MX.sym("p", np_), ca.MX.sym("h")
    one = ca.Function("rk4_sub", [x, u, p, h], [step(x, u, p, h / n)])
    xn = one.fold(n)(x, u, p, h) if n > 1 else one(x, u, p, h)
    return ca.Function(f"ballbot_rk4_{n}", [x, u, p, h], [xn], ["x", "tau", "p", "h"], ["x_next"])
