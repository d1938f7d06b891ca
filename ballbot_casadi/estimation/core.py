"""Generic unscented and extended Kalman filter steps built from CasADi Functions.

The filter code knows nothing about the ballbot.  A :class:`FilterModel` bundles

* a :class:`~ballbot_casadi.estimation.manifold.Manifold` (``⊕``, ``⊖``, mean),
* the process model ``f(x, u, dt, p) -> x_next`` (thesis 3.22, 4.13, 5.8),
* the measurement model ``h(x, u, dt, p) -> z`` (thesis 3.25, 4.27, 5.15),
* where the process noise ``Q`` enters: ``"pre"`` - on the state before the process
  model, through the sigma points of ``P + Q`` (the QUKF, thesis 4.5) - or
  ``"additive"`` - added to the predicted covariance (the VUKF, thesis 5.14),
* optionally a measurement-noise Function ``(x, u, p, R) -> R_eff`` evaluated at the
  predicted mean (the VUKF adds the QUKF attitude uncertainty, thesis 5.27-5.28).

:func:`ukf_step` and :func:`ekf_step` turn it into the MX expressions of one filter
period (predict + correct); :func:`make_filter` wraps them in a Function with the
generic inputs ``(xhat, P, z, u, Q, R, dt, p)``.  The concrete filters
(:mod:`~ballbot_casadi.estimation.attitude`, :mod:`~ballbot_casadi.estimation.velocity`)
call the step functions with their own named inputs.

Conventions
-----------
* ``P`` (and ``Q``) are dense ``nd x nd`` matrices on the tangent space of the manifold.
* Sigma points (thesis 3.21, 4.6, 5.6-5.7, Julier's set): ``X_0 = x``,
  ``X_{i,i+n} = x ⊕ (±sqrt(n + kappa) col_i L)`` with ``L L^T = P (+ Q)``; weights
  ``w_0 = kappa / (n + kappa)``, ``w_i = 1 / (2 (n + kappa))`` (5.13).  ``kappa = 0`` is
  the QUKF's equally weighted 2n-point set (4.6, 4.19): the centre point then has weight
  0 and only serves as the starting point of the mean.  The thesis prints the QUKF spread
  as ``sqrt(2d)``; with weights ``1/(2d)`` that set has covariance ``2 (P + Q)`` (an
  erratum inherited from Kraft 2003), so the spread here is ``sqrt(n + kappa)``, which
  reproduces ``P + Q`` exactly.
* The sigma points are propagated by ``f.map`` and ``h.map`` (the models stay called
  Functions); deviations are ``X_i ⊖ x_mean`` (4.22-4.25); the covariances are (4.21),
  (4.26), (4.32), (4.33) / (5.14), (5.21), (5.22) with the weights; the correction is
  ``x = x_pred ⊕ K nu`` (4.35, 5.24) and ``P = P_pred - K S K^T`` (4.36, 5.25), done by
  :func:`~ballbot_casadi.estimation.linalg.make_masked_update` (non-finite measurement
  components are masked inside: a fully invalid measurement is a predict-only step).
* EKF: the Jacobians are taken by CasADi AD in the manifold's chart,
  ``F = d/dd [f(x ⊕ d) ⊖ f(x)]``, ``H = d/dd h(x_pred ⊕ d)`` at ``d = 0``; the
  prediction is ``F (P + Q) F^T`` (pre) or ``F P F^T + Q`` (additive); after the
  correction the manifold's ``normalise`` (if any) is applied to the state.
* Closed form for affine models (``ukf_step(..., closed_form=True)``): when the process
  and the measurement model are affine in the state and the manifold is ``R^n``, the
  unscented transform is exact for any spread and weights (Julier and Uhlmann 2004): the
  sigma points' weighted mean and covariances (4.21, 5.14, 5.21, 5.22) *are*
  ``f(x)``, ``F P F^T``, ``h(x)``, ``H P H^T`` and ``P H^T`` (``F``, ``H`` the models'
  Jacobians, by AD).  The closed form computes those directly - the arithmetic of the EKF
  step, without the sigma points' Cholesky factors and 2n+1 model evaluations - and
  equals the sigma-point form to rounding.  Affinity is checked when the step is built
  (:class:`~ballbot_casadi.errors.ShapeError` otherwise).
* The filters' Functions are generated as one flat SX graph with common subexpressions
  shared (:func:`flat_function`): the called sub-Functions (Cholesky, repair, maps over
  the sigma points, the quaternion mean) are inlined, repeated work (e.g. the model
  parameters' trigonometry in every sigma point's kinematics) is done once and the
  centre point's zero weight removes its terms.  Same operations, same results.
* Innovation gating (optional, :class:`InnovationGate`, keyword ``gate`` of the step
  functions): before the correction each measurement group's normalised innovation
  squared (with the group's block of ``P_zz``) is compared with a chi-square quantile;
  a rejected group is masked like a missing reading (predict-only for it), so one glitch
  sample cannot move the estimate.  ``n_rej`` carries the consecutive rejections per
  group from period to period (the lock-out guard of
  :func:`~ballbot_casadi.estimation.linalg.make_innovation_gate`); the step then also
  returns ``rejected`` and ``n_rej_next`` (:data:`GATE_OUTPUT_NAMES`).  ``nu``, ``nis``
  and ``n_valid`` describe the components actually used.
* Every covariance is symmetrised; the incoming, the predicted and the corrected
  covariance are repaired if they are not positive definite
  (:func:`~ballbot_casadi.estimation.linalg.make_spd_repair`), and ``n_repair`` counts
  the repairs of the call (0..3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
from scipy.stats import chi2

from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.estimation.linalg import (
    make_cholesky,
    make_innovation_gate,
    make_masked_update,
    make_spd_repair,
)
from ballbot_casadi.estimation.manifold import Manifold
from ballbot_casadi.estimation.tuning import GATE_MAX_REJECTIONS, GATE_PROBABILITY

__all__ = [
    "GATE_OUTPUT_NAMES",
    "flat_function",
    "OUTPUT_NAMES",
    "FilterModel",
    "InnovationGate",
    "ekf_step",
    "make_filter",
    "sigma_weights",
    "ukf_step",
]

#: Outputs of every filter Function, in this order (the concrete filters may append more).
OUTPUT_NAMES = ("xhat_next", "P_next", "nu", "nis", "n_valid", "n_repair")

#: Outputs a gated filter appends (per measurement group): rejected this period (0/1) and
#: the consecutive-rejection counters for the next period (input ``n_rej``).
GATE_OUTPUT_NAMES = ("rejected", "n_rej_next")

_NOISE = ("pre", "additive")


@dataclass(frozen=True)
class InnovationGate:
    """Chi-square gating of a filter's measurement groups (see the module docstring).

    Attributes
    ----------
    groups
        ``((name, (indices into z ...)), ...)``: disjoint groups of measurement
        components that are accepted or rejected together (one sensor each).
    probability
        The gate's chi-square probability (default
        :data:`~ballbot_casadi.estimation.tuning.GATE_PROBABILITY`).
    max_rejections
        Consecutive rejections after which a group's gate opens (default
        :data:`~ballbot_casadi.estimation.tuning.GATE_MAX_REJECTIONS`).
    scale
        The gate tests the innovation against ``scale S``: the thresholds are ``scale``
        times the chi-square quantiles (1: the textbook test of a consistent filter).
    name
        Name of the gate's Function.
    """

    groups: tuple
    probability: float = GATE_PROBABILITY
    max_rejections: int = GATE_MAX_REJECTIONS
    scale: float = 1.0
    name: str = "innovation_gate"

    def __post_init__(self) -> None:
        seen: list[int] = []
        for g in self.groups:
            ok = (isinstance(g, tuple) and len(g) == 2 and isinstance(g[0], str)
                  and isinstance(g[1], tuple) and len(g[1]) > 0
                  and all(isinstance(i, int) and i >= 0 for i in g[1]))
            if not ok:
                raise BallbotTypeError(f"gate group must be (name, (index, ...)), got {g!r}")
            seen += list(g[1])
        if not self.groups or len(set(seen)) != len(seen):
            raise ShapeError(f"gate groups must be non-empty and disjoint, got {self.groups!r}")
        if not 0.0 < self.probability < 1.0:
            raise ShapeError(f"gate probability must be in (0, 1), got {self.probability!r}")
        if not (isinstance(self.scale, (int, float)) and math.isfinite(self.scale)
                and self.scale > 0):
            raise ShapeError(f"gate scale must be a finite number > 0, got {self.scale!r}")
        if not isinstance(self.max_rejections, int) or self.max_rejections < 1:
            raise ShapeError(f"gate max_rejections must be an int >= 1, got {self.max_rejections!r}")

    @classmethod
    def per_field(cls, layout: Any, **options: Any) -> "InnovationGate":
        """A gate with one group per field of the measurement ``layout``
        (:class:`~ballbot_casadi.core.layout.Layout`), its rows, in order; ``options`` as
        the attributes."""
        return cls(tuple((f, tuple(range(layout[f].start, layout[f].stop))) for f in layout.fields),
                   **options)

    @property
    def names(self) -> tuple[str, ...]:
        """The groups' names, in order."""
        return tuple(g[0] for g in self.groups)

    def thresholds(self) -> list[list[float]]:
        """Per group: ``scale`` times the chi-square quantiles for 1 .. len(group) valid
        components."""
        return [[self.scale * float(chi2.ppf(self.probability, k)) for k in range(1, len(idx) + 1)]
                for _, idx in self.groups]

    def function(self, nz: int) -> ca.Function:
        """The gate Function (:func:`~ballbot_casadi.estimation.linalg.make_innovation_gate`)."""
        if max(i for _, idx in self.groups for i in idx) >= nz:
            raise ShapeError(f"gate groups {self.groups!r} index beyond the {nz} measurements")
        return make_innovation_gate(nz, [idx for _, idx in self.groups], self.thresholds(),
                                    self.max_rejections, self.name)


