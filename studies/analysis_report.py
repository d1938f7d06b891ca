"""Markdown report and plots of ``ballbot analyze`` (computation in :mod:`ballbot_casadi.analysis`).

The report explains the numbers for a reader of the thesis: the reduction of the
constraint, controllability, the right-half-plane zeros of the position channel (thesis
§2.5, §7.1) and, once the controllers exist, the loop bandwidths and the 3x cascade rule
(thesis §7.1, §9.1).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from ballbot_casadi.core.layout import STATE_DXY
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.model import linearization as lz

__all__ = ["write_plots", "write_markdown", "OMEGA"]

#: Frequency grid of the plant plots (rad/s).
OMEGA = np.logspace(-2, 2, 400)

_CHANNEL_STYLE = {
    "position": ("tab:red", "o"),
    "tilt": ("tab:blue", "s"),
    "heading": ("tab:green", "D"),
    "pose": ("tab:purple", "^"),
}


def _plt():
    matplotlib.use("Agg")

    return plt


def write_plots(lin: lz.LinearModel, result: dict[str, Any], out: Path) -> list[Path]:
    """Write ``pole_zero.png``, ``singular_values.png`` and, if present, ``closed_loop.png``."""
    plt = _plt()
    files = []

    fig, ax = plt.subplots(figsize=(7, 5))
    ef = np.array([complex(*z) for z in result["eigenvalues_full"]])
    er = np.array([complex(*z) for z in result["eigenvalues_reduced"]])
    cons = np.array([complex(*z) for z in result["constraint_eigenvalues"]])
    ax.axvspan(0, max(5.0, 1.2 * float(np.max(np.abs(ef)))), color="0.93", zorder=0)
    ax.plot(er.real, er.imag, "kx", ms=10, mew=2, label="poles (reduced 10-state model)")
    ax.plot(cons.real, cons.imag, "x", color="0.6", ms=10, mew=2, label="constraint poles (12-state only)")
    for name, ch in result["channels"].items():
        z = np.array([complex(*v) for v in ch["zeros"]])
        if z.size:
            c, m = _CHANNEL_STYLE[name]
            ax.plot(z.real, z.imag, m, mfc="none", color=c, ms=10, mew=2, label=f"zeros: torques -> {name}")
    ax.axhline(0, color="0.5", lw=0.5)
    ax.axvline(0, color="0.5", lw=0.5)
    ax.set_xlabel("Re s (rad/s)")
    ax.set_ylabel("Im s (rad/s)")
    ax.set_title("Pole-zero map at the operating point (shaded: right half-plane)")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_ylim(-2, 2)
    fig.tight_layout()
    files.append(out / "pole_zero.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(3, 1, figsize=(7, 9), sharex=True)
    units = {"position": "m/(N m)", "tilt": "1/(N m)", "heading": "1/(N m)"}
    for ax, name in zip(axes, ("position", "tilt", "heading")):
        sv = an.singular_values(lin, OMEGA, name)
        c, _ = _CHANNEL_STYLE[name]
        for k in range(sv.shape[1]):
            ax.semilogx(OMEGA, 20 * np.log10(sv[:, k]), color=c, ls="-" if k == 0 else "--",
                        label=f"sigma_{k + 1}")
        for p in result["unstable_poles"]:
            ax.axvline(p, color="k", ls=":", lw=1)
        for z in result["rhp_zeros_position" if name == "position" else f"rhp_zeros_{name}"]:
            ax.axvline(z, color="tab:red", ls="-.", lw=1)
        ax.set_ylabel(f"dB re 1 {units[name]}")
        ax.set_title(f"wheel torques -> {name} ({', '.join(an.CHANNELS[name][1])})", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1].set_xlabel("omega (rad/s)   [dotted: unstable poles, dash-dot: RHP zeros]")
    fig.tight_layout()
    files.append(out / "singular_values.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    cl = result.get("closed_loop")
    if cl and cl.get("frequency_response"):
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for key, label in (("inner", "inner loop: q_ref -> tilt"), ("outer", "outer loop: v_ref -> ball velocity")):
            fr = cl["frequency_response"].get(key)
            if fr:
                w = np.array(fr["omega"])
                ax.semilogx(w / (2 * np.pi), 20 * np.log10(np.array(fr["mag"])), label=label)
        for key, color in (("bandwidth_sensitivity_inner_hz", "tab:blue"),
                           ("bandwidth_sensitivity_outer_hz", "tab:orange")):
            if result.get(key):
                ax.axvline(result[key], color=color, ls="--", lw=1)
        ax.axhline(-3.01, color="0.5", lw=0.5)
        ax.set_ylim(-60, 10)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("|T| (dB)")
        ax.set_title("Closed-loop |T| (dashed: tracking bandwidths, |1 - T| = -3 dB)", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        files.append(out / "closed_loop.png")
        fig.savefig(files[-1], dpi=120)
        plt.close(fig)
    return files


def _fmt_c(z: list[float]) -> str:
    re, im = z
    return f"{re:+.4f}" if abs(im) < 1e-9 else f"{re:+.4f} {im:+.4f}j"


def _fmt_list(zs: list[list[float]]) -> str:
    return ", ".join(_fmt_c(z) for z in zs) if zs else "none"


def _sensitivity_bound(p: float, z: float) -> float:
    """Lower bound on the peak of |S| and |T| for a real RHP pole p and zero z (SISO)."""
    return abs(z + p) / abs(z - p)


def write_markdown(result: dict[str, Any], out: Path, params_source: str, plots: list[Path]) -> Path:
    """Write ``analysis.md``: the report of ``ballbot analyze``."""
    op = result["operating_point"]
    ctrb = result["controllability"]
    pr = result["planar_reduction"]
    L: list[str] = []
    add = L.append
    add("# Ballbot linear analysis\n")
    add(f"Parameters: {params_source}. Generated by `ballbot analyze`; numbers in "
        "`analysis.json`.\n")

    add("## Operating point\n")
    rpy = ", ".join(f"{v:.4g}" for v in op["rpy_deg"])
    add(f"- roll, pitch, yaw = {rpy} deg; ball position ({op['state'][0]:.4g}, "
        f"{op['state'][1]:.4g}) m, velocity ({op['state'][6]:.4g}, {op['state'][7]:.4g}) m/s")
    add(f"- trim torques tau0 = [{', '.join(f'{t:.4g}' for t in op['tau'])}] N m "
        f"(acceleration residual {op['trim_residual']:.2e})\n")

    add("## Linearisation and the minimal model\n")
    add("The exact Jacobians `A = df/dx`, `B = df/dtau` of the generated model (12 states "
        "`x, y, q0..q3` and rates) are taken at the operating point. The quaternion carries "
        "the unit-norm constraint with Baumgarte stabilisation (thesis C.64-C.68), so the "
        "12-state model has two *constraint modes* at `-beta` besides the physical ones. The "
        "physical motion lives on the constraint's tangent space, parametrised by the ball-frame "
        "attitude perturbation `q = [1, v] o q0` (`delta q = Gamma(q0)[:,1:] v`, thesis E.12). "
        "With the orthonormal basis `T = blkdiag(I2, Gamma(q0)[:,1:], I2, Gamma(q0)[:,1:])` the "
        "reduced model is `A_r = T^T A T`, `B_r = T^T B` on the 10 states "
        f"`{', '.join(result['reduced_state_names'])}` (`v = (q1, q2, q3)` at zero heading; "
        "`2v` is the small rotation vector). `A` leaves the tangent space invariant: "
        f"`|A T - T A_r| / |A| = {result['reduction_invariance_error']:.1e}`.\n")
    add("| | eigenvalues (rad/s) |")
    add("|---|---|")
    add(f"| 12-state | {_fmt_list(result['eigenvalues_full'])} |")
    add(f"| reduced 10-state | {_fmt_list(result['eigenvalues_reduced'])} |")
    add(f"| constraint modes (difference) | {_fmt_list(result['constraint_eigenvalues'])} |\n")
    er = np.array([complex(*z) for z in result["eigenvalues_reduced"]])
    n_zero = int(np.sum(np.abs(er) < 1e-6))
    poles = ", ".join(f"{p:.4f}" for p in result["unstable_poles"])
    add(f"Unstable poles: {poles + ' rad/s' if poles else 'none'} "
        "(one real unstable pole per tilt axis: the inverted pendulum; without friction each "
        f"has a stable mirror image -p). {n_zero} eigenvalues at zero: "
        + ("the double integrators of the ball position x, y and of the heading."
           if n_zero == 6 else
           "the ball position and heading (friction turns their rates into stable modes)."
           if n_zero == 3 else "rigid-body modes.") + "\n")

    add("## Controllability\n")
    add("Computed on the reduced model in scaled units (thesis §7.1 envelope: 1 m, 0.5 m/s, "
        "5 deg tilt, 20 deg/s tilt rate, 1 rad heading, 1 rad/s heading rate; torques in units "
        "of `tau_max`).\n")
    sv = ctrb["singular_values"]
    add(f"- Kalman matrix `[B, AB, ..., A^9 B]` (time-scaled by `|A|`): rank "
        f"**{result['controllability_rank']} of {result['n_states_reduced']}** (singular values "
        f"{sv[0]:.3g} ... {sv[-1]:.3g}, threshold {ctrb['rtol']:.0e} x largest).")
    add("- PBH test `rank [A - lambda I, B]` per distinct eigenvalue (normalised smallest "
        "singular value; 0 means uncontrollable):\n")
    add("| eigenvalue | sigma_min | controllable |")
    add("|---|---|---|")
    for e in ctrb["pbh"]:
        add(f"| {_fmt_c(e['eigenvalue'])} | {e['sigma_min']:.3e} | {'yes' if e['controllable'] else 'NO'} |")
    add("")
    add(f"- Gramian measure: the finite-horizon Gramian `W(T)`, T = {ctrb['gramian_horizon_s']:g} s, "
        "exists for the unstable plant, so no stabilising loop is needed. Restricted to the left "
        "invariant subspace `U` of each mode group (the decoupled modal subsystem `z = U^T x`), "
        "`1 / lambda_min(U^T W U)` is the least input energy (`tau_max^2 s`) that moves the "
        "group one scale unit in its weakest direction within T. Larger = weaker.\n")
    add("| mode group | dominant states | weakest direction | energy (tau_max^2 s) |")
    add("|---|---|---|---|")
    for m in ctrb["modes"]:
        ev = sorted({_fmt_c(z) for z in m["eigenvalues"]})
        mult = f" (x{len(m['eigenvalues'])})" if len(m["eigenvalues"]) > 1 else ""
        add(f"| {', '.join(ev)}{mult} | {', '.join(m['dominant_states'])} | "
            f"{', '.join(m['weakest_direction'])} | {m['energy']:.3g} |")
    w = ctrb["weakest_mode"]
    add(f"\nWeakest: the modes at {', '.join(sorted({_fmt_c(z) for z in w['eigenvalues']}))} "
        f"(direction {', '.join(w['weakest_direction'])}). The unstable tilt modes need almost "
        "no energy (they grow by themselves)"
        + ("; moving the ball is the expensive part because the torques act on the position "
           "only through the tilt (shape acceleration, thesis §2.5)."
           if set(w["weakest_direction"]) <= {"x", "y", "dx", "dy"} else ".") + "\n")

    add("## Poles and transmission zeros\n")
    add("Channels from the three wheel torques (minimal realisation by SLICOT TB01PD, "
        "invariant zeros by AB08ND via python-control):\n")
    add("| channel | outputs | minimal order | poles | zeros | RHP zeros |")
    add("|---|---|---|---|---|---|")
    for name, ch in result["channels"].items():
        add(f"| {name} | {', '.join(ch['outputs'])} | {ch['minimal_order']} | "
            f"{_fmt_list(ch['poles'])} | {_fmt_list(ch['zeros'])} | {_fmt_list(ch['rhp_zeros'])} |")
    add("")
    add("`pose` is the square channel torques -> (x, y, heading). At upright rest the summed "
        "(yaw) torque does not reach x, y, so the 2x3 `position` channel is effectively square "
        "and has the same zeros; away from that symmetric point (tilted by a COM offset, "
        "rolling) the yaw torque couples in weakly and the non-square 2x3 channel generically "
        "loses its transmission zeros (a third input can steer around the zero direction), "
        "while the square `pose` channel keeps them. `rhp_zeros_position` in the JSON is taken "
        "from `pose`.\n")
    zpos = result["rhp_zeros_position"]
    if zpos:
        add("**The position channel is non-minimum phase.** Its right-half-plane zeros mean "
            "that a torque that eventually moves the ball forwards first rolls it backwards: "
            "to accelerate, the body must tilt into the motion, and the only way to tilt it is "
            "to drive the ball the other way under it (inverse response, thesis §2.5, §7.1; "
            "actuators below the centre of mass of a shape-accelerated robot). The tilt channel "
            "has no finite zeros, which is why the thesis balances on the tilt in the inner "
            "loop and closes the velocity loop around it.\n")
        add("Hand check (planar ball + inverted pendulum per axis with the same energies, "
            "thesis C.14, C.18, C.21, C.24; see `analysis.planar_reduction`): "
            "`z = sqrt(Mb g l / (Jb + Mb l (l + rk)))`, "
            "`p = sqrt((a+J) Mb g l / ((a+J)(c+J) - (b-J)^2))`.\n")
        P = result.get("parameters", {})
        exact = (all(P.get(k, 0.0) == 0.0 for k in ("com_x", "com_y", "Bvk", "Bvm", "Bvb"))
                 and np.allclose(op["state"][STATE_DXY], 0.0))
        if not exact:
            add("(The planar reduction is exact only at rest with a centred COM and no friction; "
                "at this operating point it is an approximation.)\n")
        add("| axis | unstable pole (hand) | RHP zero (hand) |")
        add("|---|---|---|")
        for axis in ("pitch", "roll"):
            add(f"| {axis} | {pr['pole_' + axis]:.6f} | {pr['zero_' + axis]:.6f} |")
        add(f"\nModel: unstable poles {', '.join(f'{p:.6f}' for p in result['unstable_poles'])}, "
            f"RHP zeros {', '.join(f'{z:.6f}' for z in zpos)} rad/s.\n")
        if result["unstable_poles"]:
            p, z = max(result["unstable_poles"]), min(zpos)
            add(f"Limitation: with a real RHP pole p = {p:.3f} and zero z = {z:.3f} rad/s on the "
                f"same axis, any loop closed from the position alone has peak |S| and |T| of at "
                f"least |z+p|/|z-p| = {_sensitivity_bound(p, z):.1f}"
                + (" (z < p: practically uncontrollable from position alone)" if z < p else "")
                + "; the cascade avoids this by stabilising with the tilt, whose channel has no "
                "RHP zero, and the RHP zero then bounds the achievable outer-loop (velocity) "
                f"bandwidth to roughly z/2 = {z / 2:.2f} rad/s = {z / 4 / np.pi:.2f} Hz.\n")
    else:
        add("No right-half-plane zeros at this operating point.\n")

    add("## Closed loop (cascade, thesis §7.1, §9.1)\n")
    cl = result.get("closed_loop")
    if not cl or cl.get("status") != "ok":
        msg = (cl or {}).get("message", "the controllers are not available")
        add(f"Not computed: {msg}. The report covers the plant only; `bandwidth_inner_hz` and "
            "`bandwidth_outer_hz` are null.\n")
    else:
        add(cl["description"] + "\n")
        add("| loop | -3 dB of \\|T\\| | tracking bandwidth (\\|1-T\\| = -3 dB) | peak \\|T\\| | "
            "slowest pole (rad/s) | neutral modes |")
        add("|---|---|---|---|---|---|")
        for key, label in (("inner", "inner: FLC, tilt ref -> tilt"),
                           ("outer", "outer: velocity ctrl, v_ref -> ball velocity")):
            d = cl[key]
            add(f"| {label} | {_hz(result['bandwidth_' + key + '_hz'])} | "
                f"{_hz(result['bandwidth_sensitivity_' + key + '_hz'])} | "
                f"{max(d['peak_gain_db']):+.2f} dB | {d['max_real_pole']:.3f} | {d['n_neutral_modes']} |")
        add("")
        rs, r3 = result.get("bandwidth_sensitivity_ratio"), result.get("bandwidth_ratio")
        add(f"**3x rule (thesis §7.1: inner loop at least three times faster than the outer): "
            f"{_verdict(result.get('cascade_rule_ok'))}** on the tracking bandwidths "
            f"(ratio {_num(rs)}); on the -3 dB points of |T| the ratio is {_num(r3)} "
            f"({_verdict(result.get('cascade_rule_ok_3db'))}).\n")
        add("Why two numbers: the outer loop's |T| stays near 0 dB up to a few Hz only because "
            "the velocity reference reaches the torques directly (reference tilt acceleration -> "
            "FLC feedforward) and the ball then moves *out of phase* with the reference (phase "
            "beyond -180 deg there: the RHP zero's inverse response). The -3 dB point of |T| "
            "therefore overstates what the loop can track; the frequency where the tracking "
            "error |1 - T| reaches -3 dB (Skogestad & Postlethwaite's omega_B) does not, and is "
            "the one compared with the 3x rule. For the inner loop both are meaningful.\n")
        stable = cl["inner"]["stable_apart_from_neutral"] and cl["outer"]["stable_apart_from_neutral"]
        add(f"Stability: {'all modes stable' if stable else 'UNSTABLE modes present'} apart from "
            "the neutral ones (|z| = 1: the ball position, which neither loop feeds back - the "
            "outer loop integrates the velocity error - the ball velocity in the inner loop "
            "alone, and the heading integrator).\n")
        add("For comparison, the thesis' chirp test found the attitude loop bandwidth about "
            "1.25 Hz, limited by torque saturation (thesis §9.1); a linear analysis has no "
            "saturation and gives the small-signal bandwidth.\n")

    if plots:
        add("## Plots\n")
        for f in plots:
            add(f"![{f.stem}]({f.name})\n")
    path = out / "analysis.md"
    path.write_text("\n".join(L) + "\n", encoding="utf-8")
    return path


def _verdict(ok: bool | None) -> str:
    return "n/a" if ok is None else ("satisfied" if ok else "NOT satisfied")


def _num(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.2f}"


def _hz(v: float | None) -> str:
    return "n/a (not reached on the grid)" if v is None else f"{v:.3f} Hz ({2 * np.pi * v:.2f} rad/s)"
