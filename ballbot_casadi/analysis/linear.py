"""Linear analysis of the ballbot: minimal model, controllability, poles and zeros.

The thesis designs its controllers on the linearised model and reasons about bandwidth and
non-minimum-phase behaviour (thesis §2.5, §7.1, §9.1) without showing the analysis; this
module computes it.  Everything here is numpy/CasADi/python-control; plots and the report
live in :mod:`ballbot_casadi.studies.analyze`.

Operating points and the exact full/reduced linearisation are in
:mod:`ballbot_casadi.model.linearization`.

The closed loop (cascade bandwidths, 3x rule) is :mod:`ballbot_casadi.analysis.closed_loop`.

Scaling
-------
Controllability numbers depend on units, so they are computed in the scaled coordinates
of :data:`STATE_SCALE` (the design envelope of thesis §7.1: 1 m, 0.5 m/s, 5 deg tilt,
20 deg/s tilt rate, 1 rad heading, 1 rad/s heading rate) with the torques normalised by
``tau_max``.
"""

from __future__ import annotations

from typing import Any, Sequence

import casadi as ca
import control
import numpy as np
import scipy.linalg as sla

from ballbot_casadi.core.params import Params
from ballbot_casadi.errors import ParameterError, ShapeError
from ballbot_casadi.model.dynamics import NU, NX, make_model_functions
from ballbot_casadi.model.linearization import (
    NR,
    REDUCED_STATE_NAMES,
    LinearModel,
    linearize,
    sorted_eig,
)

__all__ = [
    "STATE_SCALE",
    "CHANNELS",
    "state_scaling",
    "controllability",
    "mode_groups",
    "channel_system",
    "channel_poles_zeros",
    "right_half_plane",
    "singular_values",
    "finite_gramian",
    "planar_reduction",
    "unmatched_eigenvalues",
    "analyze_plant",
]

#: Largest ``max|Re lambda| T`` of the Gramian horizon ``T`` (``e^30 ~ 1e13``).
_MAX_GRAMIAN_EXPONENT = 30.0

#: Typical magnitude of each reduced state (thesis §7.1 envelope), used for scaling.
STATE_SCALE = np.array(
    [
        1.0, 1.0,  # position, m
        np.sin(np.radians(2.5)), np.sin(np.radians(2.5)),  # 5 deg tilt, quaternion units
        np.sin(0.5),  # 1 rad heading
        0.5, 0.5,  # 0.5 m/s
        0.5 * np.radians(20.0), 0.5 * np.radians(20.0),  # 20 deg/s tilt rate
        0.5,  # 1 rad/s heading rate
    ]
)

#: Output channels of the analysis: name -> (reduced-state indices, output names).
#: ``pose`` (x, y and heading) is the square 3x3 channel: at upright rest the summed
#: ("yaw") torque does not reach x, y, so the 2x3 ``position`` channel is effectively
#: square and has the RHP zeros; away from that symmetric point (tilted, rolling) the
#: yaw torque couples in weakly and a generic non-square system has no transmission
#: zeros, while the square ``pose`` channel keeps them.  ``rhp_zeros_position`` therefore
#: comes from ``pose``.
CHANNELS: dict[str, tuple[tuple[int, ...], tuple[str, ...]]] = {
    "position": ((0, 1), ("x", "y")),
    "tilt": ((2, 3), ("v1", "v2")),
    "heading": ((4,), ("v3",)),
    "pose": ((0, 1, 4), ("x", "y", "v3")),
}

# --------------------------------------------------------------------------- controllability


def state_scaling(lin: LinearModel) -> tuple[np.ndarray, np.ndarray]:
    """Scaled reduced model ``(S^-1 Ar S, S^-1 Br tau_max)`` with ``S = diag(STATE_SCALE)``."""
    s = STATE_SCALE
    return lin.Ar * (1.0 / s)[:, None] * s[None, :], lin.Br * (lin.tau_max / s)[:, None]