@dataclass(frozen=True)
class FilterModel:
    """Process/measurement models of a filter on a manifold (see the module docstring)."""

    manifold: Manifold
    process: ca.Function
    measurement: ca.Function
    noise: str = "additive"
    measurement_noise: ca.Function | None = None

    def __post_init__(self) -> None:
        if self.noise not in _NOISE:
            raise BallbotTypeError(f"noise must be one of {_NOISE}, got {self.noise!r}")
        for what, f in (("process", self.process), ("measurement", self.measurement)):
            if not isinstance(f, ca.Function) or f.n_in() != 4 or f.n_out() != 1:
                raise BallbotTypeError(
                    f"{what} must be a CasADi Function (x, u, dt, p) -> one output"
                )
        nx = self.manifold.nx
        f, h = self.process, self.measurement
        if f.size_in(0) != (nx, 1) or f.size_out(0) != (nx, 1) or h.size_in(0) != (nx, 1):
            raise ShapeError(
                f"process/measurement must map states of size {nx} "
                f"(manifold {self.manifold.name}); "
                f"got f: {f.size_in(0)} -> {f.size_out(0)}, h: {h.size_in(0)}"
            )
        if f.size_in(1) != h.size_in(1) or f.size_in(3) != h.size_in(3):
            raise ShapeError("process and measurement must take the same u and p sizes")
        if f.size_in(2) != (1, 1) or h.size_in(2) != (1, 1):
            raise ShapeError("the dt input of process and measurement must be a scalar")
        r = self.measurement_noise
        if r is not None:
            nz = self.nz
            ok = (isinstance(r, ca.Function) and r.n_in() == 4 and r.n_out() == 1
                  and r.size_in(0) == (nx, 1) and r.size_in(1) == f.size_in(1)
                  and r.size_in(2) == f.size_in(3) and r.size_in(3) == (nz, nz)
                  and r.size_out(0) == (nz, nz))
            if not ok:
                raise ShapeError(
                    f"measurement_noise must be a Function (x, u, p, R[{nz}x{nz}]) -> R_eff"
                )

    @property
    def nd(self) -> int:
        return self.manifold.nd

    @property
    def nz(self) -> int:
        return self.measurement.size1_out(0)

    @property
    def nu(self) -> int:
        return self.process.size1_in(1)

    @property
    def np(self) -> int:
        return self.process.size1_in(3)


