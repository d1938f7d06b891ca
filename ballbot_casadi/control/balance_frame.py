"""Common frame of the balance controllers: their one signature, built in one place.

Every balance controller (:data:`~ballbot_casadi.control.BALANCE_CONTROLLERS`) is::
    ballbot_<name>(x[12], q_ref[4], dq_ref[4], ddq_ref[4], p[NP], k[NK]) -> (tau[3], diag[12])

and one with a *balance-controller state* ``zb`` (size ``nz``) takes it as the 7th input
and returns its next value as the 3rd output::
    ballbot_<name>(x, q_ref, dq_ref, ddq_ref, p, k, zb[nz]) -> (tau, diag, zb_next[nz])

:func:`balance_controller` creates these symbols, evaluates the model's ``affine``
Function and the exact error-output dynamics ``ddy = D + E tau`` (thesis 8.12-8.25, the
body-frame error of 7.4/7.5, :func:`~ballbot_casadi.control.decoupling.error_output_dynamics`)
and hands them to the controller's law as a :class:`BalanceFrame`.  Laws that prescribe
the error acceleration ``v`` get the torque from :meth:`BalanceFrame.linearising_torque`
(thesis 8.26).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

import casadi as ca

from ballbot_casadi.control.decoupling import (
    DampedInverse,
    check_affine,
    damped_solve,
    error_output_dynamics,
)

__all__ = [
    "DIAG_NAMES",
    "BALANCE_INPUTS",
    "BALANCE_OUTPUTS",
    "BalanceFrame",
    "balance_controller",
    "balance_diag",
]

#: ``diag`` entries of every balance controller.
DIAG_NAMES = (
    "singular",  # 1.0 when E(x) was near-singular and damped least squares was used
    "cond_margin",  # conditioning margin of E(x); < 1: damped inverse active
    "sigma",  # shortest-path sign applied to the error quaternion (+1 / -1)
    "e1", "e2", "e3",  # vec(q_e), body-frame error (half-angle units)
    "de1", "de2", "de3",  # its time derivative
    "v1", "v2", "v3",  # commanded error acceleration (linear control input)
)
#: Inputs of every balance controller, with their sizes (``p``, ``k``: per model/controller).
BALANCE_INPUTS = (("x", 12), ("q_ref", 4), ("dq_ref", 4), ("ddq_ref", 4), ("p", None),
                  ("k", None))
#: Outputs of every balance controller.
BALANCE_OUTPUTS = ("tau", "diag")
#: Name of the balance-controller state input and of its next value (stateful controllers).
_ZB, _ZB_NEXT = "zb", "zb_next"


@dataclass(frozen=True)
class BalanceFrame:
    """What a balance law works on: the inputs, the model terms and the error output.

    Attributes
    ----------
    x, p, k
        State (12), internal-model parameters (NP) and gains (NK) symbols.
    zb
        Balance-controller state symbol (``nz``), ``None`` for a stateless controller.
    f, g
        The model's affine form ``ddchi = f + g tau`` at ``(x, p)`` (thesis 8.12).
    o
        :func:`~ballbot_casadi.control.decoupling.error_output_dynamics`: ``y``, ``dy``,
        ``D``, ``E``, ``sigma``, ``qe0``, ``G``.
    inverse
        Thresholds and damping of the regularised inverse of :meth:`linearising_torque`.
    """

    x: ca.MX
    p: ca.MX
    k: ca.MX
    zb: Optional[ca.MX]
    f: ca.MX
    g: ca.MX
    o: dict[str, ca.MX]
    inverse: DampedInverse

    def linearising_torque(self, v: ca.MX) -> tuple[ca.MX, ca.MX]:
        """``tau = E^-1 (v - D)`` (thesis 8.26) with the regularised inverse, and ``diag``.

        ``v`` is the desired error acceleration
        (:func:`~ballbot_casadi.control.decoupling.damped_solve`).  Returns ``(tau, diag)``.
        """
        o = self.o
        tau, singular, margin = damped_solve(o["E"], v - o["D"], o["qe0"], o["G"], self.inverse)
        return tau, balance_diag(o, singular, margin, v)


def balance_diag(o: dict[str, ca.MX], singular: ca.MX, margin: ca.MX, v: ca.MX) -> ca.MX:
    """The ``diag`` output (:data:`DIAG_NAMES`) from the error output ``o`` and the law's terms."""
    return ca.vertcat(singular, margin, o["sigma"], o["y"], o["dy"], v)


def balance_controller(
    name: str,
    affine: ca.Function,
    n_gains: int,
    law: Callable[[BalanceFrame], tuple[ca.MX, ...]],
    nz: int = 0,
    inverse: DampedInverse = DampedInverse(),
) -> ca.Function:
    """Build ``ballbot_<name>`` with the balance controllers' signature (module docstring).

    Parameters
    ----------
    name
        Controller name; the Function is ``ballbot_<name>``.
    affine
        The model Function ``affine(x, p) -> (f, g)`` (``ddchi = f + g tau``); it stays a
        called Function inside the controller.
    n_gains
        Length of the gain vector ``k``.
    law
        ``law(frame) -> (tau, diag)``, or ``(tau, diag, zb_next)`` when ``nz > 0``.
    nz
        Size of the balance-controller state ``zb`` (0: stateless, no ``zb`` in or out).
    inverse
        Singularity thresholds and relative damping of the regularised inverse
        (:class:`~ballbot_casadi.control.decoupling.DampedInverse`).

    Returns
    -------
    casadi.Function
        ``ballbot_<name>(x[12], q_ref[4], dq_ref[4], ddq_ref[4], p[NP], k[n_gains]
        [, zb[nz]]) -> (tau[3], diag[12][, zb_next[nz]])``; ``diag`` as :data:`DIAG_NAMES`.

    Notes
    -----
    ``q_ref`` must be a unit quaternion and ``dq_ref``, ``ddq_ref`` its derivatives (e.g.
    from :func:`ballbot_casadi.sim.references.rpy_reference` or the velocity controller);
    they are used as given, not re-normalised.  The reference may use either sign of
    the double cover: the shortest-path sign is applied inside.
    """
    _, np_ = check_affine(affine)
    sizes = {"p": np_, "k": n_gains}
    ins = [ca.MX.sym(n, sizes[n] if m is None else m) for n, m in BALANCE_INPUTS]
    names_in, names_out = [n for n, _ in BALANCE_INPUTS], list(BALANCE_OUTPUTS)
    if nz:
        ins.append(ca.MX.sym(_ZB, nz))
        names_in.append(_ZB)
        names_out.append(_ZB_NEXT)
    x, q_ref, dq_ref, ddq_ref, p, k = ins[:6]
    f, g = affine(x, p)
    o = error_output_dynamics(x, q_ref, dq_ref, ddq_ref, f, g)
    outs = law(BalanceFrame(x, p, k, ins[6] if nz else None, f, g, o, inverse))
    return ca.Function(f"ballbot_{name}", ins, list(outs), names_in, names_out)
