"""``ballbot study``: command-line front end of :mod:`ballbot_casadi.studies.study`."""

from __future__ import annotations

import argparse
from pathlib import Path

from ballbot_casadi.core.files import check_output_dir
from ballbot_casadi.studies.registry import STUDY_NAMES
from ballbot_casadi.studies.study import CONTROLLERS, format_summary, run_all, run_study

__all__ = ["add_parser"]


def _cmd_study(args: argparse.Namespace) -> int:
    if args.out:
        check_output_dir(args.out, "--out")
    if args.name == "all":
        table = run_all(Path(args.out) if args.out else None, plot=not args.no_plot)
        ok = True
        for res in table.values():
            for r in res.values():
                ok &= r["passed"]
                if not args.quiet:
                    print(format_summary(r))
        return 0 if ok else 1
    result = run_study(args.name, args.controller, Path(args.out) if args.out else None,
                       plot=not args.no_plot)
    if not args.quiet:
        print(format_summary(result))
    return 0 if result["passed"] else 1


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot study <name>``."""
    p = sub.add_parser(
        "study",
        help="run a closed-loop acceptance study (exit 1 if its spec is not met, 2 on bad input)",
        description="Closed-loop acceptance studies (issue 4): " + ", ".join(STUDY_NAMES)
        + "; 'all' runs every study for flc and smc.",
    )
    p.add_argument("name", choices=[*STUDY_NAMES, "all"])
    p.add_argument("--controller", choices=CONTROLLERS, default="flc")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.add_argument("--out", help="output directory (default build/study/<name>/<controller>)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    p.set_defaults(func=_cmd_study)
