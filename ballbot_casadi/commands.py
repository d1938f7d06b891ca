"""Core ``ballbot`` subcommands: ``codegen``, ``summary``, ``bench`` and ``demo``."""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path
from types import MappingProxyType
from typing import Callable, Mapping

import numpy as np

from .params import load_params

__all__ = ["add_parser", "model_summary", "DEMO_STEPS", "CODEGEN_LIBRARIES"]

#: Libraries built by ``ballbot codegen``: name -> "module:function" returning the list of
#: CasADi Functions to export.
CODEGEN_LIBRARIES: Mapping[str, str] = MappingProxyType({
    "ballbot_model": "ballbot_casadi.codegen:model_functions_list",
    "ballbot_control": "ballbot_casadi.control_library:control_codegen_functions",
})


def _resolve(spec: str) -> Callable:
    module, _, attr = spec.partition(":")
    return getattr(importlib.import_module(module), attr)


def run_codegen(root: Path | None = None) -> dict[str, object]:
    """Generate and compile every library of :data:`CODEGEN_LIBRARIES`."""
    from .codegen import build_library

    return {name: build_library(name, _resolve(spec)(), root) for name, spec in CODEGEN_LIBRARIES.items()}


def model_summary(params_path: str | None = None) -> str:
    """Sizes and upright-equilibrium eigenvalues of the model, as text."""
    from .model import NP, NU, NX
    from .robot import BallbotModel

    params = load_params(params_path)
    model = BallbotModel(params)
    A, _ = model.linearize(model.upright(), np.zeros(3))
    eig = np.linalg.eigvals(A)
    eig = eig[np.argsort(-eig.real)]
    lines = [
        f"states: {NX}  inputs: {NU}  parameters: {NP}",
        "upright equilibrium eigenvalues (rad/s):",
        *[f"  {e.real:+.6f}{e.imag:+.6f}j" for e in eig],
    ]
    return "\n".join(lines)


def _cmd_codegen(args: argparse.Namespace) -> int:
    for name, lib in run_codegen().items():
        print(f"{name}: {lib.source}  ->  {lib.shared}, {lib.static}")
    return 0


def _cmd_summary(args: argparse.Namespace) -> int:
    print(model_summary(args.params))
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from .bench import run_benchmarks

    results = run_benchmarks(Path(args.out), args.only)
    for key, value in sorted(results.items()):
        print(f"{key:28s} {value:.6g}" if isinstance(value, float) else f"{key:28s} {value}")
    print(f"written to {args.out}")
    return 0


def _step_codegen(out: Path) -> int:
    _cmd_codegen(argparse.Namespace())
    print(model_summary())
    return 0


#: Steps of ``ballbot demo`` in order: (title, "module:function" taking the output dir).
DEMO_STEPS: tuple[tuple[str, str], ...] = (
    ("generate and compile C, model summary", "ballbot_casadi.commands:_step_codegen"),
    (
        "linear analysis: minimal model, controllability, RHP zeros, bandwidths",
        "ballbot_casadi.studies.analyze:demo_step",
    ),
    (
        "closed loop: roll sine 3 deg 0.5 Hz (thesis 8.2.5)",
        "ballbot_casadi.studies.study:demo_sine",
    ),
    (
        "closed loop: COM offset, runaway and velocity loop (thesis 8.4.2, 9.2)",
        "ballbot_casadi.studies.study:demo_com",
    ),
    (
        "plant FMU: build BallbotPlant.fmu and co-simulate it in fmpy",
        "ballbot_casadi.fmu_cli:demo_step",
    ),
    ("report", "ballbot_casadi.studies.report:demo_step"),
)


def _cmd_demo(args: argparse.Namespace) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    status = 0
    for title, spec in DEMO_STEPS:
        print(f"\n=== {title} ===", flush=True)
        rc = int(_resolve(spec)(out) or 0)
        if rc:
            print(f"step failed with exit code {rc}: {title}")
            status = rc
    print(f"\ndemo outputs in {out}")
    return status


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``codegen``, ``summary``, ``bench`` and ``demo``."""
    p = sub.add_parser("codegen", help="generate C code and compile the libraries under build/")
    p.set_defaults(func=_cmd_codegen)
    p = sub.add_parser("summary", help="print model sizes and upright eigenvalues")
    p.add_argument("--params", help="parameter TOML file (default: thesis App. A)")
    p.set_defaults(func=_cmd_summary)
    p = sub.add_parser("bench", help="run benchmarks and write a JSON file")
    p.add_argument("--out", default="build/bench.json")
    p.add_argument("--only", nargs="*", help="benchmark groups to run (default: all)")
    p.set_defaults(func=_cmd_bench)
    p = sub.add_parser("demo", help="the main job: build, analyse, simulate, report")
    p.add_argument("--out", default="build/demo")
    p.set_defaults(func=_cmd_demo)
