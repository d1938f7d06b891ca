"""The ``make demo`` report: one Markdown page over every demo step's outputs.

Reads what the earlier demo steps wrote under the demo directory (analysis, studies, FMU,
benchmarks if present) and writes ``report.md`` linking the plots.  It computes nothing
new, so the numbers in the report are exactly those of the step outputs.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ballbot_casadi.core.params import PARAM_INFO, load_params
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.model.linearization import model_summary

__all__ = ["write_report", "demo_step"]


def _load(path: Path) -> dict[str, Any] | None:
    return json.loads(path.read_text()) if path.is_file() else None


def _num(v: Any, fmt: str = ".4g") -> str:
    if v is None:
        return "n/a"
    if isinstance(v, (list, tuple)):
        return ", ".join(_num(x, fmt) for x in v)
    if isinstance(v, bool):
        return "yes" if v else "no"
    return format(v, fmt) if isinstance(v, (int, float)) else str(v)


def _model_section() -> list[str]:
    p = load_params()
    rows = [f"| `{n}` | {getattr(p, n):.6g} | {PARAM_INFO[n][0]} | {PARAM_INFO[n][1]} |"
            for n in p.names]
    return [
        "## Model",
        "",
        "3D quaternion Euler–Lagrange model (thesis App. B–C), generated to C with its",
        "Jacobians (`build/codegen/`).",
        "",
        "```",
        model_summary(p),
        "```",
        "",
        "<details><summary>Parameters (thesis App. A)</summary>",
        "",
        "| name | value | unit | meaning |",
        "| --- | --- | --- | --- |",
        *rows,
        "",
        "</details>",
        "",
    ]


def _analysis_section(out: Path) -> list[str]:
    a = _load(out / "analysis" / "analysis.json")
    if a is None:
        return ["## Linear analysis", "", "not run", ""]
    return [
        "## Linear analysis ([full report](analysis/analysis.md))",
        "",
        f"- reduced model: {a['n_states_reduced']} states, controllability rank "
        f"{a['controllability_rank']}",
        f"- unstable poles: {_num(a['unstable_poles'])} rad/s",
        f"- right-half-plane zeros, torques → position: {_num(a['rhp_zeros_position'])} rad/s "
        "(non-minimum phase: the ball first moves backwards, thesis §2.5)",
        f"- tracking bandwidths (|S| = −3 dB): inner {_num(a.get('bandwidth_sensitivity_inner_hz'))}"
        f" Hz, outer {_num(a.get('bandwidth_sensitivity_outer_hz'))} Hz, ratio "
        f"{_num(a.get('bandwidth_sensitivity_ratio'))}; 3× rule (thesis §7.1): "
        f"{_num(a.get('cascade_rule_ok'))}",
        f"- −3 dB of |T|: inner {_num(a.get('bandwidth_inner_hz'))} Hz, outer "
        f"{_num(a.get('bandwidth_outer_hz'))} Hz (see the full report on why |T| misleads for "
        "the non-minimum-phase outer loop)",
        "",
        "![pole-zero map](analysis/pole_zero.png)",
        "",
    ]


def _study_section(out: Path, name: str, title: str, keys: list[str]) -> list[str]:
    m = _load(out / f"study_{name}" / "metrics.json")
    if m is None:
        return [f"## {title}", "", "not run", ""]
    flat = {**m, **m.get("metrics", {})} if isinstance(m.get("metrics"), dict) else m
    verdict = "PASS" if m.get("passed") else "FAIL"
    lines = [f"## {title} ([report](study_{name}/report.md)): {verdict}", "",
             "| metric | value |", "| --- | --- |"]
    lines += [f"| `{k}` | {_num(flat.get(k))} |" for k in keys if k in flat]
    exceeded = m.get("limits_exceeded") or []
    if exceeded:
        lines += ["", "Thesis §7.1 limits exceeded (reported): " + ", ".join(f"`{k}`" for k in exceeded)]
    plot = {"chirp": "chirp_bode.png", "full": "estimates_velocity.png"}.get(name, "plot.png")
    lines += ["", f"![{name}](study_{name}/{plot})", ""]
    return lines


def _montecarlo_section(out: Path) -> list[str]:
    m = _load(out / "montecarlo" / "montecarlo.json")
    if m is None:
        return ["## Monte Carlo", "", "not run", ""]
    return [f"## Monte Carlo: `{m['name']}`, {m['n']} runs ([report](montecarlo/report.md))", "",
            f"- success rate against the scenario's specs: {100 * m['success_rate']:.1f} %",
            *[f"- `{s['metric']}` {s['op']} {s['threshold']}: {100 * s['pass_rate']:.1f} % pass"
              for s in m["specs"]],
            "- worst runs (rerun with `ballbot simulate`): "
            + ", ".join(f"[run {w['index']}](montecarlo/{w['file']})" for w in m["worst"]), "",
            "![histograms](montecarlo/histograms.png)", ""]


def _fmu_section(out: Path) -> list[str]:
    s = out / "fmu" / "summary.txt"
    if not s.is_file():
        return ["## Plant FMU", "", "not run", ""]
    return ["## Plant FMU (`build/fmu/BallbotPlant.fmu`)", "", *[f"- {line}" for line in
            s.read_text().splitlines() if line.strip()], ""]


def _bench_section(bench: Path) -> list[str]:
    b = _load(bench)
    if b is None:
        return ["## Benchmarks", "", "`make bench` not run yet (writes build/bench.json).", ""]
    keys = ["ode_ns", "jac_ns", "python_call_ns", "control_step_us", "mission_100s_s",
            "python_loop_ratio", "fmu_plant_step_us", "fmu_vs_pythonfmu_ratio",
            "montecarlo_runs_per_s_1w", "montecarlo_runs_per_s_2w", "montecarlo_parallel_efficiency"]
    return ["## Benchmarks (`make bench`, build/bench.json)", "", "| key | value |",
            "| --- | --- |", *[f"| `{k}` | {_num(b.get(k))} |" for k in keys if k in b], ""]


def write_report(out: Path, bench: Path | None = None) -> Path:
    """Write ``out/report.md`` from the demo outputs under ``out``."""
    out = Path(out)
    if bench is None:
        bench = build_root() / "bench.json"
    lines = ["# ballbot-casadi demo report", "", "Default robot (thesis App. A). The controller "
             "studies (sine, COM offset, chirp) feed the true state back; the complete system "
             "(§9.3) reads noisy sensors through the QUKF + VUKF (and the SMC + EKF baseline). "
             "Regenerate with `make demo`; every thesis result beside ours: `ballbot study thesis`.", ""]
    lines += _model_section()
    lines += _analysis_section(out)
    lines += _study_section(out, "sine", "Roll sine 3° at 0.5 Hz (thesis §8.2.5)",
                            ["roll_lag_s", "pitch_error_max_deg", "yaw_error_max_deg",
                             "torque_total_variation", "torque_tv_ratio", "max_abs_torque_nm"])
    lines += _study_section(out, "com", "COM offset (−2, −3, +3) cm (thesis §8.4.2, §9.2)",
                            ["runaway_speed_mps", "final_speed_mps", "equilibrium_roll_deg",
                             "equilibrium_pitch_deg", "equilibrium_roll_analytic_deg",
                             "equilibrium_pitch_analytic_deg", "max_tilt_deg"])
    lines += _study_section(out, "chirp", "Chirp bandwidth test (thesis §9.1)",
                            ["bandwidth_hz", "bandwidth_criterion", "first_saturation_hz",
                             "first_saturation_s", "fell_at_s", "linear_bandwidth_hz"])
    lines += _study_section(out, "full", "The complete system: noisy sensors, QUKF + VUKF, thesis mode "
                            "(thesis §9.3, §9.4)",
                            ["tilt_error_max_deg", "heading_error_max_deg", "estimator_roll_rms_deg",
                             "estimator_pitch_rms_deg", "estimator_velocity_rms_mps", "position_drift_m",
                             "quat_norm_max_dev", "covariance_repairs", "gate_rejections"])
    lines += _montecarlo_section(out)
    lines += _fmu_section(out)
    lines += _bench_section(bench)
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def demo_step(out: Path) -> int:
    """``make demo`` step: write ``out/report.md``."""
    path = write_report(out)
    print(f"report: {path}")
    return 0
