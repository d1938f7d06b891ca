"""The "full" prediction model: the exact linearisation of the closed loop as it runs.

The shipped prediction model (:func:`ballbot_casadi.guidance.prediction.closed_velocity_loop`)
is the velocity loop's *design* model: the plant reduced to the tilt axes, closed by the
*continuous* linearised balance controller, with only the LQR sampled.  The loop that
actually runs is sampled throughout: every control period ``Ts`` the balance controller
(FLC, thesis 8.26/8.44) and the velocity LQR (thesis §7.3) read the full 3D plant state,
and the wheel torque is held over the period.  Its exact linearisation at the upright
equilibrium is one matrix pair per period,

``w+ = A1 w + B1 v_ref``,  ``w = [x (12), z (8)]`` (plant and velocity-controller state),

handed in as numbers (this layer imports neither the model nor the controllers; the
builder is :func:`ballbot_casadi.sim.prediction_models.full_loop_model`).  Composed over
``m = dt / Ts`` periods with ``v_ref`` held, and expressed in the loop model's coordinates
``X = T w`` (``T`` the Jacobian of the loop-state map, velocity, tilt, tilt rate, the
reference model, ``p_e`` and the position) through the lift ``w = L X`` (``T L = I``, the
heading, heading rate, heading reference and the quaternion's norm direction at their
upright values), it is a :class:`~ballbot_casadi.guidance.prediction.LoopModel` with the
shipped state layout, so the MPC takes it unchanged:

``A = T A1^m L``,  ``B = T sum_{i<m} A1^i B1``.

The reduction is exact when the upright, heading-free motions stay heading free
(``(I - L T) A1 L = 0``, :func:`reduction_residual`; the heading decouples from the tilt
axes at first order).  Outputs: ``v``, ``tilt``, ``tilt_rate`` are states; the ball
acceleration ``acc`` and the tilt-reference acceleration ``tilt_acc`` are the rows ``Cw``,
``Dw`` handed in (at the start of a period, on ``w`` and ``v_ref``), mapped by ``L``.
"""

from __future__ import annotations

import numpy as np

from ballbot_casadi.errors import ShapeError
from ballbot_casadi.guidance.prediction import NXL, LoopModel

__all__ = ["sampled_loop_model", "reduction_residual", "compose_periods"]


def _check(A1: np.ndarray, B1: np.ndarray, T: np.ndarray, L: np.ndarray) -> int:
    n = A1.shape[0]
    if A1.shape != (n, n) or B1.shape != (n, 2) or T.shape != (NXL, n) or L.shape != (n, NXL):
        raise ShapeError(f"A1, B1, T, L must be nxn, nx2, {NXL}xn, nx{NXL} for one n, got "
                         f"{A1.shape}, {B1.shape}, {T.shape}, {L.shape}")
    if not np.allclose(T @ L, np.eye(NXL), atol=1e-9):
        raise ShapeError("the lift L must be a right inverse of the loop-state map T (T L = I)")
    return n


def compose_periods(A1: np.ndarray, B1: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """``(A1^m, sum_{i<m} A1^i B1)``: ``m`` periods with the input held."""
    A, B = np.eye(A1.shape[0]), np.zeros_like(B1)
    for _ in range(int(m)):
        A, B = A1 @ A, A1 @ B + B1
    return A, B


def reduction_residual(A1: np.ndarray, T: np.ndarray, L: np.ndarray) -> float:
    """``max |(I - L T) A1 L|``: how far one period leaves the heading-free subspace
    (0: the reduction to the loop coordinates is exact)."""
    A1, T, L = (np.asarray(M, float) for M in (A1, T, L))
    return float(np.max(np.abs((np.eye(A1.shape[0]) - L @ T) @ A1 @ L)))


def sampled_loop_model(A1: np.ndarray, B1: np.ndarray, T: np.ndarray, L: np.ndarray,
                       Cw: dict, Dw: dict, Ts: float, dt: float) -> LoopModel:
    """The :class:`LoopModel` of the sampled closed loop (module docstring).

    Parameters
    ----------
    A1, B1
        One control period of the closed loop linearised at upright (n x n, n x 2), on
        ``w`` and the held ``v_ref``.
    T, L
        Loop-state map (14 x n) and its lift (n x 14), ``T L = I``.
    Cw, Dw
        ``{"acc": (2 x n), "tilt_acc": (2 x n)}`` and their ``v_ref`` parts (2 x 2).
    Ts, dt
        Control period and MPC step (s), ``dt`` an integer multiple of ``Ts``.
    """
    A1, B1, T, L = (np.asarray(M, float) for M in (A1, B1, T, L))
    _check(A1, B1, T, L)
    m = int(round(dt / Ts))
    if m < 1 or abs(m * Ts - dt) > 1e-9 * dt:
        raise ShapeError(f"dt = {dt} s must be an integer multiple of Ts = {Ts} s")
    Am, Bm = compose_periods(A1, B1, m)
    A, B = T @ Am @ L, T @ Bm
    sel = {"v": 0, "tilt": 2, "tilt_rate": 4}
    C = {k: np.eye(NXL)[i:i + 2] for k, i in sel.items()}
    D = {k: np.zeros((2, 2)) for k in sel}
    for key in ("acc", "tilt_acc"):
        Cr, Dr = np.asarray(Cw[key], float), np.asarray(Dw[key], float)
        if Cr.shape != (2, A1.shape[0]) or Dr.shape != (2, 2):
            raise ShapeError(f"output {key}: rows must be 2 x {A1.shape[0]} and 2 x 2, got "
                             f"{Cr.shape}, {Dr.shape}")
        C[key], D[key] = Cr @ L, Dr
    return LoopModel(A, B, C, D, float(dt))
