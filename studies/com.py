"""The ``com`` study: a COM offset unknown to the controllers, without and with the observer.

Runs (thesis §8.4.2, §9.2; the observer of ch. 11's future work,
:mod:`ballbot_casadi.estimation.com_observer`), with the COM at (-2, -3, +3) cm unless
said otherwise:

* ``com_balance_only`` - the balance controller alone runs away (§8.4.2);
* ``com`` - the velocity loop of §9.2 stops the run-away: the integrator of the
  velocity error holds the tilt, so the robot stands ~1.3 m away and the balance
  controller misses its reference by ~0.5 deg (its model is wrong);
* ``com_observer_true`` - the same with the online observer and position hold
  (controllers on the true state);
* ``com_ukf`` / ``com_observer`` - without and with the observer, noisy sensors and
  QUKF + VUKF in the loop (same seed; the shipped filters, ``ukf_adaptive``);
  ``com_observer`` is the main run, ``com_observer_ukf`` the same with the thesis's
  filters (``ukf``, :func:`thesis_filter_expand`) beside it;
* ``com_observer_velocity`` - the velocity profile of the ``velocity`` study (nominal
  robot) with the observer switched on (its specs must still hold);
* ``com_observer_centred`` - the observer on the nominal robot (COM centred), with noisy
  sensors; its file's Monte Carlo draws random offsets around the centre
  (``ballbot montecarlo com_observer_centred --n 100``).

The cross-run metrics carry the run as a prefix (``no_observer_``, ``observer_true_``,
``no_observer_ukf_``, ``observer_velocity_``, ``observer_centred_``,
``observer_thesis_filter_``); the main run's are unprefixed.  ``shipped_vs_thesis_velocity_rms_ratio``
is the main run's velocity error RMS over its thesis-filter twin's.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)
import numpy as np  # noqa: E402

from ballbot_casadi.analysis.com_observer import (  # noqa: E402
    WINDOW_S,
    com_observer_metrics,
    inclination_error_deg,
    trailing_mean_angle_deg,
)
from ballbot_casadi.analysis.metrics import run_metrics  # noqa: E402
from ballbot_casadi.core.layout import STATE, STATE_XY  # noqa: E402
from ballbot_casadi.estimation.com_observer import observable_offset  # noqa: E402
from ballbot_casadi.sim.log import SimulationLog  # noqa: E402
from ballbot_casadi.sim.scenario import set_value  # noqa: E402
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, THESIS_ESTIMATOR  # noqa: E402

__all__ = ["RUN_PREFIX", "THESIS_RUN", "thesis_filter_expand", "com_study_metrics", "plot_com",
           "com_report_lines"]

#: The main run with the thesis's filters (its name).
THESIS_RUN = f"com_observer_{THESIS_ESTIMATOR}"

#: Scenario name -> metric prefix of the cross-run metrics (the main run has none).
RUN_PREFIX = {"com": "no_observer_", "com_observer_true": "observer_true_",
              "com_ukf": "no_observer_ukf_", "com_observer_velocity": "observer_velocity_",
              "com_observer_centred": "observer_centred_", THESIS_RUN: "observer_thesis_filter_"}
_STANDING = ("final_position_error_m", "standing_tilt_error_deg", "standing_tilt_error_est_deg",
             "com_estimate_error_max_mm", "com_estimate_settle_s", "com_estimate_error_mm",
             "com_estimate_raw_error_mm", "final_speed_mps", "equilibrium_error_deg")
_VELOCITY = ("velocity_error_rms_delayed_mps", "max_abs_roll_pitch_deg", "final_velocity_error_mps",
             "finite")
#: Rows of the side-by-side table.
_TABLE = ("final_position_error_m", "standing_tilt_error_deg", "standing_tilt_error_est_deg",
          "com_estimate_error_max_mm", "com_estimate_settle_s", "com_estimate_raw_error_mm",
          "final_speed_mps", "peak_tilt_deg", "estimator_velocity_rms_mps", "nis_velocity_mean")


def thesis_filter_expand(tables: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``expand`` hook: the files as written, with the main run (last) once more with the
    thesis's filters (:data:`THESIS_ESTIMATOR`, named :data:`THESIS_RUN`) just before it."""
    main = tables[-1]
    thesis = set_value(set_value(main, "estimator", THESIS_ESTIMATOR), "name", THESIS_RUN)
    return [*tables[:-1], thesis, main]


def _name(log: SimulationLog) -> str:
    return str(log.scenario["name"])


def com_study_metrics(logs: Sequence[SimulationLog]) -> dict[str, Any]:
    """Run-away of the balance-only run, the other runs' standing (or velocity) metrics
    under their prefix, and ``by_run`` (each run's metrics for the side-by-side table)."""
    out: dict[str, Any] = {}
    by_run: dict[str, dict[str, Any]] = {}
    for log in logs:
        name = _name(log)
        x = log.arrays["state"]
        if name == "com_balance_only":
            out["runaway_speed_mps"] = float(math.hypot(x[-1, STATE.index("dx")], x[-1, STATE.index("dy")]))
            out["runaway_distance_m"] = float(np.linalg.norm(x[-1, STATE_XY]))
            continue
        m = run_metrics(log)
        if "com_hat" in log.arrays and m["finite"]:
            m.update(com_observer_metrics(log))  # also for runs whose controllers do not use it
        by_run[name] = m
        prefix = RUN_PREFIX.get(name)
        if prefix is None:
            continue
        keys = _VELOCITY if log.scenario.get("velocity_keyframes") else _STANDING
        out.update({prefix + k: m[k] for k in keys if k in m})
    main, thesis = by_run.get("com_observer", {}), by_run.get(THESIS_RUN, {})
    if "estimator_velocity_rms_mps" in main and thesis.get("estimator_velocity_rms_mps"):
        out["shipped_vs_thesis_velocity_rms_ratio"] = (main["estimator_velocity_rms_mps"]
                                                       / thesis["estimator_velocity_rms_mps"])
    out["by_run"] = by_run
    return out


