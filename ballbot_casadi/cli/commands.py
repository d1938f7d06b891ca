"""Core ``ballbot`` subcommands: ``codegen``, ``summary``, ``bench`` and ``demo``."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Callable

from ballbot_casadi.bench import BENCHMARKS, run_benchmarks
from ballbot_casadi.codegen.libraries import run_codegen
from ballbot_casadi.core.files import (
    check_input_file,
    check_output_dir,
    check_output_file,
)
from ballbot_casadi.core.params import load_params
from ballbot_casadi.model.linearization import model_summary
from ballbot_casadi.studies import analyze, fmu_demo, montecarlo_report, report, study

__all__ = ["add_parser", "DEMO_STEPS"]


def _cmd_codegen(args: argparse.Namespace) -> int:
    # build_library verifies every cached file against its manifest and rebuilds it if needed
    for name, lib in run_codegen().items():
        print(f"{name} ({lib.status}): {lib.source}  ->  {lib.shared}, {lib.static}")
    return 0


def _cmd_summary(args: argparse.Namespace) -> int:
    if args.params is not None:
        check_input_file(args.params, "--params")
    print(model_summary(load_params(args.params)))
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    check_output_file(args.out, "--out")
    results = run_benchmarks(Path(args.out), args.only)
    for key, value in sorted(results.items()):
        print(f"{key:28s} {value:.6g}" if isinstance(value, float) else f"{key:28s} {value}")
    print(f"written to {args.out}")
    return 0


def _step_codegen(out: Path) -> int:
    _cmd_codegen(argparse.Namespace())
    print(model_summary(load_params()))
    return 0


#: Steps of ``ballbot demo`` in order: (title, function taking the output directory).
DEMO_STEPS: tuple[tuple[str, Callable[[Path], int]], ...] = (
    ("generate and compile C, model summary", _step_codegen),
    ("linear analysis: minimal model, controllability, RHP zeros, bandwidths", analyze.demo_step),
    ("closed loop: roll sine 3 deg 0.5 Hz (thesis 8.2.5)", study.demo_sine),
    ("closed loop: COM offset, runaway and velocity loop (thesis 8.4.2, 9.2)", study.demo_com),
    ("closed loop: chirp bandwidth test (thesis 9.1)", study.demo_chirp),
    ("complete system: noisy sensors, QUKF + VUKF, FLC in the thesis mode, beside SMC + EKF "
     "(thesis 9.3, 9.4)", study.demo_full),
    ("Monte Carlo: 16 random COM offsets, estimated online, noise and UKFs, on 2 Dask workers",
     montecarlo_report.demo_step),
    ("plant FMU: build BallbotPlant.fmu and co-simulate it in fmpy", fmu_demo.demo_step),
    ("report", report.demo_step),
)


def _cmd_demo(args: argparse.Namespace) -> int:
    out = check_output_dir(args.out, "--out")
    out.mkdir(parents=True, exist_ok=True)
    # the report is written last: a demo that stops midway leaves no stale report behind
    (out / "report.md").unlink(missing_ok=True)
    status = 0
    for title, step in DEMO_STEPS:
        print(f"\n=== {title} ===", flush=True)
        rc = int(step(out) or 0)
        if rc:
            print(f"step failed with exit code {rc}: {title}")
            status = rc
    print(f"\ndemo outputs in {out}")
    return status


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``codegen``, ``summary``, ``bench`` and ``demo``."""
    p = sub.add_parser("codegen", help="generate C code and compile the libraries under build/")
    p.set_defaults(func=_cmd_codegen)
    p = sub.add_parser("summary", help="print model sizes and the equilibrium eigenvalues")
    p.add_argument("--params", help="parameter TOML file (default: thesis App. A)")
    p.set_defaults(func=_cmd_summary)
    p = sub.add_parser("bench", help="run benchmarks and write a JSON file")
    p.add_argument("--out", default="build/bench.json", help="JSON file (default build/bench.json)")
    p.add_argument("--only", nargs="*", choices=list(BENCHMARKS), metavar="GROUP",
                   help=f"benchmark groups to run: {', '.join(BENCHMARKS)} (default: all)")
    p.set_defaults(func=_cmd_bench)
    p = sub.add_parser("demo", help="the main job: build, analyse, simulate, report")
    p.add_argument("--out", default="build/demo", help="output directory (default build/demo)")
    p.set_defaults(func=_cmd_demo)
