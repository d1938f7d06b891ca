"""Running a study of :mod:`ballbot_casadi.studies.registry`: logs, metrics, specs, plots.

Each study runs its scenario(s) through the compiled closed loop, writes
``DIR/metrics.json``, the run log ``DIR/run.npz`` (``com`` also
``DIR/run_balance_only.npz``) and ``DIR/plot.png``; the command (``ballbot study``)
prints a short summary and exits with status 1 when a spec of the study is missed.  ``ballbot study all`` runs every study for both balance controllers and
writes the FLC and SMC results side by side (``summary.json``, ``summary.md``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)
import numpy as np

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.analysis.metrics import attitude_error_deg, rpy_deg, tilt_deg
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.log import SimulationLog, save_log
from ballbot_casadi.studies.registry import STUDY_NAMES, get_study

__all__ = ["run_study", "run_all", "demo_sine", "demo_com", "CONTROLLERS"]

CONTROLLERS = ("flc", "smc")
DEFAULT_OUT = Path("build") / "study"


def _jsonable(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, np.bool_):
        return bool(v)
    return v


def plot_study(name: str, logs: Sequence[SimulationLog], path: Path) -> Path:
    """Euler angles vs references, tracking error, speed and torques of the main run (PNG)."""


    log = logs[-1]
    a = log.arrays
    n = a["tau"].shape[0]
    t = a["time"]
    ang = rpy_deg(a["state"][:, STATE["q"]])
    ref = rpy_deg(a["q_ref"])
    fig, axes = plt.subplots(4, 1, figsize=(8, 10), sharex=True)
    err = attitude_error_deg(log)
    for i, lab in enumerate(("roll", "pitch", "yaw")):
        line, = axes[0].plot(t, ang[:, i], label=lab)
        axes[0].plot(t[:n], ref[:, i], "--", color=line.get_color(), lw=0.8)
        axes[3].plot(t[:n], err[:, i], color=line.get_color(), label=f"{lab} error")
    axes[0].set_ylabel("angle (deg), -- ref")
    axes[0].legend(loc="upper right")
    axes[3].set_yscale("symlog", linthresh=1e-3)
    axes[3].set_ylabel("attitude error (deg)")
    axes[3].legend(loc="upper right", fontsize=7)
    speed = np.hypot(a["state"][:, STATE.index("dx")], a["state"][:, STATE.index("dy")])
    axes[1].plot(t, a["state"][:, STATE.index("dx")], label="dx")
    axes[1].plot(t, a["state"][:, STATE.index("dy")], label="dy")
    if log.scenario.get("cascade"):
        axes[1].plot(t[:n], a["v_ref"][:, 0], "--", lw=0.8, label="vx ref")
        axes[1].plot(t[:n], a["v_ref"][:, 1], "--", lw=0.8, label="vy ref")
    axes[1].plot(t, speed, ":", label="|v|")
    if len(logs) > 1:
        b = logs[0].arrays
        axes[1].plot(b["time"], np.hypot(b["state"][:, STATE.index("dx")], b["state"][:, STATE.index("dy")]), label="|v| balance only")
    axes[1].set_ylabel("ball velocity (m/s)")
    axes[1].legend(loc="upper right", fontsize=7)
    for i in range(3):
        axes[2].step(t[:n], a["tau"][:, i], where="post", label=f"tau{i}")
    axes[2].set_ylabel("wheel torque (N m)")
    axes[3].set_xlabel("time (s)")
    axes[2].legend(loc="upper right")
    fig.suptitle(f"study {name} ({log.scenario['controller']}): tilt max {tilt_deg(a['state'][:, 2:6]).max():.2f} deg")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def run_study(
    name: str,
    controller: str = "flc",
    out: Path | None = None,
    sim: ClosedLoop | None = None,
    plot: bool = True,
) -> dict[str, Any]:
    """Run study ``name`` and write its outputs to ``out``.

    Returns
    -------
    dict
        ``{"study", "controller", "passed", "metrics", "spec"}`` (also ``metrics.json``).
    """
    out = Path(out) if out is not None else DEFAULT_OUT / name / controller
    study = get_study(name)
    scenarios = study.scenarios(controller)
    sim = ClosedLoop() if sim is None else sim
    logs = [run_scenario(s, sim) for s in scenarios]
    metrics = study.compute_metrics(logs)
    spec = study.check(metrics)
    result = {
        "study": name,
        "controller": controller,
        "passed": all(r["ok"] for r in spec),
        "metrics": {k: _jsonable(v) for k, v in metrics.items()},
        "spec": [{k: _jsonable(v) for k, v in r.items()} for r in spec],
        "scenarios": [s.description for s in scenarios],
    }
    out.mkdir(parents=True, exist_ok=True)
    save_log(logs[-1], out / "run.npz")
    for s, log in zip(scenarios[:-1], logs[:-1]):
        save_log(log, out / f"run_{s.name.removeprefix(name + '_')}.npz")
    (out / "metrics.json").write_text(json.dumps(result, indent=2) + "\n")
    if plot:
        plot_study(name, logs, out / "plot.png")
    return result


def format_summary(result: dict[str, Any]) -> str:
    """Short text summary: one line per spec criterion and the verdict."""
    lines = [f"study {result['study']} ({result['controller']}): "
             f"{'PASS' if result['passed'] else 'FAIL'}"]
    for r in result["spec"]:
        v = r["value"]
        vs = f"{v:.4g}" if isinstance(v, float) else str(v)
        lines.append(f"  [{'ok' if r['ok'] else 'FAIL'}] {r['metric']} = {vs} "
                     f"(spec {r['op']} {r['threshold']}; {r['source']})")
    return "\n".join(lines)


def run_all(out: Path | None = None, plot: bool = True) -> dict[str, Any]:
    """Every study for both controllers; writes ``summary.json`` and ``summary.md``."""
    out = Path(out) if out is not None else DEFAULT_OUT
    sim = ClosedLoop()
    table: dict[str, Any] = {}
    for name in STUDY_NAMES:
        table[name] = {c: run_study(name, c, out / name / c, sim, plot) for c in CONTROLLERS}
    (out / "summary.json").write_text(json.dumps(table, indent=2) + "\n")
    md = ["| study | metric | spec | flc | smc |", "| --- | --- | --- | --- | --- |"]
    for name, res in table.items():
        for i, row in enumerate(res["flc"]["spec"]):
            cells = []
            for c in CONTROLLERS:
                r = res[c]["spec"][i]
                v = r["value"]
                cells.append((f"{v:.4g}" if isinstance(v, float) else str(v)) + ("" if r["ok"] else " ✗"))
            md.append(f"| {name} | {row['metric']} | {row['op']} {row['threshold']} | {cells[0]} | {cells[1]} |")
    (out / "summary.md").write_text("\n".join(md) + "\n")
    return table


def _demo(name: str, out: Path) -> int:
    result = run_study(name, "flc", Path(out) / f"study_{name}")
    print(format_summary(result))
    for k, v in result["metrics"].items():
        print(f"  {k:32s} {v}")
    return 0 if result["passed"] else 1


def demo_sine(out: Path) -> int:
    """``make demo`` step: the roll-sine study (thesis §8.2.5) into ``out/study_sine``."""
    return _demo("sine", out)


def demo_com(out: Path) -> int:
    """``make demo`` step: the COM-offset study (thesis §8.4.2, §9.2) into ``out/study_com``."""
    return _demo("com", out)
