"""``ballbot analyze``: command-line front end of :mod:`ballbot_casadi.studies.analyze`."""

from __future__ import annotations

import argparse

from ballbot_casadi.core.files import check_input_file, check_output_dir
from ballbot_casadi.studies.analyze import OWNED_OUTPUTS, run_analysis, summary_text

__all__ = ["add_parser"]


def _cmd_analyze(args: argparse.Namespace) -> int:
    if args.params is not None:
        check_input_file(args.params, "--params")
    check_output_dir(args.out, "--out", owned=OWNED_OUTPUTS)
    result = run_analysis(args.out, args.params, args.at, plots=not args.no_plots, compiled=args.compiled)
    print(summary_text(result))
    print(f"written: {', '.join(result['files'])}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot analyze``."""
    p = sub.add_parser(
        "analyze",
        help="linearise, reduce, controllability, poles/zeros, bandwidths; JSON + Markdown + plots",
        description="Linearise the ballbot at an operating point, reduce it to the minimal "
        "10-state model, test controllability, compute poles/zeros of the wheel-torque channels "
        "and the cascade bandwidths; write analysis.json, analysis.md and PNG plots to --out.",
    )
    p.add_argument("--params", help="parameter TOML file (default: thesis App. A)")
    p.add_argument(
        "--at",
        metavar="STATE",
        help="operating point: key=value pairs (x, y [m], dx, dy [m/s], roll, pitch, yaw [deg]), "
        "e.g. 'yaw=30', or 12 comma-separated numbers (full state); default: balanced at rest",
    )
    p.add_argument("--out", default="build/analysis", help="output directory (default build/analysis)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--compiled", action="store_true",
                   help="use the compiled C model library for the plant Jacobians (built if needed)")
    p.set_defaults(func=_cmd_analyze)
