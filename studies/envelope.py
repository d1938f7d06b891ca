"""The ``envelope`` study: the push-recovery envelope of every balance controller.

For each balance controller (FLC, SMC, super-twisting, balance LQR) the largest
disturbance it recovers from is found by bisection
(:func:`~ballbot_casadi.analysis.envelope.largest_recovered`), with the controllers on
the true state and with the QUKF + VUKF (noisy sensors, seed 0):

* an attitude push (thesis §8.4.3) about roll, pitch and the diagonal (deg);
* a wheel-torque disturbance step on wheel 0 held for 0.5 s (N m, added after the
  motor saturation).

Each run is the standing robot (velocity cascade on, zero velocity reference), the
disturbance at ``t = 0.5 s``, 4 s in all.  *Recovered* means the run stays finite and,
over its last 0.5 s, is back to the controller's own undisturbed behaviour: the tilt
within ``max(0.5 deg, 2x)`` and the tilt rate within ``max(2 deg/s, 2x)`` of what the
undisturbed run (same controller, estimator and noise) shows there, and the heading
within the §7.1 band of ±5 deg (with the UKFs the sensor noise alone keeps the tilt rate
at 2-12 deg/s, so fixed thresholds would call every run unrecovered).  The thesis's FLC +
disturbance-observer extension is not built (see the report).  Writes ``metrics.json``,
``report.md`` and ``envelope.png`` (polar plot of the push envelope).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)
import numpy as np  # noqa: E402

from ballbot_casadi.analysis.envelope import largest_recovered  # noqa: E402
from ballbot_casadi.core import quaternion as Q  # noqa: E402
from ballbot_casadi.core.layout import STATE  # noqa: E402
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario  # noqa: E402
from ballbot_casadi.sim.scenario import Scenario  # noqa: E402

__all__ = ["ENVELOPE_CONTROLLERS", "PUSH_DIRECTIONS", "final_motion", "recovered",
           "run_envelope_study",
           "envelope_report_lines"]

#: Balance controllers of the study.
ENVELOPE_CONTROLLERS = ("flc", "smc", "sta", "lqr")
#: Push directions (roll, pitch) as unit vectors, by name.
PUSH_DIRECTIONS = {"roll": (1.0, 0.0), "pitch": (0.0, 1.0),
                   "diagonal": (math.sqrt(0.5), math.sqrt(0.5))}
_T_DIST, _DURATION, _PULSE = 0.5, 4.0, 0.5
_FINAL_S, _TILT_OK, _RATE_OK, _YAW_OK = 0.5, 0.5, 2.0, 5.0


def final_motion(log: Any) -> tuple[float, float, float]:
    """Largest tilt (deg), tilt rate (deg/s) and |heading| (deg) over the run's last
    0.5 s (inf when the run is not finite)."""
    x = np.asarray(log["state"], float)
    if not np.all(np.isfinite(x)):
        return math.inf, math.inf, math.inf
    t = np.asarray(log["time"], float)
    late = t >= t[-1] - _FINAL_S
    q, dq = x[late][:, STATE["q"]], x[late][:, STATE["dq"]]
    w = np.degrees([2 * Q.vee(Q.mul(Q.conj(a), b)) for a, b in zip(q, dq)])
    tilt = np.degrees(np.arccos(np.clip(1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2), -1, 1)))
    yaw = np.degrees(Q.to_rpy(q)[:, 2])
    return float(tilt.max()), float(np.linalg.norm(w[:, :2], axis=1).max()), float(np.abs(yaw).max())


def recovered(log: Any, base: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> bool:
    """The recovery predicate of the study (module docstring) on a run's log; ``base`` is
    :func:`final_motion` of the undisturbed run."""
    tilt, rate, yaw = final_motion(log)
    return bool(tilt <= max(_TILT_OK, 2 * base[0]) and rate <= max(_RATE_OK, 2 * base[1])
                and yaw <= _YAW_OK)


def _scenario(controller: str, estimator: str, k_bal: Sequence[float], push_deg=(0.0, 0.0),
              torque: float = 0.0) -> Scenario:
    pushes = ((_T_DIST, push_deg[0], push_deg[1], 0.0),) if any(push_deg) else ()
    dist = ((_T_DIST, _T_DIST + _PULSE, torque, 0.0, 0.0),) if torque else ()
    return Scenario(name=f"envelope_{controller}", controller=controller, duration=_DURATION,
                    cascade=True, estimator=estimator, seed=0, k_bal=tuple(k_bal),
                    pushes=pushes, torque_disturbances=dist)


def run_envelope_study(out: Path, plot: bool = True, controllers: Sequence[str] = ENVELOPE_CONTROLLERS,
                       estimators: Sequence[str] = ("true", "ukf"), push_max: float = 30.0,
                       push_tol: float = 0.25, torque_max: float = 10.0,
                       torque_tol: float = 0.05, sim: ClosedLoop | None = None) -> dict[str, Any]:
    """Run the study into ``out``; returns the metrics (``table[estimator][controller]``)."""
    out.mkdir(parents=True, exist_ok=True)
    sim = ClosedLoop() if sim is None else sim
    table: dict[str, dict[str, dict[str, Any]]] = {}
    for est in estimators:
        table[est] = {}
        for c in controllers:
            k_bal = Scenario(name="k", controller=c, duration=0.01).inputs()["k_bal"]
            base = final_motion(run_scenario(_scenario(c, est, k_bal), sim))
            row: dict[str, Any] = {"undisturbed_final_tilt_deg": base[0],
                                   "undisturbed_final_tilt_rate_deg_s": base[1]}
            for d, (u, v) in PUSH_DIRECTIONS.items():
                def ok(a: float, u=u, v=v) -> bool:
                    return recovered(run_scenario(_scenario(c, est, k_bal, (a * u, a * v)), sim),
                                     base)
                r = largest_recovered(ok, 0.0, push_max, push_tol)
                row[f"push_{d}_deg"] = r.value
                row[f"push_{d}_bracketed"] = r.bracketed
            r = largest_recovered(lambda a: recovered(run_scenario(
                _scenario(c, est, k_bal, torque=a), sim), base), 0.0, torque_max, torque_tol)
            row["torque_step_nm"] = r.value
            row["torque_bracketed"] = r.bracketed
            table[est][c] = row
    m = {"table": table, "recovery": {"final_window_s": _FINAL_S, "tilt_deg": _TILT_OK,
                                      "tilt_rate_deg_s": _RATE_OK, "heading_deg": _YAW_OK},
         "disturbance_time_s": _T_DIST, "duration_s": _DURATION, "torque_pulse_s": _PULSE,
         "push_tol_deg": push_tol, "torque_tol_nm": torque_tol, "passed": True}
    (out / "metrics.json").write_text(json.dumps(m, indent=2) + "\n")
    (out / "report.md").write_text("\n".join(envelope_report_lines(m)) + "\n")
    if plot:
        fig, axes = plt.subplots(1, len(estimators), subplot_kw={"projection": "polar"},
                                 figsize=(5 * len(estimators), 5), squeeze=False)
        for ax, est in zip(axes[0], estimators):
            for c, row in table[est].items():
                ang, rad = [], []
                for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):  # symmetric robot
                    for d, (u, v) in PUSH_DIRECTIONS.items():
                        ang.append(math.atan2(sy * v, sx * u))
                        rad.append(row[f"push_{d}_deg"])
                order = np.argsort(ang)
                a = np.array(ang)[order]
                r = np.array(rad)[order]
                ax.plot(np.append(a, a[0]), np.append(r, r[0]), marker="o", ms=3, label=c)
            ax.set_title(f"largest push recovered (deg), {est}")
            ax.legend(loc="lower left", fontsize=8)
        fig.tight_layout()
        fig.savefig(out / "envelope.png", dpi=120)
        plt.close(fig)
    return m


def envelope_report_lines(m: dict[str, Any]) -> list[str]:
    """``report.md``: the envelope table, the thesis's statements beside it."""
    lines = ["# Push-recovery envelope per balance controller", "",
             f"Standing robot (velocity cascade), disturbance at t = {m['disturbance_time_s']} s, "
             f"{m['duration_s']} s runs; recovered = finite and, over the last "
             f"{m['recovery']['final_window_s']} s, tilt <= max({m['recovery']['tilt_deg']} deg, "
             f"2x undisturbed), tilt rate <= max({m['recovery']['tilt_rate_deg_s']} deg/s, 2x "
             f"undisturbed), heading within ±{m['recovery']['heading_deg']} deg.  Bisection to {m['push_tol_deg']} deg / "
             f"{m['torque_tol_nm']} N m (the largest value verified recovered; '>=' when the "
             "search's upper end was recovered).", ""]
    for est, rows in m["table"].items():
        lines += [f"## controllers on {'the true state' if est == 'true' else 'the QUKF + VUKF'}",
                  "", "| controller | roll push (deg) | pitch push (deg) | diagonal push (deg) | "
                  f"wheel-0 torque pulse {m['torque_pulse_s']} s (N m) |", "|---|---|---|---|---|"]
        for c, r in rows.items():
            cells = [("" if r[f"push_{d}_bracketed"] else ">= ") + f"{r[f'push_{d}_deg']:.2f}"
                     for d in PUSH_DIRECTIONS]
            tq = ("" if r["torque_bracketed"] else ">= ") + f"{r['torque_step_nm']:.2f}"
            lines.append(f"| {c} | " + " | ".join(cells) + f" | {tq} |")
        lines.append("")
    lines += ["Thesis: the FLC recovers from the 4 deg roll jump of §8.4.3 (Fig. 8.14); the "
              "SMC's robustness is argued for the reaching phase only (§8.3); the super-twisting "
              "law and a disturbance observer for the FLC are proposed as future work (ch. 11); "
              "the predecessor balanced with an LQR (§1.2).", "",
              "Not built: the FLC + disturbance-observer extension (issue 22); its row is "
              "missing, so whether it raises the FLC's envelope is not measured."]
    return lines