def plot_com(logs: Sequence[SimulationLog], metrics: dict[str, Any], out: Path) -> list[Path]:
    """``com_observer.png``: distance from the start, COM estimate against its observable
    part, and inclination error against the reference, of the standing runs."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for log in logs:
        name = _name(log)
        if name in ("com_balance_only", "com_observer_velocity"):
            continue
        a = log.arrays
        n = a["q_ref"].shape[0]
        t = a["time"]
        axes[0].plot(t, np.linalg.norm(a["state"][:, STATE_XY], axis=1), label=name)
        p, c = log.params, log.ctrl_params
        obs = observable_offset([p.com_x, p.com_y], p.l, c.l)
        axes[1].semilogy(t[:n], np.maximum(np.linalg.norm(a["com_hat"] - obs, axis=1) * 1e3, 1e-6),
                         label=name + ("" if log.scenario.get("com_observer") else " (shadow)"))
        e, ang = inclination_error_deg(a["state"][:n, STATE["q"]], a["q_ref"])
        line, = axes[2].semilogy(t[:n], np.maximum(ang, 1e-9), lw=0.5, alpha=0.35)
        axes[2].semilogy(t[:n], np.maximum(trailing_mean_angle_deg(e, t[:n], WINDOW_S), 1e-9),
                         lw=1.4, color=line.get_color(), label=name)
    axes[0].set_ylabel("distance from start (m)")
    axes[1].axhline(2.0, color="r", lw=0.6)
    axes[1].set_ylabel("|COM estimate - observable| (mm)")
    axes[2].axhline(0.05, color="r", lw=0.6)
    axes[2].set_ylabel("inclination error vs ref (deg)")
    axes[2].set_title(f"thin: instantaneous (true attitude); thick: the mean error over the preceding "
                      f"{WINDOW_S:g} s (what the 0.05 deg spec limits)", fontsize=8)
    axes[2].set_xlabel("time (s)")
    for ax in axes:
        ax.legend(loc="upper right", fontsize=7)
    fig.suptitle("COM offset (-2, -3, +3) cm: without and with the observer")
    fig.tight_layout()
    path = out / "com_observer.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return [path]


def _cell(v: Any) -> str:
    if v is None:
        return "—"
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def com_report_lines(metrics: dict[str, Any]) -> list[str]:
    """The runs side by side and what the numbers mean."""
    runs = metrics.get("by_run", {})
    names = [n for n in runs if n != "com_observer_velocity"]
    lines = ["## Runs side by side", "", "| metric | " + " | ".join(f"`{n}`" for n in names) + " |",
             "| --- |" + " --- |" * len(names)]
    for k in _TABLE:
        lines.append(f"| `{k}` | " + " | ".join(_cell(runs[n].get(k)) for n in names) + " |")
    lines += [
        "",
        "- `com_estimate_*` compare the estimate with the *observable part* of the offset, "
        "`l_model / l_true (com_x, com_y)`: at rest only the direction of the COM vector is "
        "observable (every point on the vertical through the ball centre balances), and that "
        "direction gives the exact balance point; `com_estimate_raw_error_mm` is the distance "
        "to the true offset, which includes the unobservable height error's share "
        "(here +3 cm of height scale the offset by 0.93).",
        "- Runs without the observer run it in the shadow (its estimate is logged, the "
        "controllers do not use it): the same estimate, but the loop of thesis §9.2.",
        "- `standing_tilt_error_est_deg` is the mean inclination error, over the last 10 s, of "
        "the attitude the controllers read against their reference: the systematic error of "
        "a wrong internal model. `standing_tilt_error_deg` uses the true attitude; with "
        "sensors the two differ by the attitude estimate's own slowly varying tilt error, "
        "which no controller can see: the QUKF alone leaves about 0.05 deg (up to 0.13 deg) "
        "averaged over 10 s (gyroscope noise integrated between its deliberately slow "
        "accelerometer corrections); the embedded software's velocity-aided tilt correction "
        "(the VUKF's horizontal accelerometer bias is that error, observed through the "
        "encoders; `ballbot_casadi/estimation/tilt_aiding.py`) brings it to about 0.01 deg "
        "(up to 0.03 deg over 100 random offsets).",
        f"- `{THESIS_RUN}` is the main run with the thesis's filters (`estimator = "
        f"\"{THESIS_ESTIMATOR}\"`, `--estimator {THESIS_ESTIMATOR}`) on the same noise draws; "
        f"the shipped files run `{DEFAULT_ESTIMATOR}` (issue 22), whose velocity filter is "
        "consistent (`nis_velocity_mean` near its dimension 6; the thesis's far above: "
        "overconfident) and whose velocity error is smaller.",
        "",
    ]
    return lines
