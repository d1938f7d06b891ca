"""``ballbot`` command line: one parser, each subcommand registered by its module.

Every command module here defines ``add_parser(subparsers)``, which adds its
subcommands; each subcommand parser sets ``func`` (called with the parsed arguments,
returns the exit code).  Command functions check their paths first
(:func:`~ballbot_casadi.core.files.check_output_dir`,
:func:`~ballbot_casadi.core.files.check_input_file`) so that a bad path fails before any
computation.

Exit codes (also in ``ballbot --help``): 0 success; 1 a study or check ran but missed its
specification; 2 user error (bad option, path or value: one line on stderr); 3 internal
failure: the C toolchain, a co-simulation engine or a bug (one line; the traceback with
``--debug``); 130 interrupted.  A :class:`~ballbot_casadi.errors.BallbotError` carries its
own exit code (``exit_code``, by kind of failure).
"""

from __future__ import annotations

import argparse
import sys
import traceback
from typing import NoReturn

from ballbot_casadi.cli import analyze, animate, commands, firmware, fmu, montecarlo, simulate, study
from ballbot_casadi.errors import EXIT_INTERNAL_ERROR, EXIT_USER_ERROR, BallbotError

__all__ = ["main", "build_parser", "EXIT_OK", "EXIT_SPEC_MISSED", "EXIT_USER_ERROR",
           "EXIT_INTERNAL_ERROR"]

#: Modules that register subcommands, in ``--help`` order.
_COMMAND_MODULES = (commands, study, simulate, montecarlo, animate, analyze, fmu, firmware)

EXIT_OK = 0
EXIT_SPEC_MISSED = 1
EXIT_INTERRUPTED = 130

_EPILOG = """\
exit codes:
  0    success
  1    a study or check ran but missed its specification
  2    user error: bad option, path, parameter or operating point (one line on stderr)
  3    internal failure: C toolchain, co-simulation engine or a bug (one line on
       stderr; add --debug for the traceback)
  130  interrupted (Ctrl-C)
"""


class _Parser(argparse.ArgumentParser):
    """Argument parser whose usage errors are one line on stderr and exit code 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _add_debug(parser: argparse.ArgumentParser, top: bool) -> None:
    """Add ``--debug`` to ``parser`` and to every subcommand below it."""
    parser.add_argument("--debug", action="store_true",
                        default=False if top else argparse.SUPPRESS,
                        help="on an internal failure, print the full traceback")
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _add_debug(sub, top=False)


def build_parser() -> argparse.ArgumentParser:
    """The top-level argument parser with every registered subcommand."""
    parser = _Parser(
        prog="ballbot", description="Ballbot model, analysis, control studies and FMUs.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=_Parser)
    for module in _COMMAND_MODULES:
        module.add_parser(sub)
    _add_debug(parser, top=True)
    return parser


def _one_line(exc: BaseException) -> str:
    """The first line of an exception's message (BuildErrors carry compiler output)."""
    text = str(exc).strip()
    first = text.splitlines()[0] if text else type(exc).__name__
    return first + (" [more with --debug]" if len(text.splitlines()) > 1 else "")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``ballbot`` console script; returns the exit code (see module doc)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    where = f"ballbot {args.command}"
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print(f"{where}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BallbotError as exc:
        if args.debug:
            traceback.print_exc()
        print(f"{where}: error: {_one_line(exc)}", file=sys.stderr)
        return exc.exit_code
    except OSError as exc:  # a path the checks could not foresee (disk full, removed, ...)
        if args.debug:
            traceback.print_exc()
        name = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"{where}: error:{name} {exc.strerror or exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except Exception as exc:  # noqa: BLE001 - the documented exit code 3
        text = str(exc).strip()
        first = f"{type(exc).__name__}: {text.splitlines()[0]}" if text else type(exc).__name__
        if args.debug:
            traceback.print_exc()
            print(f"{where}: internal error: {first}", file=sys.stderr)
        else:
            print(f"{where}: internal error: {first} (run with --debug for the traceback)",
                  file=sys.stderr)
        return EXIT_INTERNAL_ERROR
