"""The ``predecessor`` study: the V2019 EKF with its heading correction against the QUKF (thesis ch. 6).

The thesis compares its QUKF + VUKF (no heading sensor) with the predecessor's QEKF +
VEKF, whose QEKF had heading readings and gyro-bias states (§6.1-6.3), and concludes
"the UKF with no heading available produces as accurate estimations as the EKF that has
heading readings", and that the VEKF's "slightly better performance in the y-axis
velocity" "might be caused by [...] a heading correction in the QEKF".  This study runs
the noisy sine and the velocity profile (the ``estimators`` study's files) with four
systems on the same noise draws:

``ekfh``   the predecessor as the thesis describes it: QEKF with heading correction and
           gyro-bias states + VEKF, heading sensor on (``ekf_heading``,
           :mod:`~ballbot_casadi.estimation.predecessor`);
``ekf``    the EKF baseline without heading (the ``estimators`` study's);
``ukfh``   our QUKF with the heading reading and the z gyro bias (``ukf_heading``);
``ukf``    the thesis's set-up: QUKF + VUKF, no heading sensor (the main run).

The heading sensor (10 Hz, 0.2° noise, :mod:`~ballbot_casadi.core.sensor_params`) is an
assumption: the thesis names a LiDAR scan match or a magnetometer, without numbers.
"""

from __future__ import annotations

from typing import Any, Sequence

from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.sim.log import SimulationLog
from ballbot_casadi.sim.scenario import set_value

__all__ = ["SYSTEMS", "predecessor_expand", "predecessor_metrics", "predecessor_report_lines"]

#: The systems of the study: tag -> (estimator, heading sensor on), run order (main last).
SYSTEMS: dict[str, tuple[str, bool]] = {"ekfh": ("ekf_heading", True), "ekf": ("ekf", False),
                                        "ukfh": ("ukf_heading", True), "ukf": ("ukf", False)}
#: Per-run metrics compared, from the sine (attitude) and the velocity profile (the rest).
_SINE_KEYS = ("estimator_roll_rms_deg", "estimator_pitch_rms_deg", "estimator_tilt_rms_deg")
_VEL_KEYS = ("estimator_heading_max_deg", "estimator_heading_drift_deg", "estimator_vx_error_rms_mps",
             "estimator_vy_error_rms_mps", "estimator_velocity_rms_mps", "position_drift_m")


def predecessor_expand(tables: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``expand`` hook: every file once per system of :data:`SYSTEMS` (same seed), named
    ``<file>_<tag>``; the thesis's set-up (``ukf``) last, as written."""
    out = []
    for tag, (est, heading) in SYSTEMS.items():
        for t in tables:
            r = set_value(t, "estimator", est)
            if heading:
                r = set_value(r, "heading_sensor", True)
            out.append(r if tag == "ukf" else set_value(r, "name", f"{t.get('name', 'run')}_{tag}"))
    return out


def predecessor_metrics(logs: Sequence[SimulationLog]) -> dict[str, Any]:
    """``<tag>_<metric>`` per system (attitude errors on the sine, heading and velocity
    errors on the velocity profile) and the ratios the thesis's claims are judged by:

    * ``ukf_vs_ekfh_roll_rms_ratio``, ``..._pitch_...``: the UKF without heading over the
      EKF with heading (thesis: "as accurate");
    * ``ukf_vs_ekfh_heading_max_ratio``: the same for the heading estimate's largest error;
    * ``ukf_vs_ekfh_vy_rms_ratio``: VUKF over VEKF y-velocity error RMS (thesis: > 1,
      "slightly better in y" for the VEKF);
    * ``ukfh_vs_ekfh_*``: the same with our heading-aided QUKF.
    """
    runs = {log.scenario["name"]: run_metrics(log) for log in logs}
    names = [log.scenario["name"] for log in logs]
    n = len(SYSTEMS)
    per = len(names) // n
    out: dict[str, Any] = {}
    for i, tag in enumerate(SYSTEMS):
        sine, vel = (runs[k] for k in names[i * per:(i + 1) * per][:2])
        out.update({f"{tag}_{k.removeprefix('estimator_')}": sine[k] for k in _SINE_KEYS})
        out.update({f"{tag}_{k.removeprefix('estimator_')}": vel[k] for k in _VEL_KEYS})
        out[f"{tag}_heading_max_deg"] = abs(out[f"{tag}_heading_max_deg"])
    for a in ("ukf", "ukfh"):
        for k in ("roll_rms_deg", "pitch_rms_deg", "heading_max_deg", "vy_error_rms_mps"):
            short = k.replace("_deg", "").replace("_mps", "").replace("_error", "")
            out[f"{a}_vs_ekfh_{short}_ratio"] = out[f"{a}_{k}"] / out[f"ekfh_{k}"]
    out["by_run"] = runs
    return out


def predecessor_report_lines(m: dict[str, Any]) -> list[str]:
    """The four systems side by side and the reading of the thesis's two claims."""
    keys = ("roll_rms_deg", "pitch_rms_deg", "tilt_rms_deg", "heading_max_deg", "heading_drift_deg",
            "vx_error_rms_mps", "vy_error_rms_mps", "velocity_rms_mps", "position_drift_m")
    label = {"ekfh": "QEKF+heading+bias, VEKF (V2019)", "ekf": "QEKF, VEKF (no heading)",
             "ukfh": "QUKF+heading+bias, VUKF (ours)", "ukf": "QUKF, VUKF (thesis)"}
    lines = ["## The predecessor's EKF with its heading correction (thesis §6)", "",
             "| metric | " + " | ".join(label[t] for t in SYSTEMS) + " |",
             "| --- |" + " --- |" * len(SYSTEMS)]
    for k in keys:
        lines.append(f"| `{k}` | " + " | ".join(f"{m[f'{t}_{k}']:.4g}" for t in SYSTEMS) + " |")
    r = m
    lines += [
        "",
        f"- \"The UKF with no heading available produces as accurate estimations as the EKF that "
        f"has heading readings\" (§6.3): tilt - roll RMS ratio UKF / EKF-with-heading "
        f"{r['ukf_vs_ekfh_roll_rms_ratio']:.3g}, pitch {r['ukf_vs_ekfh_pitch_rms_ratio']:.3g}; "
        f"heading - largest error ratio {r['ukf_vs_ekfh_heading_max_ratio']:.3g} "
        f"({r['ukf_heading_max_deg']:.3g}° against {r['ekfh_heading_max_deg']:.3g}°). The claim holds "
        "for the tilt, which the accelerometer observes in both filters; the heading of a filter "
        "without a heading sensor integrates the gyroscope's noise and bias random walk, so it is "
        "as accurate only over runs short enough for that drift to stay small.",
        f"- \"Slightly better performance in the y-axis velocity estimated by the VEKF\" (§6.2): "
        f"VUKF / VEKF y-velocity error RMS {r['ukf_vs_ekfh_vy_rms_ratio']:.3g} (> 1: the VEKF "
        f"is better). With the heading reading in our QUKF the ratio is "
        f"{r['ukfh_vs_ekfh_vy_rms_ratio']:.3g}: the thesis's explanation (the heading "
        "correction) is tested by that column.",
        "- Same noise draws for every system (seed of the file); the heading sensor: 10 Hz, "
        "0.2° white noise, an assumed sensor (the thesis names a LiDAR or a magnetometer).", ""]
    return lines
