"""``ballbot simulate SCENARIO``: run one scenario file (:mod:`ballbot_casadi.sim.scenario`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ballbot_casadi.core.files import check_input_file, check_output_dir
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario
from ballbot_casadi.studies.study import MAX_LONG_RUN_S, OWNED_OUTPUTS, format_summary, run_file, with_duration

__all__ = ["add_parser"]


def _cmd_simulate(args: argparse.Namespace) -> int:
    path = resolve_scenario(args.scenario)
    if args.params is not None:
        check_input_file(args.params, "--params")
    out = Path(args.out) if args.out else Path("build") / "simulate" / path.stem
    check_output_dir(out, "--out", owned=OWNED_OUTPUTS)
    source = load_scenario_file(path)
    if args.log_every < 1:
        raise ScenarioError(f"--log-every must be >= 1, got {args.log_every}")
    if args.duration is not None:  # long runs beyond the file format's hour, decimated
        source = with_duration(source, args.duration, args.log_every)
    result = run_file(source, out, plot=not args.no_plot,
                      params=load_params(args.params) if args.params else None,
                      log_every=args.log_every)
    if not args.quiet:
        print(format_summary(result))
        print(f"written to {out} (metrics.json, run.npz, plot.png, report.md)")
    return 0 if result["passed"] else 1


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot simulate``."""
    p = sub.add_parser(
        "simulate",
        help="run one scenario file (TOML); exit 1 if one of its [[spec]] rows is missed",
        description="Run the closed loop described by a scenario file (see `ballbot study --list` "
        "for the shipped ones; copy one and edit it). Unknown keys, wrong types and impossible "
        "values are rejected with the file, the key and the reason (exit 2).",
    )
    p.add_argument("scenario", help="scenario file (.toml) or the name of a shipped one")
    p.add_argument("--out", help="output directory (default build/simulate/<file name>)")
    p.add_argument("--params", metavar="FILE", help="parameter TOML file: another robot")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    p.add_argument("--log-every", type=int, default=1, metavar="M",
                   help="keep every M-th control period in the log and run the mission in 60 s "
                        "segments: the log's memory per simulated second is divided by M (default 1; "
                        "measured sizes in the README)")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help=f"run S seconds instead of the file's duration_s, up to {MAX_LONG_RUN_S:g} s "
                        "(beyond one hour at 5 ms with --log-every M keeping at most 720000 periods)")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=_cmd_simulate)
