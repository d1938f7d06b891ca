"""``ballbot study chirp``: the bandwidth test of thesis §9.1 (Fig. 9.1-9.2).

The roll (or pitch, ``--axis pitch``) reference is a chirp of ``--amplitude`` deg
(default 3) from 0.05 Hz rising 0.05 Hz/s to 5 Hz; the balance controller follows it
alone, once with the exact feed-forward and once in the thesis's mode (reference
acceleration taken as zero, thesis (8.44)).  The measured response
(:func:`~ballbot_casadi.analysis.bandwidth.chirp_metrics`) is compared with the linear
closed loop of ``ballbot analyze`` (:func:`~ballbot_casadi.analysis.closed_loop.analyze_closed_loop`,
inner loop: quaternion reference only) and with the ideal linear responses of both
feed-forward modes (thesis (8.45): exact feed-forward gives ``T = 1``; without the
reference acceleration ``T = (Kd s + Kp) / (s^2 + Kd s + Kp)``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)
import numpy as np

from ballbot_casadi.analysis import closed_loop as cla
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.analysis.bandwidth import CROSS_AXIS_DEG, FALL_TILT_DEG, chirp_metrics
from ballbot_casadi.analysis.metrics import rpy_deg, run_metrics
from ballbot_casadi.control import default_balance_gains
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.params import Params
from ballbot_casadi.sim.log import SimulationLog

__all__ = ["linear_response", "chirp_study_metrics", "plot_chirp_study", "plot_chirp", "chirp_report_lines",
           "THESIS_BANDWIDTH_HZ", "axis_overrides"]

#: The thesis's chirp bandwidth (§9.1: tracking lost at ~23-25 s of the sweep).
THESIS_BANDWIDTH_HZ = 1.25


def axis_overrides(table: dict[str, Any], axis: str | None, amplitude_deg: float | None) -> list[tuple[str, Any]]:
    """``--set``-style overrides for ``--axis`` and ``--amplitude``: the chirp table of
    ``table`` moved to ``axis`` (roll or pitch) with the given amplitude."""
    att = dict(table.get("attitude") or {})
    src = next((ax for ax, sig in att.items() if isinstance(sig, dict) and sig.get("type") == "chirp"), None)
    if src is None:
        return []
    sig = dict(att[src])
    if amplitude_deg is not None:
        sig["amplitude_deg"] = float(amplitude_deg)
    dst = axis or src
    att.pop(src)
    att[dst] = sig
    return [("attitude", att)]


def linear_response(params: Params, controller: str = "flc", axis: str = "roll") -> dict[str, Any]:
    """Linear closed-loop responses to overlay on the measured one.

    Returns ``analyze`` (the sampled cascade's inner loop of ``ballbot analyze``: omega,
    mag, phase_deg, and ``bandwidth_hz``) and ``none``: the continuous FLC in the
    thesis's mode, ``(Kd s + Kp) / (s^2 + Kd s + Kp)`` with the axis's gains, with its
    -3 dB frequency.  (The exact feed-forward gives ``T = 1`` at every frequency.)
    """
    lin, _ = an.analyze_plant(params)
    res = cla.analyze_closed_loop(params, lin)
    inner = (res.get("closed_loop") or {}).get("frequency_response", {}).get("inner")
    k = np.asarray(default_balance_gains("flc"), float)
    i = {"roll": 0, "pitch": 1, "yaw": 2}[axis]
    kp, kd = k[i], k[3 + i]
    w = np.logspace(-2, math.log10(2 * math.pi * 10), 800)
    s = 1j * w
    T = (kd * s + kp) / (s**2 + kd * s + kp)
    mag = np.abs(T)
    # -3 dB in closed form: |T|^2 = 1/2  <=>  x^2 - (2 Kp + Kd^2) x - Kp^2 = 0, x = omega^2
    b = 2 * kp + kd**2
    bw_none = math.sqrt((b + math.sqrt(b**2 + 4 * kp**2)) / 2) / (2 * math.pi) if kp > 0 else None
    return {
        "analyze": None if inner is None else {**inner, "bandwidth_hz": res.get("bandwidth_inner_hz")},
        "linear_bandwidth_hz": res.get("bandwidth_inner_hz"),
        "none": {"omega": w.tolist(), "mag": mag.tolist(),
                 "phase_deg": np.degrees(np.unwrap(np.angle(T))).tolist(), "bandwidth_hz": bw_none},
        "gains": {"Kp": float(kp), "Kd": float(kd)},
    }


def chirp_study_metrics(logs: Sequence[SimulationLog]) -> dict[str, Any]:
    """The chirp study's metrics: :func:`~ballbot_casadi.analysis.bandwidth.chirp_metrics`
    and the §7.1 peaks of each feed-forward mode (``by_feedforward``), the main run's at
    the top level, and the linear model's bandwidths (:func:`linear_response`)."""
    by, per_wheel, per_wheel_end = {}, None, None
    main_limit = logs[-1].scenario.get("torque_limit", "direction")
    for log in logs:
        m = chirp_metrics(log)
        m.update({k: v for k, v in run_metrics(log).items()
                  if k in ("peak_tilt_deg", "peak_tilt_rate_deg_s", "peak_torque_nm")})
        if log.scenario.get("torque_limit", "direction") == main_limit:
            by[log.scenario["feedforward"]] = m
        else:
            per_wheel, per_wheel_end = m, log.scenario["duration"]
    main = by[logs[-1].scenario["feedforward"]]
    out = {k: v for k, v in main.items() if k != "response"}
    out["by_feedforward"] = by
    if per_wheel is not None:  # the thesis's set-up: each motor clips on its own (§9.1)
        for k in ("first_saturation_s", "first_saturation_motor", "cross_axis_onset_s",
                  "cross_axis_onset_hz", "cross_axis_error_max_deg", "fell_at_s", "bandwidth_hz"):
            out[f"per_wheel_{k}"] = per_wheel[k]
        onset, fell = per_wheel["cross_axis_onset_s"], per_wheel["fell_at_s"]
        out["per_wheel_cross_axis_lead_s"] = (None if onset is None else
                                              (fell if fell is not None else per_wheel_end) - onset)
    linear = linear_response(logs[-1].params, logs[-1].scenario["controller"], out["chirp_axis"])
    out["linear_bandwidth_hz"] = linear["linear_bandwidth_hz"]
    out["linear_bandwidth_none_hz"] = linear["none"]["bandwidth_hz"]
    return out


