"""``ballbot fmu cosim``: run an SSP system (plant + controller FMUs) and write it up like a study.

:func:`run_sil` co-simulates an SSP archive of :mod:`ballbot_casadi.fmi.system.sil` (libcosim by
default, or the controller-first Gauss-Seidel master) and writes, all together (the
folder is replaced as a whole):

* ``connections.csv``: every connection's value at every communication point (both ends:
  the output that was read and the input that was held), the plant's states and the
  controller's estimate and diagnostics (``%.17g``, exact doubles);
* ``run.npz``: the run as a :class:`~ballbot_casadi.sim.log.SimulationLog` in the
  compiled mission's layout (:func:`~ballbot_casadi.fmi.system.sil_log.sil_log`);
* ``metrics.json``: the metrics of :func:`~ballbot_casadi.analysis.metrics.run_metrics`,
  the scenario file's specs, the thesis §7.1 limits (as a study's), and the section
  ``sil``: master, steps, wall time and, when the SSP carries its scenario, the largest
  difference of states and torques from the compiled mission that the master reproduces
  (``libcosim``: the mission with the Jacobi master's one period of actuation delay,
  :func:`run_scenario` with ``actuation_delay``; ``gauss-seidel``: the mission itself);
* ``plot.png`` (attitude, speed, torques, tracking error), ``sil_compare.png`` (the
  differences from that mission over time) and ``report.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)
import numpy as np

from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.core.files import staged_dir
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.fmi.masters.ssp_run import run_ssp
from ballbot_casadi.fmi.system.sil import SilRun
from ballbot_casadi.fmi.system.sil_log import sil_log
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.guided import run_path_scenario
from ballbot_casadi.sim.log import save_log
from ballbot_casadi.studies.registry import Spec, evaluate_specs
from ballbot_casadi.studies.study import OWNED_OUTPUTS, _report, _result, jsonable, plot_run
from ballbot_casadi.studies.formatting import write_metrics

__all__ = ["SIL_OUTPUTS", "run_sil", "mission_difference", "plot_compare"]

#: Files the output folder may hold and still be replaced.
SIL_OUTPUTS = (*OWNED_OUTPUTS, "connections.csv")


def mission_difference(run: SilRun, log_arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """Largest differences of the run from the compiled mission its master reproduces.

    ``libcosim`` (Jacobi) is compared with the compiled mission with ``actuation_delay`` (:func:`run_scenario`),
    ``gauss-seidel`` with the compiled mission itself (:func:`run_scenario`), over the
    periods the run covers; a scenario with a ``[path]`` with the compiled guided mission
    (:func:`~ballbot_casadi.sim.guided.run_path_scenario`, with or without the delay).  Returns ``reference``, ``state_max``, ``tau_max``,
    ``tau_cmd_max``, ``x_hat_max`` and the per-period differences ``state_diff``,
    ``tau_diff`` (for the plot).
    """
    sc = run.scenario
    if sc is None:
        raise ScenarioError("the SSP carries no scenario to compare with")
    n = log_arrays["tau"].shape[0]
    sc = sc.replace(duration=n * sc.Ts) if sc.n_periods != n else sc
    delay = run.master == "libcosim"
    if sc.route.build() is not None:  # the guided mission (the path-following variant)
        ref = run_path_scenario(sc, actuation_delay=delay).arrays
    else:
        ref = run_scenario(sc, ClosedLoop(), actuation_delay=delay).arrays
    what = ("compiled mission with one period of actuation delay (Jacobi)" if delay
            else "compiled mission")
    ds = np.max(np.abs(log_arrays["state"] - ref["state"]), axis=1)
    dt = np.max(np.abs(log_arrays["tau"] - ref["tau"]), axis=1)
    return {"reference": what, "state_max": float(ds.max()), "tau_max": float(dt.max()),
            "tau_cmd_max": float(np.max(np.abs(log_arrays["tau_cmd"] - ref["tau_cmd"]))),
            "x_hat_max": float(np.max(np.abs(log_arrays["x_hat"] - ref["x_hat"]))),
            "state_diff": ds, "tau_diff": dt}


def plot_compare(time: np.ndarray, diff: dict[str, Any], path: Path) -> Path:
    """Per-period largest state and torque difference from the reference mission (PNG)."""
    fig, ax = plt.subplots(figsize=(8, 3.5))
    n = diff["tau_diff"].size
    ax.semilogy(time, np.maximum(diff["state_diff"], 1e-18), label="max |state - mission|")
    ax.semilogy(time[:n], np.maximum(diff["tau_diff"], 1e-18), label="max |tau - mission| (N m)")
    ax.axhline(1e-9, color="r", lw=0.6, label="1e-9")
    ax.set_xlabel("time (s)")
    ax.set_title(f"SIL vs {diff['reference']}", fontsize=9)
    ax.legend(loc="upper left", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def run_sil(ssp: str | Path, out: str | Path, duration: float | None = None,
            master: str = "libcosim", plot: bool = True, compare: bool = True,
            allow_long: bool = False) -> dict[str, Any]:
    """Co-simulate ``ssp`` and write the outputs of the module docstring to ``out``.

    Returns the content of ``metrics.json``.  ``compare`` (needs the scenario in the SSP)
    adds the difference from the compiled mission.  ``allow_long``: see
    :func:`~ballbot_casadi.fmi.masters.ssp_run.run_ssp`.
    """
    ssp, out = Path(ssp), Path(out)
    run = run_ssp(ssp, duration, master, allow_long=allow_long)
    if run.scenario is None:
        raise ScenarioError(f"{ssp} carries no scenario (resources/scenario.json); write it with "
                            "'ballbot fmu ssp'")
    if any(f"plant.{n}" not in run.signals for n in STATE.names):
        return _connections_only(run, out)
    log = sil_log(run)
    metrics = run_metrics(log)
    spec = evaluate_specs([Spec.from_row(r) for r in run.specs], metrics)
    sc = run.scenario
    result = _result("sil", sc.name, sc.controller, metrics, spec, [log], [sc.description])
    n = log.arrays["tau"].shape[0]
    sil: dict[str, Any] = {"ssp": str(ssp), "master": run.master, "steps": n, "step_s": sc.Ts,
                           "duration_s": n * sc.Ts, "wall_s": run.wall_s,
                           "connections": len(run.connections), "signals": len(run.signals)}
    diff = mission_difference(run, log.arrays) if compare else None
    if diff is not None:
        sil["vs_mission"] = {k: v for k, v in diff.items() if not k.endswith("_diff")}
    result["sil"] = sil
    with staged_dir(out, owned=SIL_OUTPUTS) as tmp:
        save_log(log, tmp / "run.npz")
        run.write_connections(tmp / "connections.csv")
        plots: list[str] = []
        if plot:
            plots.append(plot_run(f"SIL {sc.name} ({run.master})", [log], tmp / "plot.png").name)
            if diff is not None:
                plots.append(plot_compare(log.arrays["time"], diff, tmp / "sil_compare.png").name)
        lines = [f"- SSP: `{ssp}`; master `{run.master}`, {n} steps of {sc.Ts:g} s, "
                 f"{run.wall_s:.3g} s wall time, {len(run.connections)} connections logged "
                 "(`connections.csv`)", f"- {sc.description or sc.name}"]
        if diff is not None:
            lines.append(f"- against the {diff['reference']}: states within "
                         f"{diff['state_max']:.3g}, torques within {diff['tau_max']:.3g} N m")
        _report(tmp, f"Software in the loop `{sc.name}`", result, plots, lines)
        write_metrics(tmp, jsonable(result))
    return result


def _connections_only(run: SilRun, out: Path) -> dict[str, Any]:
    """A plant without the state outputs: the connections and the run's facts only."""
    result = {"sil": {"master": run.master, "steps": run.time.size - 1, "wall_s": run.wall_s,
                      "connections": len(run.connections), "signals": len(run.signals)},
              "passed": True, "metrics": {},
              "note": "the plant FMU has no state outputs (x, y, q0..q3, dx, dy, dq0..dq3): no "
                      "metrics or plots, the connections are in connections.csv"}
    with staged_dir(out, owned=SIL_OUTPUTS) as tmp:
        run.write_connections(tmp / "connections.csv")
        write_metrics(tmp, jsonable(result))
    return result
