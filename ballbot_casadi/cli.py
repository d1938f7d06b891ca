"""``ballbot`` command line: one subcommand per module, registered in :data:`COMMANDS`.

Each command module defines ``add_parser(subparsers)``, which adds its subcommands; each
subcommand parser sets ``func`` (called with the parsed arguments, returns the exit code).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from types import MappingProxyType
from typing import Mapping

from .errors import BallbotError

__all__ = ["main", "COMMANDS"]

#: subcommand -> module defining ``add_parser``.
COMMANDS: Mapping[str, str] = MappingProxyType({
    "codegen": "ballbot_casadi.commands",
    "summary": "ballbot_casadi.commands",
    "bench": "ballbot_casadi.commands",
    "demo": "ballbot_casadi.commands",
    "study": "ballbot_casadi.studies.study",
    "fmu": "ballbot_casadi.fmu_cli",
    "analyze": "ballbot_casadi.studies.analyze",
})


def build_parser() -> argparse.ArgumentParser:
    """The top-level argument parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="ballbot", description="Ballbot model, analysis, control studies and FMUs."
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in dict.fromkeys(COMMANDS.values()):
        importlib.import_module(module).add_parser(sub)
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


if __name__ == "__main__":
    sys.exit(main())
