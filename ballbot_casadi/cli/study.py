"""``ballbot study`` and ``ballbot simulate``: front ends of :mod:`ballbot_casadi.studies.study`."""

from __future__ import annotations

import argparse
from pathlib import Path

from ballbot_casadi.core.files import check_input_file, check_output_dir
from ballbot_casadi.core.params import load_params
from ballbot_casadi.control import BALANCE_CONTROLLERS
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.scenario import ESTIMATOR_CHOICES, FEEDFORWARD_MODES, TORQUE_LIMIT_MODES
from ballbot_casadi.studies import chirp as chirp_study
from ballbot_casadi.studies.registry import (
    STUDIES,
    STUDY_NAMES,
    parse_overrides,
    shipped_scenarios,
)
from ballbot_casadi.studies.extra import EXTRA_DESCRIPTIONS, EXTRA_STUDIES, run_extra_study
from ballbot_casadi.studies.study import (
    CONTROLLERS,
    DEFAULT_OUT,
    OWNED_OUTPUTS,
    format_summary,
    run_all,
    run_study,
    run_thesis,
)

__all__ = ["add_parser", "list_text"]


def list_text() -> str:
    """``ballbot study --list``: the studies and the shipped scenario files."""
    lines = ["studies (ballbot study NAME):"]
    lines += [f"  {n:12s} {s.description}  [files: {', '.join(f + '.toml' for f in s.files)}]"
              for n, s in STUDIES.items()]
    lines += [f"  {n:12s} {d}" for n, d in EXTRA_DESCRIPTIONS.items()]
    lines.append("shipped scenario files (copy one, edit it, run it with `ballbot simulate FILE`):")
    lines += [f"  {p}" for p in shipped_scenarios().values()]
    return "\n".join(lines)


def _cmd_study(args: argparse.Namespace) -> int:
    if args.list:
        print(list_text())
        return 0
    if args.name is None:
        raise ScenarioError("give a study name (or --list); studies: "
                            + ", ".join([*STUDY_NAMES, *EXTRA_STUDIES]))
    if args.name in EXTRA_STUDIES:
        return _cmd_extra(args)
    if args.params is not None:
        check_input_file(args.params, "--params")
    if args.out:
        check_output_dir(args.out, "--out", owned=None if args.name == "all" else OWNED_OUTPUTS)
    params = load_params(args.params) if args.params else None
    overrides = parse_overrides(args.set or [])
    overrides += [(k, v) for k, v in (("estimator", args.estimator), ("seed", args.seed),
                                      ("feedforward", args.feedforward),
                                      ("torque_limit", args.torque_limit)) if v is not None]
    if (args.axis or args.amplitude is not None) and args.name != "chirp":
        raise ScenarioError("--axis and --amplitude apply to the chirp study only")
    if args.amplitude is not None and not 0 < args.amplitude <= 45:
        raise ScenarioError(f"--amplitude must be in (0, 45] deg, got {args.amplitude:g}")
    if args.name == "chirp" and (args.axis or args.amplitude is not None):
        table = STUDIES["chirp"].tables(args.controller, overrides)[-1]
        overrides += chirp_study.axis_overrides(table, args.axis, args.amplitude)
    if args.name == "thesis":
        if overrides or params is not None or args.controller != "flc":
            raise ScenarioError("--set, --estimator, --seed, --feedforward, --torque-limit, --params and "
                                "--controller do not apply to 'thesis': it reads the studies as shipped")
        res = run_thesis(Path(args.out) if args.out else None, rerun=args.rerun, plot=not args.no_plot)
        if not args.quiet:
            print("thesis table: " + ", ".join(f"{n} {v}" for v, n in res["counts"].items())
                  + ("" if res["passed"] else f"; metrics missing for: {', '.join(res['missing'])}"))
        return 0 if res["passed"] else 1
    if args.name == "all":
        if overrides or params is not None:
            raise ScenarioError("--set, --estimator, --seed, --feedforward, --torque-limit and --params apply to one "
                                "study, not to 'all'")
        table = run_all(Path(args.out) if args.out else None, plot=not args.no_plot)
        ok = True
        for res in table.values():
            for r in res.values():
                ok &= r["passed"]
                if not args.quiet:
                    print(format_summary(r))
        return 0 if ok else 1
    result = run_study(args.name, args.controller, Path(args.out) if args.out else None,
                       plot=not args.no_plot, overrides=overrides, params=params)
    if not args.quiet:
        print(format_summary(result))
    return 0 if result["passed"] else 1


