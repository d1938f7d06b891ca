"""``ballbot`` command line: one parser, each subcommand registered by its module.

Every command module here defines ``add_parser(subparsers)``, which adds its
subcommands; each subcommand parser sets ``func`` (called with the parsed arguments,
returns the exit code).
"""

from __future__ import annotations

import argparse
import sys

from ballbot_casadi.cli import analyze, commands, fmu, study
from ballbot_casadi.errors import BallbotError

__all__ = ["main", "build_parser"]

#: Modules that register subcommands, in ``--help`` order.
_COMMAND_MODULES = (commands, study, analyze, fmu)


def build_parser() -> argparse.ArgumentParser:
    """The top-level argument parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="ballbot", description="Ballbot model, analysis, control studies and FMUs."
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in _COMMAND_MODULES:
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``ballbot`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BallbotError as exc:
        print(f"ballbot {args.command}: error: {exc}", file=sys.stderr)
        return 2