def flat_function(name: str, inputs: list, outputs: list, names_in: list,
                  names_out: list) -> ca.Function:
    """``ca.Function(name, inputs, outputs, names_in, names_out)`` expanded to one SX graph
    with common subexpressions shared (``cse``): the form the filters' C is generated from
    (module docstring).  The graph must be expandable (no ``Function.conditional``)."""
    f = ca.Function(name, inputs, outputs, names_in, names_out)
    return f.expand(name, {"cse": True})


def _require_affine(model: FilterModel) -> None:
    """Raise unless the closed form of :func:`ukf_step` is exact for ``model``: ``R^n``
    (additive retraction) and both models affine in the state."""
    man = model.manifold
    x, d, y = ca.MX.sym("x", man.nx), ca.MX.sym("d", man.nd), ca.MX.sym("y", man.nx)
    chart = ca.Function("chart", [x, d, y], [man.oplus(x, d), man.ominus(x, y)],
                        ["x", "d", "y"], ["oplus", "ominus"])
    # SX graphs: the dependency analysis through an MX call is conservative
    f, h, chart = (g.expand() for g in (model.process, model.measurement, chart))
    nonlinear = [what for what, f, i, o in (
        ("process", f, f.name_in(0), f.name_out(0)),
        ("measurement", h, h.name_in(0), h.name_out(0)),
        ("retraction", chart, "x", "oplus"), ("retraction", chart, "d", "oplus"),
        ("inverse retraction", chart, "x", "ominus"), ("inverse retraction", chart, "y", "ominus"))
        if any(f.which_depends(i, [o], 2, False))]
    if nonlinear or man.nx != man.nd or man.normalise is not None:
        raise ShapeError(f"the closed-form unscented step needs models affine in the state on "
                         f"R^n; manifold {man.name}, nonlinear: {', '.join(nonlinear) or 'none'}")


