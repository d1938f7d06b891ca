"""``ballbot fmu build|info|validate``: build and check the native plant FMU."""

from __future__ import annotations

import argparse
from pathlib import Path

from fmpy import dump
from fmpy.validation import validate_fmu

from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.fmi.build import build_fmu

__all__ = ["add_parser"]


def _default_fmu() -> Path:
    return build_root() / "fmu" / "BallbotPlant.fmu"


def _cmd_build(args: argparse.Namespace) -> int:
    b = build_fmu(args.out)
    print(f"{b.fmu}  (GUID {b.guid}, cache {b.digest})")
    return 0


def _cmd_info(args: argparse.Namespace) -> int:
    path = Path(args.fmu) if args.fmu else _default_fmu()
    if not path.is_file():
        print(f"{path} does not exist; run 'ballbot fmu build' first")
        return 1
    dump(str(path))
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    path = Path(args.fmu) if args.fmu else _default_fmu()
    if not path.is_file():
        print(f"{path} does not exist; run 'ballbot fmu build' first")
        return 1
    problems = validate_fmu(str(path))
    for p in problems:
        print(f"problem: {p}")
    print(f"{path}: {'valid' if not problems else f'{len(problems)} problem(s)'}")
    return 1 if problems else 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot fmu build|info|validate``."""
    p = sub.add_parser("fmu", help="build, describe and validate the native plant FMU")
    fsub = p.add_subparsers(dest="fmu_command", required=True, metavar="ACTION")
    b = fsub.add_parser("build", help="build BallbotPlant.fmu (gcc)")
    b.add_argument("--out", default=None, help="output directory (default build/fmu)")
    b.set_defaults(func=_cmd_build)
    i = fsub.add_parser("info", help="print the FMU's model description")
    i.add_argument("fmu", nargs="?", help="FMU file (default build/fmu/BallbotPlant.fmu)")
    i.set_defaults(func=_cmd_info)
    v = fsub.add_parser("validate", help="validate the FMU with fmpy")
    v.add_argument("fmu", nargs="?", help="FMU file (default build/fmu/BallbotPlant.fmu)")
    v.set_defaults(func=_cmd_validate)
