"""Super-twisting (second-order) sliding-mode balance controller (thesis ch. 11 future work).

``ballbot_sta(x, q_ref, dq_ref, ddq_ref, p, k, zb) -> (tau, diag, zb_next)``:
the interface of :func:`~ballbot_casadi.control.flc.make_flc` plus a *balance-controller
state* ``zb`` (3, the integral term of the algorithm) as the last input and its next
value as the last output.

Sliding manifold
----------------
The predecessor's manifold (V2019, thesis §8.3; :mod:`~ballbot_casadi.control.smc`) on the
shortest-path body-frame error quaternion (thesis 7.4, 7.5)::
    S = dy + K y,      y = vec(sigma q_ref* o q)

With the exact error-output dynamics ``ddy = D + E tau`` (thesis 8.12-8.25,
:mod:`~ballbot_casadi.control.decoupling`) and ``tau = E^-1 (v - D)`` (thesis 8.26),
``dS = v + K dy + delta``, ``delta`` collecting everything the internal model misses.

Super-twisting algorithm (Levant 1993; the thesis §11 proposal)
----------------------------------------------------------------
Per axis, the continuous law ``dS = -k1 |S|^(1/2) sgn S + z + delta``, ``dz = -k2 sgn S``
reaches ``S = dS = 0`` in finite time for any ``delta`` with ``|d delta/dt| <= L`` when
(Levant 1998, "Robust exact differentiation via sliding mode technique", Automatica
34(3), the sufficient rule quoted by Levant 2003, Int. J. Control 76(9/10))::
    k1 = 1.5 sqrt(L),   k2 = 1.1 L                                   (:func:`levant_gains`)

and for ``delta = 0`` within ``T <= 2 V(0)^(1/2) / gamma`` (Moreno & Osorio 2012,
"Strict Lyapunov functions for the super-twisting algorithm", IEEE TAC 57(4), Thm. 1;
:func:`moreno_osorio_time_bound`).  Unlike the first-order law with a boundary layer
(the thesis's SMC, stable only in the reaching phase), the switching acts on ``dS``
through the integral ``z``, so the torque is continuous and ``S`` converges exactly.

Discretisation for the period ``h = Ts`` (implicit, Brogliato, Polyakov & Efimov 2020,
"The implicit discretization of the super-twisting sliding-mode control algorithm",
IEEE TAC 65(8)): with ``S+`` the sliding variable one period ahead,
``S+ = S + h (-k1 |S+|^(1/2) xi + z+)``, ``z+ = z - h k2 xi``, ``xi in Sgn(S+)``.  Per axis,
with ``a = S + h z``, this has the closed-form unique solution (:func:`make_sta_step`)::
    |a| <= h^2 k2:  S+ = 0,                    xi = a / (h^2 k2)
    otherwise:      S+ = sgn(a) r^2,           xi = sgn(a),
                    r = (-h k1 + sqrt(h^2 k1^2 + 4 (|a| - h^2 k2))) / 2

and ``z+ = z - h k2 xi``.  The explicit Euler discretisation chatters numerically
(``|S| ~ (h k1 / 2)^2``); the implicit one does not, and on the nominal model reaches
``S = 0`` exactly.  Inside the band the implicit law is the one-step (deadbeat) law
``S+ = 0``: a perturbation ``delta`` is compensated in the torque by ``z -> -delta``, but
``S`` is left at the residual ``h delta`` of the period it acts in (first order in ``h``).  The commanded error acceleration ``v`` is the one that realises
``S(t_k + h) = S+`` on the zero-order-held double integrator ``ddy = v``
(``S+ = S + h (1 + K h / 2) v + h K dy``)::
    v = ((S+ - S) / h - K dy) / (1 + K h / 2)

Gains ``k = [K1, K2, K3, k1_1, k1_2, k1_3, k2_1, k2_2, k2_3, h]``: the manifold slopes
and the super-twisting gains from :func:`levant_gains` on the perturbation-derivative
bounds ``L`` (vec-quaternion units / s^3), and the discretisation step ``h`` (the control
period, thesis §7.1: 5 ms).  Defaults: tilt ``K = 10`` (the FLC's tilt pole, so the error
on the manifold decays as under the FLC) and ``L = 1.5``, yaw the V2019 ``K = 6`` and
``L = 0.75``.  With the algorithm's gains fixed by Levant's rule, ``L`` sets the reaching
speed: it is the largest bound for which the reaching from the thesis's 5 deg / 5 deg
initial tilt keeps the tilt rate inside the §7.1 limit of 20 deg/s, while ``|S|`` still
settles within 1 s (tests/control/test_super_twisting.py).  The V2019 tilt slope 15
would ask the tilt rate ``15 x tilt`` on the manifold, i.e. more than 20 deg/s unless
the reaching is too slow to settle in 1 s.

State slot
----------
The period carries ``zb`` (3 floats, initial value zeros) as the last field ``bal`` of
the controller state (:mod:`ballbot_casadi.sim.ports`, the balance-controller state
slot), passes it as the 7th argument and stores the 3rd output as its next value, in
balance-only mode (``cascade = 0``) too: it belongs to the balance controller, not to the
velocity loop.  ``h`` must equal the period's ``Ts`` (the default gains of
:func:`~ballbot_casadi.control.default_balance_gains` set it).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.linalg

from ballbot_casadi.control.balance_frame import BalanceFrame, balance_controller
from ballbot_casadi.control.decoupling import DampedInverse
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.errors import ScenarioError

__all__ = [
    "STA_GAIN_NAMES",
    "STA_DEFAULT_L",
    "STA_DEFAULT_GAINS",
    "STA_NZ",
    "levant_gains",
    "moreno_osorio_time_bound",
    "make_sta_step",
    "make_super_twisting",
]

#: Gain vector layout of the super-twisting controller.
STA_GAIN_NAMES = ("K1", "K2", "K3", "k1_1", "k1_2", "k1_3", "k2_1", "k2_2", "k2_3", "h")
#: Size of the balance-controller state ``zb`` (the integral term, one per axis).
STA_NZ = 3
#: Design bounds ``L`` on the perturbation derivative per axis (roll, pitch, yaw).
STA_DEFAULT_L = np.array([1.5, 1.5, 0.75])
_K_MANIFOLD = np.array([10.0, 10.0, 6.0])  # manifold slopes (module docstring)


def levant_gains(L: object) -> tuple[np.ndarray, np.ndarray]:
    """Super-twisting gains ``k1 = 1.5 sqrt(L)``, ``k2 = 1.1 L`` (Levant 1998/2003).

    ``L`` is the bound on ``|d delta / dt|`` per axis (must be > 0).
    """
    L = np.asarray(L, dtype=float).ravel()
    if not np.all(np.isfinite(L) & (L > 0)):
        raise ScenarioError(f"perturbation-derivative bound L must be finite and > 0, got {L}")
    return 1.5 * np.sqrt(L), 1.1 * L


def _default_gains() -> np.ndarray:
    k1, k2 = levant_gains(STA_DEFAULT_L)
    return np.concatenate([_K_MANIFOLD, k1, k2, [TS_CONTROL]])


#: Default gains: manifold slopes (10, 10, 6), Levant gains for ``L = (1.5, 1.5, 0.75)``, ``h = 5 ms``.
STA_DEFAULT_GAINS = _default_gains()


def moreno_osorio_time_bound(s0: float, z0: float, k1: float, k2: float) -> float:
    """Upper bound on the reaching time of the unperturbed super-twisting algorithm.

    Moreno & Osorio (2012), Thm. 1 with ``Q = I``: ``zeta = (|s|^(1/2) sgn s, z)``,
    ``A = [[-k1/2, 1/2], [-k2, 0]]``, ``A^T P + P A = -Q``, ``V = zeta^T P zeta`` and
    ``T <= 2 V(0)^(1/2) / gamma``, ``gamma = lambda_min(Q) lambda_min(P)^(1/2) / lambda_max(P)``.
    """
    A = np.array([[-k1 / 2, 0.5], [-k2, 0.0]])
    P = scipy.linalg.solve_continuous_lyapunov(A.T, -np.eye(2))
    lam = np.linalg.eigvalsh(0.5 * (P + P.T))
    zeta = np.array([np.sign(s0) * np.sqrt(abs(s0)), z0])
    gamma = np.sqrt(lam[0]) / lam[-1]
    return float(2.0 * np.sqrt(zeta @ P @ zeta) / gamma)


def make_sta_step(n: int = STA_NZ) -> ca.Function:
    """One implicit super-twisting period (module docstring), elementwise on ``n`` axes.

    Returns
    -------
    casadi.Function
        ``ballbot_sta_step(s[n], z[n], k1[n], k2[n], h) -> (s_next[n], z_next[n], w[n])``
        with ``w = (s_next - s) / h`` the sliding-variable rate to realise.
    """
    s, z, k1, k2 = (ca.SX.sym(name, n) for name in ("s", "z", "k1", "k2"))
    h = ca.SX.sym("h")
    a = s + h * z
    band = h**2 * k2
    inside = ca.fabs(a) <= band
    r = (-h * k1 + ca.sqrt(h**2 * k1**2 + 4 * ca.fmax(ca.fabs(a) - band, 0))) / 2
    sgn = ca.sign(a)
    s_next = ca.if_else(inside, 0, sgn * r**2)
    xi = ca.if_else(inside, a / band, sgn)
    z_next = z - h * k2 * xi
    return ca.Function("ballbot_sta_step", [s, z, k1, k2, h], [s_next, z_next, (s_next - s) / h],
                       ["s", "z", "k1", "k2", "h"], ["s_next", "z_next", "w"])


def make_super_twisting(affine: ca.Function, inverse: DampedInverse = DampedInverse()) -> ca.Function:
    """Build ``ballbot_sta``, the super-twisting balance controller (module docstring).

    ``affine``, ``inverse``, the signature with ``zb[STA_NZ]`` and ``diag``: as in
    :func:`~ballbot_casadi.control.balance_frame.balance_controller`; ``k`` as
    :data:`STA_GAIN_NAMES`; ``tau`` unsaturated.
    """

    def super_twisting_law(b: BalanceFrame) -> tuple[ca.MX, ca.MX, ca.MX]:
        K, k1, k2, h = b.k[0:3], b.k[3:6], b.k[6:9], b.k[9]
        S = b.o["dy"] + K * b.o["y"]
        _, zb_next, w = make_sta_step()(S, b.zb, k1, k2, h)
        v = (w - K * b.o["dy"]) / (1 + K * h / 2)  # realises S(t + h) = S+ under the ZOH
        tau, diag = b.linearising_torque(v)  # (8.26)
        return tau, diag, zb_next

    return balance_controller("sta", affine, len(STA_GAIN_NAMES), super_twisting_law, STA_NZ,
                              inverse=inverse)
