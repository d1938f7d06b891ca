"""``ballbot montecarlo SCENARIO --n N``: front end of :mod:`ballbot_casadi.studies.montecarlo_report`."""

from __future__ import annotations

import argparse
from pathlib import Path

from ballbot_casadi.studies.dask_cluster import check_scheduler_address
from ballbot_casadi.core.files import check_output_dir
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.studies.montecarlo_report import OWNED_OUTPUTS, run_montecarlo
from ballbot_casadi.studies.registry import parse_overrides, resolve_scenario

__all__ = ["add_parser"]


def _cmd_montecarlo(args: argparse.Namespace) -> int:
    path = resolve_scenario(args.scenario)
    if args.scheduler is not None:
        check_scheduler_address(args.scheduler)
    if args.n < 1:
        raise ScenarioError(f"--n must be >= 1, got {args.n}")
    if not 0.0 <= args.min_success <= 1.0:
        raise ScenarioError(f"--min-success must be within [0, 1], got {args.min_success}")
    if args.workers < 0:
        raise ScenarioError(f"--workers must be >= 0 (0 = serial in this process), got {args.workers}")
    out = Path(args.out) if args.out else Path("build") / "montecarlo" / path.stem
    check_output_dir(out, "--out", owned=OWNED_OUTPUTS)
    doc = run_montecarlo(path, args.n, out, args.scheduler, args.workers, args.quiet, args.seed,
                         parse_overrides(args.set or []), resume=args.resume)
    if not args.quiet:
        print(f"montecarlo {doc['name']}: {doc['n']} runs, success rate {100 * doc['success_rate']:.1f} %")
        for s in doc["specs"]:
            print(f"  {s['metric']} {s['op']} {s['threshold']}: {100 * s['pass_rate']:.1f} % pass")
        for w in doc["worst"][:3]:
            print(f"  worst: run {w['index']} (noise seed {w['seed']}): ballbot simulate {out / w['file']}")
        print(f"written to {out} (montecarlo.json, histograms.png, scatter.png, worst/, report.md)")
    if doc["success_rate"] < args.min_success:  # specs missed (a NaN run or a fall counts)
        if not args.quiet:
            print(f"montecarlo {doc['name']}: FAIL: success rate {100 * doc['success_rate']:.1f} % "
                  f"below --min-success {100 * args.min_success:g} %")
        return 1
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot montecarlo``."""
    p = sub.add_parser(
        "montecarlo",
        help="run a scenario file many times with dispersed parameters (Dask)",
        description="Disperse a scenario file (its [montecarlo] table, or the default set: body "
        "mass 5 %% and inertias 10 %% (1 sigma), COM offset 5 mm and height 1 cm, viscous frictions "
        "uniform, initial roll/pitch uniform +-1 deg, a sensor-noise seed per run) and run it on a "
        "Dask LocalCluster (default), an existing cluster (--scheduler) or serially (--workers 0). "
        "Writes success rates against the file's specs, histograms, scatter plots and the worst "
        "runs as scenario files rerunnable with `ballbot simulate`.",
    )
    p.add_argument("scenario", help="scenario file (.toml) or the name of a shipped one (e.g. com)")
    p.add_argument("--n", type=int, required=True, help="number of runs")
    p.add_argument("--scheduler", metavar="ADDRESS", help="existing Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--workers", type=int, default=2,
                   help="LocalCluster worker processes (default 2; 0 = serial in this process)")
    p.add_argument("--seed", type=int, help="set seed (default: the file's montecarlo.seed)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="change a key of the scenario before dispersing, e.g. duration_s=5")
    p.add_argument("--out", help="output directory (default build/montecarlo/<file name>)")
    p.add_argument("--min-success", type=float, default=1.0, metavar="RATE",
                   help="exit 1 when the fraction of runs meeting every spec is below RATE "
                        "(default 1: every run; a NaN run or a fall never meets them)")
    p.add_argument("--resume", action="store_true",
                   help="reuse the finished runs of a partial montecarlo.json in --out (a run "
                        "stopped by a cluster that lost its workers, exit 3) and run only the missing ones")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=_cmd_montecarlo)
