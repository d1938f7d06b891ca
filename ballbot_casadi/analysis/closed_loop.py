"""Linearised closed loop of the cascade: loop bandwidths and the 3x rule (thesis §7.1, §9.1).

The thesis runs the FLC balance controller (inner loop, ch. 8) inside the velocity
controller (outer loop, §7.3) and requires the inner loop to be at least three times
faster than the outer one (§7.1); it measures the attitude bandwidth with a chirp test
(§9.1).  This module linearises the sampled cascade at an operating point of
:func:`ballbot_casadi.model.linearization.linearize` by CasADi automatic differentiation through the
controller Functions (:mod:`ballbot_casadi.control`) and computes both loops'
frequency responses and bandwidths.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg as sla

from ballbot_casadi import control as C
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import REDUCED_STATE, REDUCED_TILT, STATE
from ballbot_casadi.core.layout import VELOCITY_CONTROLLER_STATE as Z
from ballbot_casadi.core.params import Params
from ballbot_casadi.errors import ParameterError
from ballbot_casadi.model.dynamics import NX, make_model_functions
from ballbot_casadi.model.linearization import NR, LinearModel

__all__ = [
    "TS_CONTROL",
    "zoh",
    "dfreq",
    "bandwidth_3db",
    "bandwidth_sensitivity",
    "analyze_closed_loop",
]

#: Offset of the velocity reference at which the velocity controller is differentiated
#: (m/s); its speed limiter ``sqrt(vx^2 + vy^2)`` has a NaN derivative at exactly zero.
_VREF_EPS = 1e-9


def zoh(A: np.ndarray, B: np.ndarray, Ts: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation ``(e^{A Ts}, int_0^Ts e^{A s} ds B)``."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = sla.expm(M * Ts)
    return E[:n, :n], E[:n, n:]


def dfreq(A: np.ndarray, B: np.ndarray, C: np.ndarray, omega: np.ndarray, Ts: float) -> np.ndarray:
    """Frequency response ``C (z I - A)^-1 B`` at ``z = exp(j omega Ts)``; shape (len(omega), p, m)."""
    n = A.shape[0]
    return np.array([C @ np.linalg.solve(np.exp(1j * w * Ts) * np.eye(n) - A, B) for w in omega])


def _crossing(omega: np.ndarray, y: np.ndarray, level: float, i: int) -> float:
    """Frequency between grid points ``i - 1`` and ``i`` where ``y`` crosses ``level``.

    Linear in log-frequency; in log-magnitude when both ends are positive, linearly in
    magnitude when one end is exactly zero (a log-log line cannot reach zero, and a floor
    put in its place would move the crossing by an arbitrary amount).
    """
    y0, y1 = float(y[i - 1]), float(y[i])
    if y0 > 0 and y1 > 0:
        frac = (np.log10(level) - np.log10(y0)) / (np.log10(y1) - np.log10(y0))
    else:
        frac = (level - y0) / (y1 - y0)
    lw = np.log10(omega[i - 1 : i + 1])
    return float(10 ** (lw[0] + frac * (lw[1] - lw[0])))


def bandwidth_3db(omega: np.ndarray, mag: np.ndarray) -> float | None:
    """First frequency where ``|T|`` falls 3 dB below its low-frequency value ``mag[0]``.

    Linear interpolation in log-frequency/dB between grid points (linear in magnitude
    towards a grid point where ``|T|`` is exactly 0); ``None`` when the magnitude never
    drops that far on the grid, or when ``mag[0]`` is 0 (no low-frequency value to fall from).
    """
    mag = np.asarray(mag, dtype=float)
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(mag)  # -inf where the magnitude is exactly 0
    target = db[0] - 3.0103
    below = np.nonzero(db < target)[0]
    if below.size == 0:
        return None
    i = int(below[0])
    if i == 0:
        return float(omega[0])
    return _crossing(omega, mag, 10 ** (target / 20), i)


def analyze_closed_loop(
    params: Params,
    lin: LinearModel,
    functions: dict[str, ca.Function] | None = None,
    Ts: float = TS_CONTROL,
    omega: np.ndarray | None = None,
) -> dict[str, Any]:
    """Linearise the cascade (FLC inner loop, velocity outer loop) and find its bandwidths.

    The loop is analysed as it runs (thesis Fig. 7.1 and ``ballbot_casadi.sim.period``):
    both controllers sample the state every ``Ts`` and the wheel torques are held
    (zero-order hold).  The plant linearisation ``(A, B)`` at the operating point is
    discretised exactly (:func:`zoh`); the controllers are linearised by CasADi automatic
    differentiation through ``ballbot_flc`` and ``ballbot_velocity`` (default gains,
    internal model = plant).  At 200 Hz this differs from the continuous design only by
    ~Ts/2 of delay.

    * Inner loop: tilt reference -> tilt, ``q_ref = [1, r] o q0`` with
      ``dq_ref = ddq_ref = 0`` (the chirp test of thesis §9.1 on the quaternion alone;
      with the exact feedforward ``dq_ref, ddq_ref`` the FLC tracks at every frequency).
      For the continuous FLC this is ``Kp / (s^2 + Kd s + Kp)`` per axis (thesis 8.45).
    * Outer loop: velocity reference ``(vx, vy)`` -> ball velocity ``(dx, dy)`` with the
      velocity controller's state (reference model, integrators) in the loop.

    Bandwidths, per diagonal element, the loop value being the smaller of the two axes:
    * ``bandwidth_*_hz``: the -3 dB point of ``|T|`` (:func:`bandwidth_3db`);
    * ``bandwidth_sensitivity_*_hz``: where the tracking error ``|1 - T|`` reaches -3 dB
      (:func:`bandwidth_sensitivity`).  For the outer loop ``|T|`` stays near 0 dB up to
      a few Hz only because the ball then moves *out of phase* with the reference (the
      RHP zero's inverse response through the direct path v_ref -> tilt acceleration ->
      torque), so the -3 dB point of ``|T|`` overstates the useful bandwidth; the
      sensitivity bandwidth does not, and the 3x rule verdict ``cascade_rule_ok`` uses
      it (``cascade_rule_ok_3db`` gives the |T| version).

    When no stabilising velocity gain exists for the parameters (e.g. ``g = 0``, where
    nothing is unstable to balance and the tilt cannot accelerate the ball), or the
    linearised loop cannot be evaluated numerically, the closed-loop part is skipped
    and ``closed_loop`` says why (``status`` ``skipped`` or ``failed``, ``message``).

    Returns
    -------
    dict
        ``closed_loop`` (details or a ``status``/``message`` when not computed),
        ``bandwidth_inner_hz``, ``bandwidth_outer_hz``, ``bandwidth_ratio``,
        ``cascade_rule_ok_3db``, ``bandwidth_sensitivity_inner_hz``,
        ``bandwidth_sensitivity_outer_hz``, ``bandwidth_sensitivity_ratio`` and
        ``cascade_rule_ok`` (ratio >= 3, thesis §7.1).
    """
    none = {"bandwidth_inner_hz": None, "bandwidth_outer_hz": None, "bandwidth_ratio": None,
            "cascade_rule_ok_3db": None, "bandwidth_sensitivity_inner_hz": None,
            "bandwidth_sensitivity_outer_hz": None, "bandwidth_sensitivity_ratio": None,
            "cascade_rule_ok": None}
    funcs = functions if functions is not None else make_model_functions()
    p = params.to_vector()
    try:
        kv = np.asarray(C.default_velocity_gains(funcs["jac"], p, Ts), dtype=float)
    except ParameterError as exc:  # e.g. g = 0: reported as a result, not a crash
        return {**none, "closed_loop": {"status": "skipped", "message": str(exc)}}
    try:
        with np.errstate(all="ignore"):
            return _analyze(params, lin, funcs, p, kv, Ts, omega, none)
    except (np.linalg.LinAlgError, ArithmeticError) as exc:
        return {**none, "closed_loop": {
            "status": "failed",
            "message": f"the linearised cascade is numerically intractable for these "
                       f"parameters ({type(exc).__name__}: {exc})"}}


def _analyze(params: Params, lin: LinearModel, funcs: dict[str, ca.Function], p: np.ndarray,
             kv: np.ndarray, Ts: float, omega: np.ndarray | None,
             none: dict[str, Any]) -> dict[str, Any]:
    """The body of :func:`analyze_closed_loop` once the velocity gain exists."""
    cf = {"flc": C.make_flc(funcs["affine"]), "vel": C.make_velocity_controller()}
    x0 = lin.op.x
    kb = np.asarray(C.default_balance_gains("flc"), dtype=float)
    z0 = np.asarray(C.velocity_initial_state(x0), dtype=float)
    v0 = np.array([x0[STATE.index("dx")] + _VREF_EPS, x0[STATE.index("dy")], 0.0])
    nz = int(C.VELOCITY_NZ)

    # symbolic cascade around the operating point
    x, z, v = ca.MX.sym("x", NX), ca.MX.sym("z", nz), ca.MX.sym("v", 3)
    r = ca.MX.sym("r", 3)  # tilt-reference perturbation (vector part, {K} frame)
    q0 = x0[STATE["q"]]
    q_ref = ca.mtimes(ca.DM(Q.Gamma(q0)), ca.vertcat(ca.sqrt(1 - ca.sumsqr(r)), r))
    zero4 = ca.DM.zeros(4)
    tau_in = cf["flc"](x, q_ref, zero4, zero4, p, kb)[0]
    qv, dqv, ddqv, z_next = cf["vel"](x, v, z, p, kv, Ts)
    tau_out = cf["flc"](x, qv, dqv, ddqv, p, kb)[0]
    outs = ("ti", "Kx", "Kr", "to", "Lx", "Lz", "Lv", "zn", "Zx", "Zz", "Zv")
    J = ca.Function(
        "cl_jac", [x, z, v, r],
        [tau_in, ca.jacobian(tau_in, x), ca.jacobian(tau_in, r),
         tau_out, ca.jacobian(tau_out, x), ca.jacobian(tau_out, z), ca.jacobian(tau_out, v),
         z_next, ca.jacobian(z_next, x), ca.jacobian(z_next, z), ca.jacobian(z_next, v)],
        ["x", "z", "v", "r"], list(outs),
    )

    def jac_at(xx: np.ndarray, zz: np.ndarray, vv: Any) -> dict[str, np.ndarray]:
        res = J(x=xx, z=zz, v=vv, r=np.zeros(3))
        return {k: np.asarray(res[k], dtype=float) for k in outs}

    vals = jac_at(x0, z0, v0)
    # integrator state that holds the operating point (COM offset, rolling): a = 0.  The
    # reference acceleration may start saturated, so the slope d(Ts a)/d p_e is taken at
    # the upright state at rest, where the controller is linear (fixed-point iteration).
    x_up = np.zeros(NX)
    x_up[STATE["q"]] = Q.from_rpy(0.0, 0.0, float(Q.to_rpy(x0[STATE["q"]])[2]))
    # d(tilt-reference rate) / d(position error): the tilt-reference rate must stay 0
    J_pe = jac_at(x_up, C.velocity_initial_state(x_up), [_VREF_EPS, 0, 0])["Zz"][Z["dtheta_r"], Z["p_e"]]
    for _ in range(50):
        step = vals["zn"].ravel()[Z["dtheta_r"]] - z0[Z["dtheta_r"]]
        if np.max(np.abs(step)) < 1e-14 or not np.all(np.isfinite(J_pe)):
            break
        z0 = z0.copy()
        z0[Z["p_e"]] -= np.linalg.lstsq(J_pe, step, rcond=None)[0]
        vals = jac_at(x0, z0, v0)
    ti, Kx, Kr, to, Lx, Lz, Lv, zn, Zx, Zz, Zv = (vals[k] for k in outs)
    if not all(np.all(np.isfinite(m)) for m in vals.values()):
        return {**none, "closed_loop": {"status": "failed",
                                        "message": "non-finite controller Jacobian"}}
    res = {"balance torque": float(np.max(np.abs(ti.ravel() - lin.op.tau))),
           "cascade torque": float(np.max(np.abs(to.ravel() - lin.op.tau))),
           "velocity-controller state": float(np.max(np.abs(zn.ravel() - z0)))}
    if max(res.values()) > 1e-6:
        return {**none, "closed_loop": {
            "status": "skipped",
            "message": "the default controllers do not hold this operating point ("
                       + ", ".join(f"{k} mismatch {v:.2g}" for k, v in res.items()) + ")"}}

    Phi, Gam = zoh(lin.A, lin.B, Ts)
    T = lin.T
    omega = np.logspace(-2, np.log10(np.pi / Ts), 600) if omega is None else np.asarray(omega)

    # inner loop on the reduced state (the tangent space stays invariant)
    Ai = T.T @ (Phi + Gam @ Kx) @ T
    Bi = T.T @ Gam @ Kr[:, :2]  # tilt-reference perturbation about {K} x and y
    Ci = np.zeros((2, NR))
    Ci[[0, 1], [REDUCED_TILT.start, REDUCED_TILT.start + 1]] = 1.0  # tilt about {K} x and y
    # outer loop: reduced plant state + controller state
    Ao = np.block([[T.T @ (Phi + Gam @ Lx) @ T, T.T @ Gam @ Lz], [Zx @ T, Zz]])
    Bo = np.vstack([T.T @ Gam @ Lv[:, :2], Zv[:, :2]])  # velocity reference vx, vy
    Co = np.zeros((2, NR + nz))
    Co[[0, 1], [REDUCED_STATE.index("dx"), REDUCED_STATE.index("dy")]] = 1.0  # ball velocity

    out: dict[str, Any] = {"status": "ok", "Ts": Ts}
    bw: dict[str, float | None] = {}
    bw_s: dict[str, float | None] = {}
    for key, (Ad, Bd, Cd) in {"inner": (Ai, Bi, Ci), "outer": (Ao, Bo, Co)}.items():
        H = dfreq(Ad, Bd, Cd, omega, Ts)
        axes = [bandwidth_3db(omega, np.abs(H[:, i, i])) for i in range(2)]
        axes_s = [bandwidth_sensitivity(omega, H[:, i, i]) for i in range(2)]
        bw[key] = None if any(a is None for a in axes) else min(axes) / (2 * np.pi)
        bw_s[key] = None if any(a is None for a in axes_s) else min(axes_s) / (2 * np.pi)
        out[key] = {
            "bandwidth_axes_hz": [None if a is None else a / (2 * np.pi) for a in axes],
            "bandwidth_sensitivity_axes_hz": [None if a is None else a / (2 * np.pi) for a in axes_s],
            "dc_gain": [float(abs(H[0, i, i])) for i in range(2)],
            "peak_gain_db": [float(20 * np.log10(np.max(np.abs(H[:, i, i])))) for i in range(2)],
            **_discrete_stability(Ad, Ts),
        }
        out.setdefault("frequency_response", {})[key] = {
            "omega": omega.tolist(), "mag": np.abs(H[:, 0, 0]).tolist(),
            "phase_deg": np.degrees(np.unwrap(np.angle(H[:, 0, 0]))).tolist()}
    out["max_real_pole"] = max(out["inner"]["max_real_pole"], out["outer"]["max_real_pole"])
    gains = dict(zip(C.BALANCE_GAIN_NAMES["flc"], kb))
    kp, kd = gains["Kp1"], gains["Kd1"]  # the tilt about x (thesis 8.45)
    out["inner_continuous_hz"] = _second_order_bw(kp, kd) / (2 * np.pi)
    out["description"] = (
        f"Sampled-data cascade at Ts = {Ts * 1e3:g} ms (zero-order hold, as simulated): plant "
        "discretised exactly, FLC and velocity controller linearised by CasADi AD with their "
        "default gains. Inner loop: tilt reference (quaternion only, dq_ref = ddq_ref = 0) -> "
        "tilt; outer loop: velocity reference -> ball velocity with the velocity controller's "
        f"states in the loop. Continuous FLC check: Kp/(s^2 + Kd s + Kp) with Kp = {kp:g}, "
        f"Kd = {kd:g} has a -3 dB bandwidth of {out['inner_continuous_hz']:.4f} Hz."
    )
    ratio = bw["inner"] / bw["outer"] if bw["inner"] and bw["outer"] else None
    ratio_s = bw_s["inner"] / bw_s["outer"] if bw_s["inner"] and bw_s["outer"] else None
    return {
        "closed_loop": out,
        "bandwidth_inner_hz": bw["inner"],
        "bandwidth_outer_hz": bw["outer"],
        "bandwidth_ratio": ratio,
        "cascade_rule_ok_3db": None if ratio is None else bool(ratio >= 3.0),
        "bandwidth_sensitivity_inner_hz": bw_s["inner"],
        "bandwidth_sensitivity_outer_hz": bw_s["outer"],
        "bandwidth_sensitivity_ratio": ratio_s,
        "cascade_rule_ok": None if ratio_s is None else bool(ratio_s >= 3.0),
    }


def _discrete_stability(Ad: np.ndarray, Ts: float, tol: float = 1e-7) -> dict[str, Any]:
    """Stability summary of a discrete closed loop.

    Eigenvalues on the unit circle (``|z| = 1`` within ``tol``) are the neutral modes the
    cascade leaves open by design (ball position and heading integrators: the velocity
    loop feeds back velocity and the integral of the velocity error, not position).
    ``max_real_pole`` is the largest continuous-equivalent real part ``ln|z| / Ts`` of the
    remaining modes.
    """
    mag = np.abs(np.linalg.eigvals(Ad))
    neutral = np.abs(mag - 1.0) <= tol
    rest = mag[~neutral]
    return {
        "n_neutral_modes": int(np.sum(neutral)),
        "max_real_pole": float(np.max(np.log(rest)) / Ts) if rest.size else float("-inf"),
        "stable_apart_from_neutral": bool(rest.size == 0 or np.max(rest) < 1.0),
    }


def bandwidth_sensitivity(omega: np.ndarray, H: np.ndarray) -> float | None:
    """Sensitivity bandwidth: first frequency where ``|1 - H/H(0)|`` rises to ``1/sqrt(2)``.

    The frequency up to which the tracking error is attenuated (Skogestad and
    Postlethwaite, Multivariable Feedback Control, §2.4.5: ``omega_B``).  Unlike the
    -3 dB point of ``|H|`` it is not fooled by a non-minimum-phase loop whose output
    still moves, but out of phase, at high frequency.  Log interpolation (linear in
    magnitude from a grid point where the error is exactly 0); ``None`` when not reached
    on the grid.
    """
    H = np.asarray(H, dtype=complex)
    S = np.abs(1.0 - H / np.abs(H[0]))
    above = np.nonzero(S >= 1 / np.sqrt(2))[0]
    if above.size == 0:
        return None
    i = int(above[0])
    if i == 0:
        return float(omega[0])
    return _crossing(omega, S, 1 / np.sqrt(2), i)


def _second_order_bw(kp: float, kd: float) -> float:
    """-3 dB bandwidth (rad/s) of ``kp / (s^2 + kd s + kp)``: root of ``|T(j w)|^2 = 1/2``."""
    # (kp - w^2)^2 + kd^2 w^2 = 2 kp^2  ->  w^4 + (kd^2 - 2 kp) w^2 - kp^2 = 0
    b = kd**2 - 2 * kp
    return float(np.sqrt((-b + np.sqrt(b * b + 4 * kp**2)) / 2))
