"""Prediction model of the MPC: the linear closed velocity loop (velocity LQR + balance loop).

The MPC commands velocity references ``v_ref`` to the existing velocity LQR
(:mod:`ballbot_casadi.control.velocity`), so it predicts the *closed* velocity loop.
Its linear model is built from the velocity loop's own design model (thesis §7.3: the
plant linearised at the upright equilibrium, closed by the linearised balance
controller, with the tilt-reference model and the position-error integrators; state
``X = [v(2), theta(2), dtheta(2), theta_r(2), dtheta_r(2), p_e(2)]``) and its LQR gain
``K``, handed in as numbers (this layer imports neither the model nor the controllers):

* continuous ``X' = Ac X + Bc a - F v_ref`` (``p_e' = v - v_ref``), position ``p' = v``;
* the LQR at the control period ``Ts`` with ``a = -K (X - E v_ref)`` held over each
  period (exact ZOH), composed ``dt / Ts`` times with ``v_ref`` held over the MPC step.

The result is exact for the linearised sampled loop at the MPC nodes.  Outputs (rows of
``C`` acting on ``[X, p]`` and ``D`` on ``v_ref``): velocity, tilt, tilt rate, the
acceleration of the ball and the tilt-reference acceleration ``a`` (the torque budget of
the balance loop: bounded, it bounds the torque, thesis §7.1 / the velocity LQR's
``tilt_acc_max``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ballbot_casadi.errors import ShapeError

__all__ = ["LoopModel", "closed_velocity_loop", "open_loop_period", "NXL", "LOOP_OUTPUTS"]

#: States of the closed velocity loop model: X (12) and position (2).
NXL = 14
#: The loop model's outputs (two rows each): velocity, tilt, tilt rate, ball acceleration,
#: tilt-reference acceleration.
LOOP_OUTPUTS = ("v", "tilt", "tilt_rate", "acc", "tilt_acc")


@dataclass(frozen=True)
class LoopModel:
    """Discrete linear prediction model ``x+ = A x + B v_ref`` at the MPC step ``dt``.

    ``x = [v(2), theta(2), dtheta(2), theta_r(2), dtheta_r(2), p_e(2), p(2)]``.  Outputs
    ``y = C[name] x + D[name] v_ref`` for ``name`` in ``v``, ``tilt``, ``tilt_rate``,
    ``acc``, ``tilt_acc`` (each 2 rows, :data:`LOOP_OUTPUTS`).

    Raises
    ------
    ShapeError
        ``A`` not 14 x 14, ``B`` not 14 x 2, an output missing or extra, a ``C`` map not
        2 x 14, a ``D`` map not 2 x 2, or ``dt`` not a positive number (one line naming it).
    """

    A: np.ndarray
    B: np.ndarray
    C: dict
    D: dict
    dt: float

    def __post_init__(self) -> None:
        shapes = {"A": (np.shape(self.A), (NXL, NXL)), "B": (np.shape(self.B), (NXL, 2))}
        if set(self.C) != set(LOOP_OUTPUTS) or set(self.D) != set(LOOP_OUTPUTS):
            raise ShapeError(f"the loop model's outputs must be {list(LOOP_OUTPUTS)}, got C "
                             f"{sorted(self.C)}, D {sorted(self.D)}")
        for name in LOOP_OUTPUTS:
            shapes[f"C[{name!r}]"] = (np.shape(self.C[name]), (2, NXL))
            shapes[f"D[{name!r}]"] = (np.shape(self.D[name]), (2, 2))
        for what, (got, want) in shapes.items():
            if got != want:
                raise ShapeError(f"the loop model's {what} must be {want[0]}x{want[1]}, got {got}")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise ShapeError(f"the loop model's dt must be > 0 s, got {self.dt!r}")

    def simulate(self, x0: np.ndarray, v_ref: np.ndarray) -> np.ndarray:
        """States over a sequence of held references ``v_ref`` (M, 2): (M+1, NXL)."""
        xs = [np.asarray(x0, float)]
        for v in np.asarray(v_ref, float):
            xs.append(self.A @ xs[-1] + self.B @ v)
        return np.array(xs)


def open_loop_period(Ac: np.ndarray, Bc: np.ndarray, Ts: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One control period of the design model augmented with the position, before the
    LQR closes it: ``x+ = Phi x + Ga a + Gv v_ref`` (exact ZOH, ``a`` and ``v_ref`` held),
    and the continuous ``(Acont, Bcont)`` on ``[X, p]`` and inputs ``[a, v_ref]``."""
    n = NXL
    Acont = np.zeros((n, n))
    Acont[:12, :12] = Ac
    Acont[12:14, 0:2] = np.eye(2)
    Bcont = np.zeros((n, 4))
    Bcont[:12, 0:2] = Bc
    Bcont[10:12, 2:4] = -np.eye(2)
    M = np.zeros((n + 4, n + 4))
    M[:n, :n], M[:n, n:] = Acont, Bcont
    Md = scipy.linalg.expm(M * Ts)
    return Md[:n, :n], Md[:n, n:n + 2], Md[:n, n + 2:], Acont, Bcont


def closed_velocity_loop(Ac: np.ndarray, Bc: np.ndarray, K: np.ndarray, Ts: float,
                         dt: float) -> LoopModel:
    """Build the :class:`LoopModel` (see the module docstring).

    Parameters
    ----------
    Ac, Bc
        Continuous design model of the velocity loop (12x12, 12x2), e.g. the first two
        results of :func:`ballbot_casadi.control.velocity.design_model`.
    K
        LQR gain (2x12).
    Ts
        Control period of the velocity loop (s).
    dt
        MPC step (s), an integer multiple of ``Ts``.
    """
    Ac, Bc, K = (np.asarray(M, float) for M in (Ac, Bc, K))
    if Ac.shape != (12, 12) or Bc.shape != (12, 2) or K.shape != (2, 12):
        raise ShapeError(f"Ac, Bc, K must be 12x12, 12x2, 2x12, got {Ac.shape}, {Bc.shape}, {K.shape}")
    m = int(round(dt / Ts))
    if m < 1 or abs(m * Ts - dt) > 1e-9 * dt:
        raise ShapeError(f"dt = {dt} s must be an integer multiple of Ts = {Ts} s")
    n = NXL
    Phi, Ga, Gv, Acont, Bcont = open_loop_period(Ac, Bc, Ts)
    Kx = np.zeros((2, n))
    Kx[:, :12] = K
    E = np.zeros((n, 2))
    E[0:2, 0:2] = np.eye(2)
    A1 = Phi - Ga @ Kx
    B1 = Ga @ Kx @ E + Gv
    A, B = np.eye(n), np.zeros((n, 2))
    for _ in range(m):
        A, B = A1 @ A, A1 @ B + B1
    sel = {"v": 0, "tilt": 2, "tilt_rate": 4}
    C = {k: np.eye(n)[i:i + 2] for k, i in sel.items()}
    D = {k: np.zeros((2, 2)) for k in sel}
    C["acc"] = Acont[0:2] - Bcont[0:2, 0:2] @ Kx
    D["acc"] = Bcont[0:2, 0:2] @ K @ E[:12]
    C["tilt_acc"], D["tilt_acc"] = -Kx, K @ E[:12]
    return LoopModel(A, B, C, D, float(dt))