def mode_groups(A: np.ndarray, tol: float = 1e-6) -> list[np.ndarray]:
    """Eigenvalues of ``A`` grouped into clusters (repeated eigenvalues and conjugate pairs).

    Each group is an array of eigenvalues; a complex pair forms one group with its
    conjugate, so every group spans a real invariant subspace.
    """
    e = sorted_eig(A)
    groups: list[list[complex]] = []
    for lam in e:
        for g in groups:
            ref = g[0]
            if min(abs(lam - ref), abs(lam - np.conj(ref))) <= tol * max(1.0, abs(ref)):
                g.append(lam)
                break
        else:
            groups.append([lam])
    return [np.array(g) for g in groups]


def _left_invariant_subspace(A: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Orthonormal basis (n x m) of the left invariant subspace of the eigenvalue group."""
    n, m = A.shape[0], group.size
    lam = group[np.argmax(group.imag)]
    if abs(lam.imag) > 0:
        N = A @ A - 2 * lam.real * A + abs(lam) ** 2 * np.eye(n)
        power = m // 2
    else:
        N = A - lam.real * np.eye(n)
        power = m
    U, _, _ = np.linalg.svd(np.linalg.matrix_power(N, power))
    return U[:, n - m :]


def finite_gramian(A: np.ndarray, B: np.ndarray, horizon: float) -> np.ndarray:
    """Controllability Gramian ``int_0^T e^{At} B B^T e^{A^T t} dt`` (Van Loan's method).

    Finite for unstable ``A``, so no stabilising loop is needed.
    """
    n = A.shape[0]
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n], M[:n, n:], M[n:, n:] = -A, B @ B.T, A.T
    E = sla.expm(M * horizon)
    W = E[n:, n:].T @ E[:n, n:]
    return 0.5 * (W + W.T)


def controllability(lin: LinearModel, rtol: float = 1e-9, horizon: float = 1.0) -> dict[str, Any]:
    """Controllability of the reduced model in scaled coordinates (:func:`state_scaling`).

    * Kalman rank: singular values of ``[B, A B, ..., A^9 B]`` built from
      ``A / w0, B / |B|`` with ``w0 = |A|_2`` (time scaling keeps the blocks of equal size);
      rank = number of singular values above ``rtol * sigma_max``.
    * PBH per distinct eigenvalue: ``sigma_min([A - lambda I, B]) / |[A, B]|``
      (zero exactly when the eigenvalue is uncontrollable).
    * Gramian measure per mode group: the finite-horizon Gramian ``W(T)`` of the scaled
      plant restricted to the group's left invariant subspace ``U`` (the decoupled modal
      subsystem ``z = U^T x``); ``1 / lambda_min(U^T W U)`` is the least input energy
      (in ``tau_max^2 s``) that moves the group by one scale unit in its weakest
      direction within ``T`` seconds.  Larger energy = more weakly controllable.
      ``T`` is ``horizon``, shortened to ``30 / max|Re lambda|`` for very fast modes so
      that ``e^{A T}`` stays finite; the returned ``horizon`` is the one used.

    Returns
    -------
    dict
        ``rank``, ``n``, ``singular_values``, ``rtol``, ``pbh`` (list of dicts), ``modes``
        (list of dicts with ``eigenvalues``, ``energy``, ``dominant_states`` of the
        modes' right invariant subspace and the states of the ``weakest_direction``)
        and ``weakest_mode``.
    """
    A, B = state_scaling(lin)
    n = A.shape[0]
    w0 = np.linalg.norm(A, 2)
    As, Bs = A / w0, B / np.linalg.norm(B, 2)
    blocks, Mk = [], Bs
    for _ in range(n):
        blocks.append(Mk)
        Mk = As @ Mk
    sv = np.linalg.svd(np.hstack(blocks), compute_uv=False)
    rank = int(np.sum(sv > rtol * sv[0]))

    AB_norm = np.linalg.norm(np.hstack([A, B]), 2)
    pbh = []
    groups = mode_groups(A)
    for g in groups:
        for lam in dict.fromkeys(np.round(g, 12)):
            s = np.linalg.svd(np.hstack([A - lam * np.eye(n), B]), compute_uv=False)[-1] / AB_norm
            pbh.append({"eigenvalue": complex(lam), "sigma_min": float(s), "controllable": bool(s > rtol)})

    # e^{|A| T} must stay far from overflow: a very fast mode (e.g. a heavy body on a
    # light frame) shortens the horizon, which the result reports.
    lam_max = float(np.max(np.abs(np.linalg.eigvals(A).real)))
    if lam_max * horizon > _MAX_GRAMIAN_EXPONENT:
        horizon = _MAX_GRAMIAN_EXPONENT / lam_max
    W = finite_gramian(A, B, horizon)
    if not np.all(np.isfinite(W)):
        raise ParameterError("the controllability Gramian of the linearised model is not "
                             "finite for these parameters")
    modes = []
    for g in groups:
        U = _left_invariant_subspace(A, g)
        lam, vec = np.linalg.eigh(U.T @ W @ U)
        energy = 1.0 / lam[0] if lam[0] > 0 else float("inf")
        right = _right_invariant_subspace(A, g)
        modes.append(
            {
                "eigenvalues": [complex(v) for v in g],
                "energy": float(energy),
                "dominant_states": _dominant(np.sum(right**2, axis=1)),
                "weakest_direction": _dominant((U @ vec[:, 0]) ** 2),
            }
        )
    weakest = max(modes, key=lambda m: m["energy"])
    return {
        "n": n,
        "rank": rank,
        "rtol": rtol,
        "singular_values": sv.tolist(),
        "pbh": pbh,
        "horizon": horizon,
        "modes": modes,
        "weakest_mode": weakest,
    }


def _dominant(weight: np.ndarray, frac: float = 0.1) -> list[str]:
    """Reduced-state names whose weight exceeds ``frac`` of the largest, largest first."""
    return [REDUCED_STATE_NAMES[i] for i in np.argsort(-weight) if weight[i] > frac * weight.max()]


def _right_invariant_subspace(A: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the right invariant subspace of an eigenvalue group."""
    return _left_invariant_subspace(A.T, group)


# --------------------------------------------------------------------------- channels


def channel_system(lin: LinearModel, channel: str):
    """python-control state-space model wheel torques -> one output channel (reduced model).

    Channels (:data:`CHANNELS`): ``position`` (x, y in m), ``tilt`` (v1, v2: vector part
    of the ball-frame attitude error, about half the roll/pitch angle in rad) and
    ``heading`` (v3, about half the yaw angle).
    """

    if channel not in CHANNELS:
        raise ShapeError(f"unknown channel {channel!r}; known: {', '.join(CHANNELS)}")
    idx, names = CHANNELS[channel]
    C = np.zeros((len(idx), NR))
    C[np.arange(len(idx)), list(idx)] = 1.0
    return control.ss(lin.Ar, lin.Br, C, np.zeros((len(idx), NU)), outputs=list(names),
                      inputs=["tau0", "tau1", "tau2"])


def channel_poles_zeros(lin: LinearModel, channel: str, tol: float = 1e-9) -> dict[str, Any]:
    """Poles and transmission zeros of a channel's minimal realisation.

    Uncontrollable or unobservable modes (e.g. the ball position seen from the tilt
    output) would otherwise show up as decoupling zeros; ``control.minreal`` (SLICOT
    TB01PD) removes them first, then SLICOT AB08ND gives the invariant zeros of the
    (possibly non-square) minimal system, i.e. its transmission zeros.

    Returns
    -------
    dict
        ``order`` (minimal order), ``poles``, ``zeros`` (complex arrays) and ``rhp_zeros``
        (zeros with real part > ``1e-6 * max(1, |z|)``).
    """

    sys = channel_system(lin, channel)
    msys = control.minreal(sys, tol=tol, verbose=False)
    poles = _sort_c(np.linalg.eigvals(msys.A)) if msys.nstates else np.array([], complex)
    zeros = _sort_c(msys.zeros()) if msys.nstates else np.array([], complex)
    return {"order": int(msys.nstates), "poles": poles, "zeros": zeros,
            "rhp_zeros": right_half_plane(zeros)}


def right_half_plane(z: np.ndarray) -> np.ndarray:
    """The entries of ``z`` with real part > ``1e-6 * max(1, |z|)``: relative to the
    magnitude, so the round-off of a large zero on the imaginary axis is not counted."""
    z = np.asarray(z, dtype=complex)
    return z[z.real > 1e-6 * np.maximum(1.0, np.abs(z))]


def _sort_c(v: Sequence[complex]) -> np.ndarray:
    v = np.asarray(v, dtype=complex)
    return v[np.lexsort((v.imag, -v.real))]


def singular_values(lin_or_sys: Any, omega: np.ndarray, channel: str | None = None) -> np.ndarray:
    """Singular values of ``G(j omega)`` (rows: frequencies; columns: sigma_1 >= sigma_2 ...).

    ``lin_or_sys`` is a :class:`LinearModel` with a ``channel`` name or a python-control
    state-space system.  Evaluated directly as ``C (j w I - A)^-1 B + D``, which is
    defined for unstable plants as well.
    """
    sys = channel_system(lin_or_sys, channel) if isinstance(lin_or_sys, LinearModel) else lin_or_sys
    A, B, C, D = (np.asarray(M, dtype=float) for M in (sys.A, sys.B, sys.C, sys.D))
    n = A.shape[0]
    out = []
    for w in np.asarray(omega, dtype=float):
        G = C @ np.linalg.solve(1j * w * np.eye(n) - A, B) + D
        out.append(np.linalg.svd(G, compute_uv=False))
    return np.array(out)


# --------------------------------------------------------------------------- hand derivation


def planar_reduction(params: Params) -> dict[str, float]:
    """Unstable pole and position zero of the planar ball + inverted-pendulum reduction.

    Per tilt axis, with the ball angle ``phi`` (``x = rk phi``), the body tilt ``theta``
    and the energies of thesis (C.14, C.18, C.21, C.24) linearised at upright:
    ``a = (Mk + Mb) rk^2 + Jk``, ``b = Mb rk l``, ``c = Jb + Mb l^2``, ``G = Mb g l`` and
    the wheel inertia ``J = Jw (rk/rw)^2 cos^2(alpha) sum_i s_i^2`` acting on the relative
    rate ``dphi - dtheta`` (``s_i = sin(i gamma)`` for pitch, ``cos(i gamma)`` for roll,
    from the wheel map B.46).  The torque enters as ``(+u, -u)``, so

    * poles: ``s^2 [((a+J)(c+J) - (b-J)^2) s^2 - (a+J) G] = 0`` ->
      ``p = sqrt((a+J) G / ((a+J)(c+J) - (b-J)^2))``;
    * torque -> position numerator ``(b + c) s^2 - G`` (``J`` cancels) -> zeros
      ``+-sqrt(G / (b + c)) = +-sqrt(Mb g l / (Jb + Mb l (l + rk)))``, one in the right
      half-plane: the shape-accelerated, non-minimum-phase behaviour of thesis §2.5.

    Exact for the 3D model at upright without friction when the wheel layout does not
    couple the axes (``sum_i sin(i gamma) cos(i gamma) = 0``, true for gamma = 120 deg)
    and the COM is centred.

    Returns
    -------
    dict
        ``pole_pitch``, ``pole_roll``, ``zero_pitch``, ``zero_roll`` in rad/s (pitch moves
        the ball along x, roll along y).
    """
    P = params
    a = (P.Mk + P.Mb) * P.rk**2 + P.Jk
    b = P.Mb * P.rk * P.l
    G = P.Mb * P.g * P.l
    ig = np.arange(3) * P.gamma
    out = {}
    for axis, Jb, s in (("pitch", P.Jby, np.sin(ig)), ("roll", P.Jbx, np.cos(ig))):
        J = P.Jw * (P.rk / P.rw) ** 2 * np.cos(P.alpha) ** 2 * float(np.sum(s**2))
        c = Jb + P.Mb * P.l**2
        out[f"pole_{axis}"] = float(np.sqrt((a + J) * G / ((a + J) * (c + J) - (b - J) ** 2)))
        out[f"zero_{axis}"] = float(np.sqrt(G / (b + c)))
    return out


# --------------------------------------------------------------------------- full plant report


def _quiet(fn: Any, *args: Any) -> Any:
    """Call ``fn`` with floating-point warnings off (extreme parameters give NaN -> null)."""
    with np.errstate(all="ignore"):
        return fn(*args)


def _largest_parameters(params: Params, n: int = 3) -> str:
    """The ``n`` parameters of largest magnitude, for messages about overflow."""
    vals = params.as_dict()
    top = sorted(vals, key=lambda k: -abs(float(vals[k])))[:n]
    return "largest: " + ", ".join(f"{k} = {float(vals[k]):g}" for k in top)


def _check_model_finite(params: Params, x0: Any | None,
                        functions: dict[str, ca.Function] | None) -> None:
    """Refuse parameters (or an operating point) where the model itself overflows.

    Legal but extreme values (e.g. ``Mb = 1e308``) make products such as ``Mb g l``
    exceed double precision; the ODE and its Jacobians are then Inf/NaN and no linear
    analysis exists.  Checked at the operating point (or upright at rest) with zero torque.
    """
    funcs = functions if functions is not None else make_model_functions()
    if x0 is None:
        x = np.zeros(NX)
        x[2] = 1.0
    else:
        x = np.asarray(x0, dtype=float).ravel()
    p = params.to_vector()
    with np.errstate(all="ignore"):
        f = np.asarray(funcs["ode"](x, np.zeros(NU), p), dtype=float)
        A, B = (np.asarray(M, dtype=float) for M in funcs["jac"](x, np.zeros(NU), p))
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        where = "upright at rest" if x0 is None else "the operating point"
        raise ParameterError(
            f"the model evaluates to Inf/NaN {'' if x0 is None else 'at '}{where} with these "
            f"parameters ({_largest_parameters(params)}): products of the parameters overflow "
            "double precision, so no linear analysis exists; use physically meaningful values")



def _cplx(v: Sequence[complex]) -> list[list[float]]:
    return [[float(np.real(z)), float(np.imag(z))] for z in v]


def _real_list(v: Sequence[complex]) -> list[float]:
    """Real parts (rad/s), largest first; complex zeros appear once per member of the pair."""
    return sorted((float(np.real(z)) for z in v), reverse=True)


def unmatched_eigenvalues(full: Sequence[complex], reduced: Sequence[complex]) -> list[complex]:
    """The eigenvalues of ``full`` left after each of ``reduced`` takes its nearest remaining
    one: the full (constrained) model's own constraint modes."""
    rest = list(full)
    if len(reduced) > len(rest):
        raise ShapeError(f"{len(reduced)} reduced eigenvalues cannot be matched among {len(rest)}")
    for lam in reduced:
        rest.pop(int(np.argmin(np.abs(np.array(rest) - lam))))
    return rest


def analyze_plant(
    params: Params,
    x0: Any | None = None,
    functions: dict[str, ca.Function] | None = None,
    horizon: float = 1.0,
) -> tuple[LinearModel, dict[str, Any]]:
    """Open-loop analysis of the plant at an operating point, as a JSON-ready dict.

    Returns
    -------
    (LinearModel, dict)
        The linearisation and a dict with the operating point, eigenvalues of the full
        and reduced model, constraint eigenvalues, ``unstable_poles`` (rad/s),
        controllability (:func:`controllability`), per-channel poles/zeros
        (:func:`channel_poles_zeros`), ``rhp_zeros_<channel>`` (real parts, rad/s),
        ``rhp_zeros_position`` (from the square ``pose`` channel, see :data:`CHANNELS`)
        and the planar hand derivation (:func:`planar_reduction`).
    """
    _check_model_finite(params, x0, functions)
    try:
        with np.errstate(all="ignore"):
            lin = linearize(params, x0, functions)
    except (np.linalg.LinAlgError, ArithmeticError) as exc:
        raise ParameterError(f"the model cannot be trimmed and linearised with these "
                             f"parameters ({type(exc).__name__}: {exc})") from None
    if not all(np.all(np.isfinite(M)) for M in (lin.A, lin.B, lin.Ar, lin.Br)):
        raise ParameterError("the linearised model is not finite for these parameters "
                             f"({_largest_parameters(params)})")
    ef, er = lin.eig_full(), lin.eig_reduced()
    rest = unmatched_eigenvalues(ef, er)
    unstable = sorted((float(z.real) for z in er if z.real > 1e-6), reverse=True)
    ctrb = controllability(lin, horizon=horizon)
    chans = {}
    for name in CHANNELS:
        r = channel_poles_zeros(lin, name)
        chans[name] = {
            "outputs": list(CHANNELS[name][1]),
            "minimal_order": r["order"],
            "poles": _cplx(r["poles"]),
            "zeros": _cplx(r["zeros"]),
            "rhp_zeros": _cplx(r["rhp_zeros"]),
        }
    weak = ctrb["weakest_mode"]
    result: dict[str, Any] = {
        "operating_point": {
            "state": lin.op.x.tolist(),
            "tau": lin.op.tau.tolist(),
            "rpy_deg": lin.op.rpy_deg().tolist(),
            "trim_residual": lin.op.residual,
        },
        "n_states_full": NX,
        "n_states_reduced": NR,
        "reduced_state_names": list(REDUCED_STATE_NAMES),
        "reduction_invariance_error": lin.invariance_error,
        "eigenvalues_full": _cplx(ef),
        "eigenvalues_reduced": _cplx(er),
        "constraint_eigenvalues": _cplx(rest),
        "unstable_poles": unstable,
        "controllability_rank": ctrb["rank"],
        "controllability": {
            "scaling": dict(zip(REDUCED_STATE_NAMES, STATE_SCALE.tolist())),
            "input_scale_tau_max": lin.tau_max,
            "rtol": ctrb["rtol"],
            "singular_values": ctrb["singular_values"],
            "pbh": [
                {"eigenvalue": [e["eigenvalue"].real, e["eigenvalue"].imag],
                 "sigma_min": e["sigma_min"], "controllable": e["controllable"]}
                for e in ctrb["pbh"]
            ],
            "gramian_horizon_s": ctrb["horizon"],
            "modes": [
                {**m, "eigenvalues": _cplx(m["eigenvalues"])} for m in ctrb["modes"]
            ],
            "weakest_mode": {**weak, "eigenvalues": _cplx(weak["eigenvalues"])},
        },
        "channels": chans,
        **{f"rhp_zeros_{n}": _real_list([complex(*z) for z in c["rhp_zeros"]]) for n, c in chans.items()},
        "rhp_zeros_position": _real_list([complex(*z) for z in chans["pose"]["rhp_zeros"]]),
        "rhp_zeros_position_2x3": _real_list([complex(*z) for z in chans["position"]["rhp_zeros"]]),
        "planar_reduction": _quiet(planar_reduction, params),
    }
    return lin, result