def sigma_weights(n: int, kappa: float) -> tuple[float, list[float]]:
    """Spread ``sqrt(n + kappa)`` and the 2n+1 weights (thesis 5.13; kappa = 0: 4.19)."""
    if not n + kappa > 0:
        raise ShapeError(f"sigma points need n + kappa > 0, got n = {n}, kappa = {kappa}")
    lam = n + kappa
    return math.sqrt(lam), [kappa / lam] + [0.5 / lam] * (2 * n)


def _measurement_cov(model: FilterModel, x_pred, u, p, R):
    return R if model.measurement_noise is None else model.measurement_noise(x_pred, u, p, R)


def _correct(model: FilterModel, x_pred, P_pred, P_xz, P_zz, z, z_pred, n_rep,
             gate: InnovationGate | None = None, n_rej=None) -> dict:
    man = model.manifold
    gated = {}
    if gate is not None:
        if n_rej is None:
            n_rej = ca.DM.zeros(len(gate.groups))
        z, rejected, n_next = gate.function(model.nz)(P_zz, z, z_pred, n_rej)
        gated = {"rejected": rejected, "n_rej_next": n_next}
    upd = make_masked_update(model.nd, model.nz)(P_pred, P_xz, P_zz, z, z_pred)
    dx, P_post, nu, nis, n_valid = upd
    x_post = man.oplus(x_pred, dx)
    if man.normalise is not None:
        x_post = man.normalise(x_post)
    P_post, r = make_spd_repair(model.nd)(P_post)
    return {**dict(zip(OUTPUT_NAMES, (x_post, P_post, nu, nis, n_valid, n_rep + r))), **gated,
            "P_zz": P_zz}


