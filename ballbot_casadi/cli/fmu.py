"""``ballbot fmu build|info|validate``: build and check the native plant FMU."""

from __future__ import annotations

import argparse
from pathlib import Path

from fmpy import dump
from fmpy.validation import validate_fmu

from ballbot_casadi.core.files import check_input_file, check_output_dir
from ballbot_casadi.errors import PathError
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.fmi.build import build_fmu, validate_fmu_archive

__all__ = ["add_parser"]


def _default_fmu() -> Path:
    return build_root() / "fmu" / "BallbotPlant.fmu"


def _cmd_build(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_output_dir(args.out, "--out")
    b = build_fmu(args.out)
    print(f"{b.fmu}  (GUID {b.guid}, cache {b.digest}, {b.status})")
    return 0


def _fmu_arg(args: argparse.Namespace) -> Path:
    """The FMU to inspect: the positional argument or the default build (checked)."""
    if args.fmu:
        return check_input_file(args.fmu, "FMU")
    path = _default_fmu()
    if not path.is_file():
        raise PathError(f"{path} does not exist; run 'ballbot fmu build' first")
    return path


def _cmd_info(args: argparse.Namespace) -> int:
    path = _fmu_arg(args)
    validate_fmu_archive(path, require_binary=False)
    dump(str(path))
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    path = _fmu_arg(args)
    # a broken zip is a clear error, not an fmpy traceback
    validate_fmu_archive(path, require_binary=False)
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
