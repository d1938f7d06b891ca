"""``ballbot montecarlo``: a scenario file dispersed over many runs, on Dask, with a report.

The runs are drawn by :mod:`ballbot_casadi.sim.scenario.dispersions`, evaluated by
:mod:`ballbot_casadi.studies.montecarlo_runner` and summarised by
:mod:`ballbot_casadi.analysis.dispersion_stats`; this module runs them (a Dask ``LocalCluster`` by default, an existing cluster with ``scheduler``,
or serially with ``workers = 0``) with a progress bar (tqdm) and writes, all together:

* ``montecarlo.json``: success rate against the file's specs, per-spec pass rates,
  metric statistics, the dispersions, and every run (index, noise seed, drawn values,
  ok, metrics);
* ``histograms.png`` (distributions of the spec metrics and the §7.1 peaks),
  ``scatter.png`` (a metric against each dispersed parameter);
* ``worst/`` the scenario files of the worst runs (failed specs first, then the spec
  closest to its threshold, :func:`spec_usage`, then the largest peak tilt), each
  rerunnable alone: ``ballbot simulate worst/<file>.toml``;
* ``report.md`` (with the worst run of each spec).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)
import numpy as np
from tqdm import tqdm

from ballbot_casadi.analysis.dispersion_stats import summarize
from ballbot_casadi.studies.dask_cluster import check_scheduler_address, connect, quiet_dask_logs
from ballbot_casadi.analysis.metric_names import check_spec_metrics
from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.files import staged_dir
from ballbot_casadi.core.safe_paths import check_file_name
from ballbot_casadi.core.specs import spec_ok, spec_usage, specs_or_default
from ballbot_casadi.errors import ArgumentError, ClusterError
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.scenario import (
    ScenarioFile,
    dump_toml,
    load_scenario_file,
    parse_scenario,
    set_value,
)
from ballbot_casadi.sim.scenario.dispersions import draw_runs
from ballbot_casadi.studies.formatting import fmt, md_cell
from ballbot_casadi.studies.montecarlo_runner import run_dask, run_serial
from ballbot_casadi.studies.registry import resolve_scenario
from ballbot_casadi.studies.study import jsonable

__all__ = ["run_montecarlo", "execute", "demo_step", "spec_usage", "OWNED_OUTPUTS", "N_WORST"]

#: Files an existing output folder may hold and still be replaced.
OWNED_OUTPUTS = ("montecarlo.json", "*.png", "report.md", "worst")
#: Number of worst runs written as scenario files.
N_WORST = 5
_RANK_METRIC = "peak_tilt_deg"
#: The thesis §7.1 limits drawn on the histograms of the peaks (deg, deg/s).
_LIMITS = {"peak_tilt_deg": math.degrees(THESIS_LIMITS["tilt_max"]),
           "peak_tilt_rate_deg_s": math.degrees(THESIS_LIMITS["tilt_rate_max"])}


def execute(source: ScenarioFile, runs: Sequence[dict[str, Any]], scheduler: str | None = None,
            workers: int = 2, quiet: bool = False, sim: ClosedLoop | None = None) -> list[dict[str, Any]]:
    """Evaluate the runs: serially (``workers == 0`` and no scheduler), on a new
    ``LocalCluster`` of ``workers`` processes, or on the cluster at ``scheduler``.

    Raises :class:`~ballbot_casadi.errors.ClusterError` (``finished``: position in
    ``runs`` to result) when the cluster lost its workers beyond repair."""
    bar = tqdm(total=len(runs), desc=f"montecarlo {source.scenario.name}", unit="run", disable=quiet)
    try:
        if scheduler is None and workers == 0:
            return run_serial(source, runs, sim, bar.update)
        from distributed import Client, LocalCluster

        if scheduler is not None:
            with quiet_dask_logs(), connect(scheduler) as client:  # never a hang if nothing answers
                return run_dask(source, runs, client, bar.update)
        with quiet_dask_logs(), LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                             dashboard_address=None) as cluster, Client(cluster) as client:
            return run_dask(source, runs, client, bar.update, cluster=cluster)  # replaces lost workers
    finally:
        bar.close()


def _worst_usage(specs: Sequence[Mapping[str, Any]], metrics: Mapping[str, Any]) -> tuple[float, str | None]:
    """The largest :func:`spec_usage` of a run over the specs, and its metric."""
    best: tuple[float, str | None] = (-math.inf, None)
    for s in specs:
        u = spec_usage(metrics.get(s["metric"]), s["op"], s["threshold"])
        if u is not None and u > best[0]:
            best = (u, s["metric"])
    return best


def _rank(results: Sequence[dict[str, Any]], specs: Sequence[Mapping[str, Any]]) -> list[int]:
    """Worst first: failed specs, then the spec closest to (or furthest beyond) its
    threshold, then the peak tilt."""
    def key(i: int) -> tuple:
        r = results[i]
        v = r["metrics"].get(_RANK_METRIC, math.inf)
        return (sum(not ok for ok in r["spec_ok"]) + (1 if r["error"] or r.get("failure") else 0),
                _worst_usage(specs, r["metrics"])[0],
                v if isinstance(v, float) and math.isfinite(v) else math.inf)
    return sorted(range(len(results)), key=key, reverse=True)


def _plots(summary: dict[str, Any], runs: Sequence[dict[str, Any]], results: Sequence[dict[str, Any]],
           out: Path) -> list[str]:
    metrics = list(dict.fromkeys([s["metric"] for s in summary["specs"] if s["metric"] != "finite"]
                                 + ["peak_tilt_deg", "peak_tilt_rate_deg_s", "peak_torque_nm"]))[:6]
    fig, axes = plt.subplots(2, 3, figsize=(11, 6))
    for ax, m in zip(axes.ravel(), metrics):
        vals = np.array([r["metrics"].get(m, np.nan) for r in results], float)
        vals = vals[np.isfinite(vals)]
        ax.hist(vals, bins=max(5, min(30, len(vals) // 2 or 1)), color="C0")
        for s in summary["specs"]:
            if s["metric"] == m and isinstance(s["threshold"], (int, float)) and not isinstance(s["threshold"], bool):
                ax.axvline(s["threshold"], color="r", lw=1, label=f"spec {s['op']} {s['threshold']}")
                ax.legend(fontsize=6)
        if m in _LIMITS:
            ax.axvline(_LIMITS[m], color="C1", lw=1, ls="--", label=f"§7.1 limit {_LIMITS[m]:g}")
            ax.legend(fontsize=6)
        ax.set_title(m, fontsize=8)
    for ax in axes.ravel()[len(metrics):]:
        ax.axis("off")
    fig.suptitle(f"Monte Carlo: {summary['n']} runs, success {100 * summary['success_rate']:.0f} %")
    fig.tight_layout()
    fig.savefig(out / "histograms.png", dpi=80)
    plt.close(fig)
    params = list(runs[0]["values"]) if runs else []
    y_metric = metrics[0] if metrics else _RANK_METRIC
    ncol = 3
    nrow = max(1, math.ceil(len(params) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(11, 3 * nrow), squeeze=False)
    y = np.array([r["metrics"].get(y_metric, np.nan) for r in results], float)
    ok = np.array([r["ok"] for r in results])
    for ax, p in zip(axes.ravel(), params):
        x = np.array([r["values"][p] for r in runs], float)
        ax.scatter(x[ok], y[ok], s=10, c="C2", label="pass")
        ax.scatter(x[~ok], y[~ok], s=14, c="C3", marker="x", label="fail")
        ax.set_xlabel(p, fontsize=8)
        ax.set_ylabel(y_metric, fontsize=8)
        ax.legend(fontsize=6)
    for ax in axes.ravel()[len(params):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(out / "scatter.png", dpi=80)
    plt.close(fig)
    return ["histograms.png", "scatter.png"]




def run_montecarlo(scenario: str | Path, n: int, out: str | Path, scheduler: str | None = None,
                   workers: int = 2, quiet: bool = False, seed: int | None = None,
                   overrides: Sequence[tuple[str, Any]] = (), sim: ClosedLoop | None = None,
                   resume: bool = False) -> dict[str, Any]:
    """Run ``n`` dispersed copies of a scenario file (or shipped name) and write the report.

    ``overrides`` (``--set``) change the base table before the dispersions (e.g. a
    shorter ``duration_s``).  Returns the content of ``montecarlo.json``.

    When the Dask cluster loses its workers beyond repair, the runs finished so far are
    written all the same (the same files, ``montecarlo.json`` with ``"partial": true``
    and the ``missing`` run indices) and :class:`~ballbot_casadi.errors.ClusterError` is
    raised saying so.  ``resume`` reuses the runs of such a file in ``out`` (the same set:
    same draws) and runs only the missing ones.
    """
    path = resolve_scenario(scenario)
    if scheduler is not None:
        check_scheduler_address(scheduler)
    source = load_scenario_file(path)
    if overrides:
        table = dict(source.table)
        for k, v in overrides:
            table = set_value(table, k, v)
        source = parse_scenario(table, f"{path} (with --set)", path.stem)
    check_spec_metrics(source.specs, str(path))  # a misspelled metric before any run
    runs = draw_runs(source, n, seed)
    out = Path(out)
    finished = _resumable(out, runs, specs_or_default(source.specs)) if resume else {}
    todo = [k for k in range(n) if k not in finished]
    stopped: ClusterError | None = None
    try:
        finished.update(zip(todo, execute(source, [runs[k] for k in todo], scheduler, workers, quiet, sim)))
    except ClusterError as exc:
        if exc.finished is None:
            raise
        finished.update((todo[j], res) for j, res in exc.finished.items())
        stopped = exc
    missing = [k for k in range(n) if k not in finished]
    doc = _write(out, path, source, runs, finished, missing, seed)
    if stopped is not None:
        raise ClusterError(f"{str(stopped).rstrip('.')}; the {len(finished)} finished runs of {n} are in "
                           f"{out / 'montecarlo.json'} (partial, missing runs {_ranges(missing)}); "
                           "run the same command with --resume to run only those") from None
    return doc


def _ranges(indices: Sequence[int]) -> str:
    """``0-3, 7, 9-10``: run indices in short form."""
    parts: list[str] = []
    for k in indices:
        if parts and parts[-1][1] == k - 1:
            parts[-1][1] = k
        else:
            parts.append([k, k])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in parts)


def _unjson(v: Any) -> Any:
    """A metric read back from ``montecarlo.json`` (non-finite floats were written as strings)."""
    return float(v) if v in ("nan", "inf", "-inf") else v


def _resumable(out: Path, runs: Sequence[dict[str, Any]], specs: Sequence[Mapping[str, Any]]) -> dict[int, dict[str, Any]]:
    """The results of ``out/montecarlo.json`` by run index, when it holds runs of the same set
    (same noise seeds and drawn values); empty when there is no such file.

    Raises
    ------
    ArgumentError
        The file is of another set (another scenario, ``--n``, ``--seed`` or ``--set``).
    """
    f = out / "montecarlo.json"
    if not f.is_file():
        return {}
    try:
        doc = json.loads(f.read_text(encoding="utf-8"))
        prior = {int(r["index"]): r for r in doc["runs"]}
        n_planned = int(doc.get("n_planned", doc["n"]))
    except (ValueError, KeyError, TypeError) as exc:
        raise ArgumentError(f"--resume: {f} is not a Monte Carlo result ({type(exc).__name__})") from None
    if n_planned != len(runs) or any(k >= len(runs) or r.get("seed") != runs[k]["seed"]
                                     or r.get("values") != runs[k]["values"] for k, r in prior.items()):
        raise ArgumentError(f"--resume: {f} holds another Monte Carlo set (other scenario, --n, --seed "
                            "or --set); give another --out or leave --resume out")
    results = {}
    for k, r in prior.items():
        m = {key: _unjson(v) for key, v in r["metrics"].items()}
        oks = ([False] * len(specs) if r.get("error") else
               [spec_ok(m.get(s["metric"]), s["op"], s["threshold"]) for s in specs])
        results[k] = {"ok": bool(r["ok"]), "spec_ok": oks, "metrics": m, "error": r.get("error"),
                      "failure": r.get("failure")}
    return results


def _write(out: Path, path: Path, source: ScenarioFile, runs: Sequence[dict[str, Any]],
           finished: Mapping[int, dict[str, Any]], missing: Sequence[int], seed: int | None = None) -> dict[str, Any]:
    """Write the outputs of the finished runs (all of them, or a partial set) into ``out``."""
    done = sorted(finished)
    runs_done = [runs[k] for k in done]
    results = [finished[k] for k in done]
    summary = summarize(source, runs_done, results, seed)  # the set seed used (--seed or the file's)
    worst = [done[j] for j in _rank(results, summary["specs"])[:min(N_WORST, len(results))]]
    doc = {"scenario": str(path), "name": source.scenario.name, **summary,
           "partial": bool(missing), "n_planned": len(runs), "missing": list(missing),
           "worst": [{"index": i, "seed": runs[i]["seed"], "file": f"worst/{runs[i]['table']['name']}.toml"}
                     for i in worst],
           "runs": [{"index": r["index"], "seed": r["seed"], "values": r["values"], "ok": res["ok"],
                     "error": res["error"], "failure": res.get("failure"), "metrics": res["metrics"]}
                    for r, res in zip(runs_done, results)]}
    doc = jsonable(doc)
    with staged_dir(out, owned=OWNED_OUTPUTS) as tmp:
        plots = _plots(summary, runs_done, results, tmp)
        (tmp / "worst").mkdir()
        for rank, i in enumerate(worst, 1):
            r = runs[i]
            check_file_name(r["table"]["name"], "Monte Carlo run name")  # stays inside worst/
            (tmp / "worst" / f"{r['table']['name']}.toml").write_text(dump_toml(
                r["table"], f"Monte Carlo run {i} of {path} (worst #{rank}); rerun alone with\n"
                            f"ballbot simulate {r['table']['name']}.toml"))
        (tmp / "montecarlo.json").write_text(json.dumps(doc, indent=1) + "\n")
        _report(tmp, doc, plots)
    return doc


def _report(out: Path, doc: dict[str, Any], plots: Sequence[str]) -> None:
    lines = [f"# Monte Carlo: `{doc['name']}` ({doc['n']} runs)", "",
             f"- scenario file: `{doc['scenario']}`; set seed {doc['seed']} (run i draws from "
             "`numpy.random.default_rng([seed, i])`)",
             f"- **success rate: {100 * doc['success_rate']:.1f} %** ({doc['n'] - doc['n_failed']}/{doc['n']} "
             "runs meet every spec)", ""]
    if doc.get("errors"):
        lines += [f"- **{len(doc['errors'])} run(s) raised an error** (not simulated, no metrics; they count as "
                  f"failed): {doc['errors'][0]}", ""]
    if doc.get("partial"):
        lines += [f"- **partial**: the Dask cluster lost its workers; {doc['n']} of {doc['n_planned']} runs "
                  f"finished, missing runs {_ranges(doc['missing'])} (`--resume` runs only those)", ""]
    lines += ["## Specs", "", "| metric | spec | pass rate | thesis | why |", "| --- | --- | --- | --- | --- |"]
    for s in doc["specs"]:
        lines.append(f"| `{s['metric']}` | {s['op']} {s['threshold']} | {100 * s['pass_rate']:.1f} % | "
                     f"{s.get('thesis') or '—'} | {s.get('source', '')} |")
    lines += ["", "## Dispersions", "", "| parameter | distribution |", "| --- | --- |"]
    for d in doc["dispersions"]:
        rel = " (relative)" if d.get("relative") else ""
        dist = f"normal, sd {d['sd']:g}{rel}" if d["dist"] == "normal" else f"uniform [{d['low']:g}, {d['high']:g}]{rel}"
        lines.append(f"| `{d['param']}` | {dist} |")
    lines += ["", "## Worst runs (rerun one alone with `ballbot simulate FILE`)", "",
              "Ranked by failed specs, then by the spec closest to its threshold (% of the "
              "allowance used: 100 % at the threshold).", "",
              "| run | noise seed | failed specs | closest spec | peak tilt (deg) | file |",
              "| --- | --- | --- | --- | --- | --- |"]
    by_index = {r["index"]: r for r in doc["runs"]}
    for w in doc["worst"]:
        r = by_index[w["index"]]
        failed = _failed_cell(doc, r)
        u, metric = _worst_usage(doc["specs"], r["metrics"])
        closest = f"`{metric}` {fmt(r['metrics'][metric])} ({100 * u:.0f} %)" if metric else "—"
        lines.append(f"| {w['index']} | {w['seed']} | {failed} | {closest} | "
                     f"{fmt(r['metrics'].get('peak_tilt_deg'))} | [{w['file']}]({w['file']}) |")
    per_spec = [s for s in doc["specs"] if s["op"] != "=="]
    if per_spec and doc["runs"]:
        lines += ["", "## Worst run of each spec", "",
                  "| metric | spec | worst value | % of the allowance | run | noise seed |",
                  "| --- | --- | --- | --- | --- | --- |"]
        for s in per_spec:
            usage = [(spec_usage(r["metrics"].get(s["metric"]), s["op"], s["threshold"]), r)
                     for r in doc["runs"]]
            usage = [(u, r) for u, r in usage if u is not None]
            if not usage:
                continue
            u, r = max(usage, key=lambda ur: ur[0])
            lines.append(f"| `{s['metric']}` | {s['op']} {s['threshold']} | {fmt(r['metrics'][s['metric']])} | "
                         f"{100 * u:.0f} % | {r['index']} | {r['seed']} |")
    lines += ["", "## Metric statistics", "", "| metric | mean | std | min | max | p95 |",
              "| --- | --- | --- | --- | --- | --- |"]
    for k, st in doc["metric_stats"].items():
        lines.append(f"| `{k}` | " + " | ".join(fmt(st[c]) for c in ("mean", "std", "min", "max", "p95")) + " |")
    lines += ["", "## Plots", ""] + [f"![{p}]({p})" for p in plots]
    (out / "report.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


def _spec_oks(doc: dict[str, Any], run: dict[str, Any]) -> list[bool]:
    return [spec_ok(run["metrics"].get(s["metric"]), s["op"], s["threshold"]) for s in doc["specs"]]


def _failed_cell(doc: dict[str, Any], run: dict[str, Any]) -> str:
    """The "failed specs" cell of a worst run: an errored run says so (its specs were never
    evaluated, so it has no metrics to judge), a fall or NaN run says why, then the specs
    its metrics miss."""
    if run.get("error"):
        return "**error**: " + md_cell(run["error"])
    failed = ", ".join(s["metric"] for s, ok in zip(doc["specs"], _spec_oks(doc, run)) if not ok) or "none"
    return f"**{run['failure']}**; {failed}" if run.get("failure") else failed


def demo_step(out: Path) -> int:
    """``make demo`` step: 16 runs with random COM offsets (<= 3 cm, the robot estimating
    its COM online, sensor noise and the UKFs) on 2 local workers into ``out/montecarlo``
    (the success rate is reported, not a failure of the demo)."""
    doc = run_montecarlo("com_observer_centred", 16, Path(out) / "montecarlo", workers=2, quiet=True)
    print(f"montecarlo com_observer_centred: {doc['n']} runs, success rate "
          f"{100 * doc['success_rate']:.1f} %; "
          f"report: {Path(out) / 'montecarlo' / 'report.md'}")
    return 0