def _sigma_points(man: Manifold, chol: ca.Function, x, P, spread: float):
    """Sigma points ``[x, x ⊕ s L, x ⊕ -s L]`` and their deviations ``[0, ±s L]``."""
    n = man.nd
    L, _ = chol(P)
    D = spread * ca.horzcat(L, -L)
    X = ca.horzcat(x, man.oplus.map(2 * n)(ca.repmat(x, 1, 2 * n), D))
    return X, ca.horzcat(ca.DM.zeros(n, 1), D)


def ukf_step(model: FilterModel, xhat, P, z, u, Q, R, dt, p, kappa: float = 0.0, *,
             gate: InnovationGate | None = None, n_rej=None, closed_form: bool = False) -> dict:
    """MX expressions of one UKF period (thesis 3.20-3.31, ch. 4 and 5); keys = OUTPUT_NAMES
    (and :data:`GATE_OUTPUT_NAMES` with ``gate``; ``n_rej`` its counters, default 0).

    With ``closed_form`` the unscented transform of the affine ``model`` is computed in
    closed form (module docstring; ``ShapeError`` if the model is not affine on ``R^n``).

    With ``"additive"`` noise the measurement sigma points are redrawn from the predicted
    mean and covariance (which contains ``Q``): the thesis (5.15) reuses the propagated
    points, whose spread lacks ``Q``, so its ``P_zz`` and ``P_xz`` would miss the process
    noise of the period (the filter would then differ from the Kalman filter even for a
    linear model).  With ``"pre"`` noise (QUKF) the propagated points already carry ``Q``
    and are reused, as in (4.27).
    """
    man, n = model.manifold, model.nd
    spread, w = sigma_weights(n, kappa)
    if closed_form:  # the unscented transform of an affine map, exactly (module docstring)
        _require_affine(model)
        return ekf_step(model, xhat, P, z, u, Q, R, dt, p, gate=gate, n_rej=n_rej)
    ns = 2 * n + 1
    Wd = ca.diag(ca.DM(w))
    repair, chol = make_spd_repair(n), make_cholesky(n)
    P0, r0 = repair(P)
    X, _ = _sigma_points(man, chol, xhat, P0 + Q if model.noise == "pre" else P0, spread)
    Xp = model.process.map(ns)(X, u, dt, p)
    x_pred = man.mean(ns)(Xp, ca.DM(w), Xp[:, 0])
    dX = man.ominus.map(ns)(Xp, ca.repmat(x_pred, 1, ns))
    P_pred = ca.mtimes([dX, Wd, dX.T])
    if model.noise == "additive":
        P_pred, r1 = repair(P_pred + Q)
        Xp, dX = _sigma_points(man, chol, x_pred, P_pred, spread)
    else:
        P_pred, r1 = repair(P_pred)
    Zp = model.measurement.map(ns)(Xp, u, dt, p)
    z_pred = ca.mtimes(Zp, ca.DM(w))
    dZ = Zp - ca.repmat(z_pred, 1, ns)
    P_zz = ca.mtimes([dZ, Wd, dZ.T]) + _measurement_cov(model, x_pred, u, p, R)
    P_xz = ca.mtimes([dX, Wd, dZ.T])
    return _correct(model, x_pred, P_pred, P_xz, P_zz, z, z_pred, r0 + r1, gate, n_rej)


def _chart_jacobians(model: FilterModel) -> tuple[ca.Function, ca.Function]:
    """``F(x, u, dt, p)`` and ``H(x, u, dt, p)``: error-state Jacobians by AD at d = 0."""
    man = model.manifold
    x = ca.MX.sym("x", man.nx)
    u = ca.MX.sym("u", model.nu)
    dt = ca.MX.sym("dt")
    p = ca.MX.sym("p", model.np)
    d = ca.MX.sym("d", man.nd)
    f, h = model.process, model.measurement
    fx = man.ominus(f(man.oplus(x, d), u, dt, p), f(x, u, dt, p))
    hx = h(man.oplus(x, d), u, dt, p)
    zero = ca.DM.zeros(man.nd)
    F = ca.substitute(ca.jacobian(fx, d), d, zero)
    H = ca.substitute(ca.jacobian(hx, d), d, zero)
    args, names = [x, u, dt, p], ["x", "u", "dt", "p"]
    return (ca.Function("ekf_F", args, [F], names, ["F"]),
            ca.Function("ekf_H", args, [H], names, ["H"]))