def plot_chirp_study(logs: Sequence[SimulationLog], metrics: dict[str, Any], out: Path) -> list[Path]:
    """The chirp study's plots: :func:`plot_chirp` over the linear responses."""
    linear = linear_response(logs[-1].params, logs[-1].scenario["controller"], metrics["chirp_axis"])
    return plot_chirp(logs, metrics, linear, out)


def plot_chirp(logs: Sequence[SimulationLog], metrics: dict[str, Any], linear: dict[str, Any],
               out: Path) -> list[Path]:
    """``chirp_time.png`` (angles and torques vs time, thesis Fig. 9.1-9.2) and
    ``chirp_bode.png`` (measured gain/phase of both modes over the linear responses)."""
    by = metrics["by_feedforward"]
    axis = metrics.get("chirp_axis", "roll")
    i_ax = ("roll", "pitch", "yaw").index(axis)
    fig, axes = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for log in logs:
        a = log.arrays
        n = a["q_ref"].shape[0]
        t = a["time"][:n]
        ff = log.scenario["feedforward"]
        if log.scenario.get("torque_limit", "direction") != logs[-1].scenario.get("torque_limit", "direction"):
            ff = f"{ff}, {log.scenario['torque_limit']} limit"
        with np.errstate(invalid="ignore"):
            ang = rpy_deg(np.nan_to_num(a["state"][:n, STATE["q"]]))
        ref = rpy_deg(a["q_ref"])
        axes[0].plot(t, np.clip(ang[:, i_ax], -20, 20), lw=0.6, label=f"{axis} ({ff} feed-forward)")
        other = 1 - i_ax if i_ax < 2 else 0
        axes[1].plot(t, np.clip(ang[:, other], -20, 20), lw=0.6, label=f"{('roll', 'pitch')[other]} ({ff})")
        if ff == logs[-1].scenario["feedforward"]:
            axes[0].plot(t, ref[:, i_ax], "k--", lw=0.5, label="reference")
            for m in range(3):
                axes[2].plot(t, a["tau_cmd"][:, m], lw=0.5, label=f"tau_cmd {m} ({ff})")
            axes[2].axhline(log.params.tau_max, color="r", lw=0.8)
            axes[2].axhline(-log.params.tau_max, color="r", lw=0.8, label="tau_max")
    for ff, m in by.items():
        for ax in axes:
            if m.get("first_saturation_s") is not None:
                ax.axvline(m["first_saturation_s"], ls=":", color="C3" if ff == "none" else "C2", lw=0.8)
    axes[0].set_ylabel(f"{axis} (deg)")
    axes[1].set_ylabel("other tilt (deg)")
    axes[2].set_ylabel("commanded torque (N m)")
    axes[2].set_ylim(-3 * logs[-1].params.tau_max, 3 * logs[-1].params.tau_max)
    axes[2].set_xlabel("time (s)  (chirp frequency = 0.05 + 0.05 t Hz; dotted: first saturation)")
    for ax in axes:
        ax.legend(loc="upper left", fontsize=6)
    fig.suptitle(f"chirp test (thesis §9.1): {axis} reference, angles clipped to ±20 deg "
                 f"(fall: tilt > {FALL_TILT_DEG:g} deg)")
    fig.tight_layout()
    p_time = out / "chirp_time.png"
    fig.savefig(p_time, dpi=80)
    plt.close(fig)

    fig, (ax_g, ax_p) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for ff, m in by.items():
        r = m["response"]
        ax_g.semilogx(r["f_hz"], r["gain_db"], lw=1.2, label=f"measured, {ff} feed-forward")
        ax_p.semilogx(r["f_hz"], r["phase_deg"], lw=1.2, label=f"measured, {ff}")
        if m.get("bandwidth_hz"):
            ax_g.axvline(m["bandwidth_hz"], ls="--", lw=0.8, color=ax_g.lines[-1].get_color())
    if linear.get("analyze"):
        la = linear["analyze"]
        f = np.asarray(la["omega"]) / (2 * math.pi)
        ax_g.semilogx(f, 20 * np.log10(la["mag"]), "k:", label="linear, ballbot analyze (q_ref only)")
        ax_p.semilogx(f, la["phase_deg"], "k:", label="linear, analyze")
    ln = linear["none"]
    f = np.asarray(ln["omega"]) / (2 * math.pi)
    ax_g.semilogx(f, 20 * np.log10(ln["mag"]), "C1:", label="linear FLC, no feed-forward (8.45)")
    ax_p.semilogx(f, ln["phase_deg"], "C1:", label="linear, no feed-forward")
    ax_g.axhline(0, color="C0", ls=":", lw=0.8, label="linear FLC, exact feed-forward (T = 1)")
    ax_g.axhline(-3, color="gray", lw=0.6)
    ax_p.axhline(-90, color="gray", lw=0.6)
    ax_g.axvline(THESIS_BANDWIDTH_HZ, color="m", lw=0.8, label="thesis ≈1.25 Hz")
    ax_g.set_ylim(-20, 6)
    ax_p.set_ylim(-200, 30)
    ax_g.set_xlim(0.05, 5)
    ax_g.set_ylabel("gain (dB)")
    ax_p.set_ylabel("phase (deg)")
    ax_p.set_xlabel("frequency (Hz)")
    ax_g.legend(fontsize=6, loc="lower left")
    ax_p.legend(fontsize=6, loc="lower left")
    fig.suptitle("chirp: measured (sliding sine fit) vs linear closed loop")
    fig.tight_layout()
    p_bode = out / "chirp_bode.png"
    fig.savefig(p_bode, dpi=80)
    plt.close(fig)
    return [p_time, p_bode]