def _cmd_extra(args: argparse.Namespace) -> int:
    """The studies of :mod:`ballbot_casadi.studies.extra` (no scenario options)."""
    given = [o for o, v in (("--set", args.set), ("--params", args.params),
                            ("--estimator", args.estimator), ("--seed", args.seed),
                            ("--feedforward", args.feedforward)) if v]
    if given:
        raise ScenarioError(f"{', '.join(given)} do not apply to the {args.name} study")
    out = Path(args.out) if args.out else DEFAULT_OUT / args.name
    if args.out:
        check_output_dir(args.out, "--out", owned=OWNED_OUTPUTS)
    m = run_extra_study(args.name, out, plot=not args.no_plot)
    if not args.quiet:
        print(f"{args.name}: {'PASS' if m['passed'] else 'FAIL'}  ({out / 'report.md'})")
    return 0 if m["passed"] else 1


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot study <name>``."""
    p = sub.add_parser(
        "study",
        help="run a closed-loop study (exit 1 if its spec is not met, 2 on bad input)",
        description="Closed-loop studies of the thesis: " + ", ".join(STUDY_NAMES)
        + "; 'all' runs every study for flc and smc; 'thesis' tables every result of thesis chapters 6-9 "
        "beside ours (from the studies' metrics.json, running the missing ones). Each writes metrics.json, run.npz, plots and "
        "report.md (specs with the thesis's value beside ours; thesis §7.1 limits reported).",
    )
    p.add_argument("name", nargs="?", choices=[*STUDY_NAMES, *EXTRA_STUDIES, "all", "thesis"])
    p.add_argument("--list", action="store_true", help="list the studies and shipped scenario files")
    p.add_argument("--controller", choices=tuple(BALANCE_CONTROLLERS), default="flc",
                   help=f"balance controller of the runs (default flc; 'all' runs "
                        f"{' and '.join(CONTROLLERS)})")
    p.add_argument("--params", metavar="FILE", help="parameter TOML file: another robot, known to the controller")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="change a scenario-file key of every run, e.g. duration_s=20 or "
                        "attitude.roll.amplitude_deg=5 (repeatable)")
    p.add_argument("--estimator", choices=ESTIMATOR_CHOICES,
                   help="what the controllers read: the true state, or noisy sensors with the "
                        "QUKF + VUKF (ukf: the thesis's filters; ukf_adaptive: the consistent velocity "
                        "filter) or the predecessor's EKFs (ekf); default: the study's files (true for "
                        "the thesis's controller studies, ukf_adaptive for 'estimators', 'full', 'com')")
    p.add_argument("--seed", type=int, metavar="N", help="sensor-noise seed (default: the study's files)")
    p.add_argument("--feedforward", choices=FEEDFORWARD_MODES,
                   help="balance controller feed-forward: exact reference acceleration, or none (the "
                        "thesis's FLC 8.44 and SMC); default: the study's files")
    p.add_argument("--torque-limit", choices=TORQUE_LIMIT_MODES,
                   help="the controller's torque limit: direction-preserving (ours) or per-wheel "
                        "clipping only (the thesis's set-up, §9.1); default: the study's files")
    p.add_argument("--axis", choices=("roll", "pitch"), help="chirp: the excited axis (default roll)")
    p.add_argument("--amplitude", type=float, metavar="DEG", help="chirp: amplitude in deg (default 3)")
    p.add_argument("--rerun", action="store_true",
                   help="thesis: rerun every study instead of reading its metrics.json")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.add_argument("--out", help="output directory (default build/study/<name>/<controller>)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plots")
    p.set_defaults(func=_cmd_study)