def ekf_step(model: FilterModel, xhat, P, z, u, Q, R, dt, p, *,
             gate: InnovationGate | None = None, n_rej=None) -> dict:
    """MX expressions of one EKF period (Jacobians by AD); keys = OUTPUT_NAMES (and
    :data:`GATE_OUTPUT_NAMES` with ``gate``, as :func:`ukf_step`)."""
    Ff, Hf = _chart_jacobians(model)
    repair = make_spd_repair(model.nd)
    P0, r0 = repair(P)
    x_pred = model.process(xhat, u, dt, p)
    F = Ff(xhat, u, dt, p)
    if model.noise == "pre":
        P_pred = ca.mtimes([F, P0 + Q, F.T])
    else:
        P_pred = ca.mtimes([F, P0, F.T]) + Q
    P_pred, r1 = repair(P_pred)
    H = Hf(x_pred, u, dt, p)
    z_pred = model.measurement(x_pred, u, dt, p)
    P_xz = ca.mtimes(P_pred, H.T)
    P_zz = ca.mtimes(H, P_xz) + _measurement_cov(model, x_pred, u, p, R)
    return _correct(model, x_pred, P_pred, P_xz, P_zz, z, z_pred, r0 + r1, gate, n_rej)


def make_filter(name: str, model: FilterModel, kind: str = "ukf",
                kappa: float = 0.0, gate: InnovationGate | None = None) -> ca.Function:
    """Generic filter Function ``name(xhat, P, z, u, Q, R, dt, p) -> OUTPUT_NAMES``
    (with ``gate``: a last input ``n_rej`` and the outputs :data:`GATE_OUTPUT_NAMES` appended).

    Parameters
    ----------
    name
        Function name (``ballbot_<filter>`` for the package's filters).
    model
        The filter's models and manifold.
    kind
        ``"ukf"`` (:func:`ukf_step`) or ``"ekf"`` (:func:`ekf_step`).
    kappa
        Sigma-point parameter of the UKF (ignored by the EKF).
    gate
        Optional chi-square gating of measurement groups (:class:`InnovationGate`).
    """
    if kind not in ("ukf", "ekf"):
        raise BallbotTypeError(f"kind must be 'ukf' or 'ekf', got {kind!r}")
    man = model.manifold
    xhat = ca.MX.sym("xhat", man.nx)
    P = ca.MX.sym("P", man.nd, man.nd)
    z = ca.MX.sym("z", model.nz)
    u = ca.MX.sym("u", model.nu)
    Q = ca.MX.sym("Q", man.nd, man.nd)
    R = ca.MX.sym("R", model.nz, model.nz)
    dt = ca.MX.sym("dt")
    p = ca.MX.sym("p", model.np)
    args = (xhat, P, z, u, Q, R, dt, p)
    names_in, names_out = ["xhat", "P", "z", "u", "Q", "R", "dt", "p"], list(OUTPUT_NAMES)
    extra = {}
    if gate is not None:
        n_rej = ca.MX.sym("n_rej", len(gate.groups))
        extra = {"gate": gate, "n_rej": n_rej}
        names_in.append("n_rej")
        names_out += GATE_OUTPUT_NAMES
    out = (ukf_step(model, *args, kappa=kappa, **extra) if kind == "ukf"
           else ekf_step(model, *args, **extra))
    ins = list(args) + ([extra["n_rej"]] if extra else [])
    return ca.Function(name, ins, [out[k] for k in names_out], names_in, names_out)