def _f(v: Any, unit: str = "", fmt: str = ".3g") -> str:
    return "none" if v is None else f"{v:{fmt}}{unit}"


def chirp_report_lines(metrics: dict[str, Any]) -> list[str]:
    """The report's chirp section: both modes, linear bandwidth and the thesis comparison."""
    by = metrics["by_feedforward"]
    lines = ["## Chirp results", "",
             f"Bandwidth criterion: {metrics['bandwidth_criterion']}. Justification: −3 dB is the "
             "half-power definition of bandwidth; a lag beyond 90° means the output moves against "
             "the reference (the error then exceeds the reference for a near-unity gain). The fit "
             "uses the chirp's own phase in a window of 3 local periods, so it measures the loop "
             "as the thesis's time plot shows it.", "",
             "| feed-forward | bandwidth (Hz) | criterion hit | first saturation (s / Hz, motor) | "
             "saturation per motor (Hz) | fell at (s / Hz) | peak torque cmd (N m) |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for ff, m in by.items():
        sat = "never" if m["first_saturation_s"] is None else (
            f"{m['first_saturation_s']:.2f} s / {m['first_saturation_hz']:.3f} Hz, motor {m['first_saturation_motor']}")
        fell = "no" if m["fell_at_s"] is None else f"{m['fell_at_s']:.2f} s / {m['fell_at_hz']:.2f} Hz"
        per = ", ".join(_f(v) for v in m["saturation_hz_per_motor"])
        lines.append(f"| {ff} | {_f(m['bandwidth_hz'])} | {m['bandwidth_reason']} | {sat} | {per} | {fell} | "
                     f"{_f(m.get('peak_torque_nm'))} |")
    lin = metrics.get("linear_bandwidth_hz")
    none = by.get("none", {})
    exact = by.get("exact", {})
    lines += ["", f"- Linear closed loop (`ballbot analyze`, inner loop, quaternion reference only): "
                  f"−3 dB at {_f(lin)} Hz; linear FLC without feed-forward (thesis (8.45) with "
                  f"dq_ref): −3 dB at {_f(metrics.get('linear_bandwidth_none_hz'))} Hz; with the exact "
                  "feed-forward the linear loop tracks at every frequency (T = 1).",
              f"- Thesis: ≈{THESIS_BANDWIDTH_HZ} Hz, read where the roll tracking visibly degrades "
              "(23–25 s of the sweep) and where motor 0 saturates (Fig. 9.2).",
              "", "**Why the numbers differ.** "
              f"Our motors first saturate at {_f(exact.get('first_saturation_hz'))} Hz (exact feed-forward) "
              f"and {_f(none.get('first_saturation_hz'))} Hz (thesis mode), motor 0 first, exactly where "
              "the thesis sees tracking lost and motor 0 saturating: the thesis's 1.25 Hz is the onset of "
              "torque saturation. A 3° sine needs a torque growing with f² (the body's inertia "
              "times the angular acceleration A(2πf)²), so the saturation frequency scales as "
              "1/√amplitude. Past it the loop no longer follows exactly but still passes most of the "
              f"signal: the −3 dB / 90° criterion is reached only at {_f(exact.get('bandwidth_hz'))} Hz "
              f"(exact) and {_f(none.get('bandwidth_hz'))} Hz (thesis mode), i.e. the bandwidth by the "
              "classical definition is higher than the thesis's visual reading, and it is set by the "
              "saturation, not by the linear loop (the linear FLC with exact feed-forward has none). "
              "The linear `analyze` number is the response to a quaternion step without any "
              "reference derivative; it is lower because it omits the dq_ref the chirp provides.", ""]
    if "per_wheel_first_saturation_s" in metrics:
        lines += ["## Torque limit: ours (direction-preserving) beside the thesis's (per-wheel)", "",
                  "| torque limit (thesis mode) | first saturation (s, motor) | other axis > "
                  f"{CROSS_AXIS_DEG:g}° from (s / Hz) | other axis max error before the fall (°) | fell at (s) |",
                  "| --- | --- | --- | --- | --- |",
                  f"| direction (ours) | {_f(none.get('first_saturation_s'), fmt='.2f')}, motor "
                  f"{none.get('first_saturation_motor')} | {_f(none.get('cross_axis_onset_s'), fmt='.2f')} / "
                  f"{_f(none.get('cross_axis_onset_hz'))} | {_f(none.get('cross_axis_error_max_deg'))} | "
                  f"{_f(none.get('fell_at_s'), fmt='.2f')} |",
                  f"| per-wheel (thesis §9.1) | {_f(metrics['per_wheel_first_saturation_s'], fmt='.2f')}, motor "
                  f"{metrics['per_wheel_first_saturation_motor']} | "
                  f"{_f(metrics['per_wheel_cross_axis_onset_s'], fmt='.2f')} / "
                  f"{_f(metrics['per_wheel_cross_axis_onset_hz'])} | "
                  f"{_f(metrics['per_wheel_cross_axis_error_max_deg'])} | "
                  f"{_f(metrics['per_wheel_fell_at_s'], fmt='.2f')} |", "",
                  "The thesis sees the pitch degrade at ≈ 23 s, when motor 0 saturates. With per-wheel "
                  "clipping the saturated motor 0 alone loses torque, the torque vector turns and the "
                  "FLC's decoupling no longer holds: the roll chirp leaks into pitch from the first "
                  "saturation on, as in the thesis's Fig. 9.1. Our direction-preserving limit scales all "
                  "three torques together, so the torque direction (and the decoupling) survives and the "
                  "pitch stays untouched until the fall. Switch: `torque_limit = \"per-wheel\"` in a "
                  "scenario file or `ballbot study chirp --torque-limit per-wheel`.", ""]
    return lines
