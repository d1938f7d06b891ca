"""``ballbot animate RUN.npz -o run.gif``: front end of :mod:`ballbot_casadi.studies.animate`."""

from __future__ import annotations

import argparse

from ballbot_casadi.core.files import check_input_file, check_output_file
from ballbot_casadi.studies.animate import animate

__all__ = ["add_parser"]


def _cmd_animate(args: argparse.Namespace) -> int:
    check_input_file(args.run, "RUN")
    check_output_file(args.output, "-o")
    path = animate(args.run, args.output, fps=args.fps, max_frames=args.max_frames)
    if not args.quiet:
        print(f"written {path}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot animate``."""
    p = sub.add_parser("animate", help="3D animation of a run log (GIF, or MP4 with ffmpeg)",
                       description="Render a run.npz written by study/simulate as a 3D view of the "
                       "ball, the body axes, the heading, the path and the time (headless).")
    p.add_argument("run", help="run log (.npz) written by ballbot study or ballbot simulate")
    p.add_argument("-o", "--output", default="run.gif", help="output .gif or .mp4 (default run.gif)")
    p.add_argument("--fps", type=float, default=15.0, help="frames per simulated second (default 15)")
    p.add_argument("--max-frames", type=int, default=200, help="at most this many frames (default 200)")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=_cmd_animate)
