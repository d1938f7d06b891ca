"""State manifolds of the filters: retraction, its inverse, weighted mean (as Functions).

The filter core (:mod:`ballbot_casadi.estimation.core`) knows a state only through a
:class:`Manifold`:

``oplus(x, d) -> x'``
    Retraction ``x ⊕ d`` of a tangent (error) vector ``d`` (size ``nd``) onto the
    state (size ``nx``).
``ominus(x, x_ref) -> d``
    Its inverse, ``x ⊖ x_ref = d`` with ``x_ref ⊕ d = x``.
``mean(n)``
    Factory of the weighted-mean Function ``(X[nx, n], w[n], x_init[nx]) -> x_mean``.
``normalise``
    Optional map applied to the state after a correction (the predecessor's forced
    quaternion renormalisation); ``None`` for the filters of this thesis.

Three manifolds are provided:

* :func:`euclidean` - ``R^n`` with ``+``/``-`` and the weighted sum (VUKF, VEKF, tests).
* :func:`attitude` - ``S^3 x R^3`` for the state ``[q, omega]`` of thesis (4.1):
  ``[q, w] ⊕ [r, dw] = [q o exp(r/2), w + dw]`` (the sigma-point rule 4.10-4.12, rotation
  vector ``r`` in the body frame) and ``[q, w] ⊖ [q_ref, w_ref] = [2 log(q_ref* o q),
  w - w_ref]`` (the rotation-vector deviation of 4.22-4.25); the mean is the Karcher
  mean of the quaternions (:mod:`~ballbot_casadi.estimation.quaternion_mean`, replacing
  the sweep of 4.20) and the weighted sum of the rates (4.19).  The thesis writes the
  deviation (4.22) as ``X o mu*``, a global-frame error, while its sigma points (4.12)
  apply the deviation on the right (body frame); a retraction and its inverse must use
  the same side, so both use the body frame here.
* :func:`attitude_additive` - the predecessor's additive chart: ``R^7`` with ``+``/``-``
  and renormalisation of ``q`` after every correction (QEKF baseline).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import ShapeError
from ballbot_casadi.estimation.quaternion_mean import MEAN_ITERATIONS, make_karcher_mean

__all__ = ["Manifold", "attitude", "attitude_additive", "euclidean"]


@dataclass(frozen=True)
class Manifold:
    """A filter state space given by CasADi Functions (see the module docstring)."""

    name: str
    nx: int
    nd: int
    oplus: ca.Function
    ominus: ca.Function
    mean: Callable[[int], ca.Function]
    normalise: ca.Function | None = None


def _weighted_sum_mean(nx: int) -> Callable[[int], ca.Function]:
    def factory(n: int) -> ca.Function:
        X, w, x0 = ca.SX.sym("X", nx, n), ca.SX.sym("w", n), ca.SX.sym("x_init", nx)
        return ca.Function(f"mean{nx}x{n}", [X, w, x0], [ca.mtimes(X, w)],
                           ["X", "w", "x_init"], ["x_mean"])
    return factory


def euclidean(n: int) -> Manifold:
    """``R^n``: ``x ⊕ d = x + d``, ``x ⊖ y = x - y``, mean = weighted sum."""
    if n < 1:
        raise ShapeError(f"euclidean manifold needs n >= 1, got {n}")
    x, d, y = ca.SX.sym("x", n), ca.SX.sym("d", n), ca.SX.sym("x_ref", n)
    oplus = ca.Function(f"oplus_r{n}", [x, d], [x + d], ["x", "d"], ["x_next"])
    ominus = ca.Function(f"ominus_r{n}", [x, y], [x - y], ["x", "x_ref"], ["d"])
    return Manifold(f"R{n}", n, n, oplus, ominus, _weighted_sum_mean(n))


def _normalise_q(nx: int = 7) -> ca.Function:
    """``[q, v] -> [q / |q|, v]``: the forced renormalisation of the quaternion."""
    x = ca.SX.sym("x", nx)
    q = x[:4]
    return ca.Function("normalise_q" + ("" if nx == 7 else f"_{nx}"), [x],
                       [ca.vertcat(q / ca.norm_2(q), x[4:])], ["x"], ["x_unit"])


def attitude(mean_iterations: int = MEAN_ITERATIONS, n_vec: int = 3,
             renormalise: bool = False) -> Manifold:
    """``S^3 x R^n_vec`` of the QUKF state ``[q, omega]`` (thesis 4.1, 4.10-4.12,
    4.19-4.25; ``n_vec = 3``), or ``[q, omega, b]`` with further vector entries (the
    heading-aided filter's gyroscope bias, :mod:`~ballbot_casadi.estimation.heading`).

    ``renormalise`` adds the forced renormalisation of ``q`` after every correction (the
    variant the thesis's conclusions discuss); the QUKF itself has none."""
    if n_vec < 0:
        raise ShapeError(f"attitude manifold needs n_vec >= 0, got {n_vec}")
    nx, nd = 4 + n_vec, 3 + n_vec
    tag = "" if n_vec == 3 else f"_{n_vec}"
    x, d, y = ca.SX.sym("x", nx), ca.SX.sym("d", nd), ca.SX.sym("x_ref", nx)
    x_next = ca.vertcat(Q.mul(x[:4], Q.from_rotation_vector(d[:3])), x[4:] + d[3:])
    oplus = ca.Function(f"oplus_att{tag}", [x, d], [x_next], ["x", "d"], ["x_next"], {"cse": True})
    dev = ca.vertcat(Q.to_rotation_vector(Q.mul(Q.conj(y[:4]), x[:4])), x[4:] - y[4:])
    ominus = ca.Function(f"ominus_att{tag}", [x, y], [dev], ["x", "x_ref"], ["d"], {"cse": True})

    def mean(n: int) -> ca.Function:
        qmean = make_karcher_mean(n, mean_iterations)
        X, w, x0 = ca.SX.sym("X", nx, n), ca.SX.sym("w", n), ca.SX.sym("x_init", nx)
        xm = ca.vertcat(qmean(X[:4, :], w, x0[:4]), ca.mtimes(X[4:, :], w))
        return ca.Function(f"mean_att{tag}{n}", [X, w, x0], [xm], ["X", "w", "x_init"],
                           ["x_mean"])

    return Manifold(f"S3xR{n_vec}" + ("/normalised" if renormalise else ""), nx, nd, oplus, ominus,
                    mean, _normalise_q(nx) if renormalise else None)


def attitude_additive(n: int = 7) -> Manifold:
    """The predecessor's additive ``[q, omega]`` chart (``n = 7``; ``[q, omega, b]`` with
    ``n = 10``, :mod:`~ballbot_casadi.estimation.predecessor`) with the quaternion
    renormalised after updates."""
    if n < 4:
        raise ShapeError(f"additive attitude chart needs n >= 4, got {n}")
    base = euclidean(n)
    return Manifold(f"R{n}/normalised", n, n, base.oplus, base.ominus, base.mean, _normalise_q(n))
