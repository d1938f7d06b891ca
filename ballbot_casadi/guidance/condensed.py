"""Condensed prediction of the MPC: states as constant linear maps of the blocked inputs.

The MPC's prediction model is linear and time invariant (the closed velocity loop of
:mod:`ballbot_casadi.guidance.prediction` plus the progress double integrator), so the
states can be eliminated once, at build time (condensing):

``X_k = Phi_k x0 + Gamma_k T ub``,  ``k = 0..N``

with ``x0 = [loop state (14), s, ds]``, the per-step inputs ``u_k = [v_ref (2), dds]``
and *move blocking*: the input is held over blocks of steps (``blocks``, e.g.
``(1, 1, 1, 1, 2, 2, 2, 2, 4, 4)`` for N = 20), ``u = T ub``.  All matrices are
constants; the QP keeps only the ``3 * len(blocks)`` blocked inputs as unknowns.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.guidance.prediction import NXL, LoopModel

__all__ = ["Condensed", "condense", "NX_MPC", "NU_MPC"]

#: MPC state: loop model (14), progress s and its rate.
NX_MPC = NXL + 2
#: MPC input per step: velocity reference (2), progress acceleration.
NU_MPC = 3


@dataclass(frozen=True)
class Condensed:
    """Condensed maps of the augmented model (see the module docstring).

    Attributes
    ----------
    A, B
        Augmented one-step model ``X+ = A X + B u`` (16x16, 16x3).
    Phi
        ``(N+1, 16, 16)``: ``X_k = Phi[k] x0 + Gamma[k] ub``.
    Gamma
        ``(N+1, 16, nb*3)`` (blocking included).
    T
        ``(N, 3, nb*3)``: the input of step ``k`` is ``T[k] ub``.
    block_of
        Block index of each step ``k`` (N,).
    """

    A: np.ndarray
    B: np.ndarray
    Phi: np.ndarray
    Gamma: np.ndarray
    T: np.ndarray
    block_of: np.ndarray
    blocks: tuple[int, ...]
    dt: float

    @property
    def N(self) -> int:
        return int(self.T.shape[0])

    @property
    def n_u(self) -> int:
        """Number of unknowns (blocked inputs)."""
        return int(self.T.shape[2])

    def states(self, x0: np.ndarray, ub: np.ndarray) -> np.ndarray:
        """Predicted states ``(N+1, 16)``."""
        return self.Phi @ np.asarray(x0, float) + self.Gamma @ np.asarray(ub, float)

    def inputs(self, ub: np.ndarray) -> np.ndarray:
        """Per-step inputs ``(N, 3)``."""
        return self.T @ np.asarray(ub, float)

    def block(self, u_steps: np.ndarray) -> np.ndarray:
        """Blocked inputs from per-step inputs ``(N, 3)``: each block's first step."""
        u_steps = np.asarray(u_steps, float)
        starts = np.concatenate([[0], np.cumsum(self.blocks)[:-1]])
        return u_steps[starts].ravel()


def condense(model: LoopModel, blocks: tuple[int, ...]) -> Condensed:
    """Condense ``model`` (step ``model.dt``) over ``sum(blocks)`` steps with move blocking."""
    blocks = tuple(int(b) for b in blocks)
    if not blocks or min(blocks) < 1:
        raise ScenarioError(f"blocks must be positive step counts, got {blocks!r}")
    N, nb, dt = sum(blocks), len(blocks), model.dt
    A = np.zeros((NX_MPC, NX_MPC))
    A[:NXL, :NXL] = model.A
    A[NXL:, NXL:] = [[1.0, dt], [0.0, 1.0]]
    B = np.zeros((NX_MPC, NU_MPC))
    B[:NXL, :2] = model.B
    B[NXL:, 2] = [0.5 * dt**2, dt]
    block_of = np.repeat(np.arange(nb), blocks)
    T = np.zeros((N, NU_MPC, NU_MPC * nb))
    for k in range(N):
        b = block_of[k]
        T[k, :, NU_MPC * b:NU_MPC * (b + 1)] = np.eye(NU_MPC)
    Phi = np.zeros((N + 1, NX_MPC, NX_MPC))
    Gamma = np.zeros((N + 1, NX_MPC, NU_MPC * nb))
    Phi[0] = np.eye(NX_MPC)
    for k in range(N):
        Phi[k + 1] = A @ Phi[k]
        Gamma[k + 1] = A @ Gamma[k] + B @ T[k]
    # drop the rounding noise of the matrix exponential (e.g. the x-y cross terms of the
    # decoupled loop): sparser rows, fewer operations in the generated solver
    for M in (Phi, Gamma):
        M[np.abs(M) < 1e-12 * np.abs(M).max()] = 0.0
    return Condensed(A, B, Phi, Gamma, T, block_of, blocks, float(dt))
