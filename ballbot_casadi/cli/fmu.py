"""``ballbot fmu build|info|validate|build-controller|ssp|cosim|container``: the plant FMU,
the controller FMU and the software-in-the-loop system (SSP, libcosim, container FMU)."""

from __future__ import annotations

import argparse
from pathlib import Path

from fmpy import dump
from fmpy.validation import validate_fmu

from ballbot_casadi.control import BALANCE_CONTROLLERS
from ballbot_casadi.core.files import check_input_file, check_output_dir
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.errors import PathError
from ballbot_casadi.fmi.build import build_fmu, validate_fmu_archive
from ballbot_casadi.fmi.system.container import CONTAINER_NAME, build_container
from ballbot_casadi.fmi.controller.controller import controller_spec
from ballbot_casadi.fmi.package import FMI_VERSIONS, build_fmu_from_spec
from ballbot_casadi.fmi.masters.ssp_run import MASTERS
from ballbot_casadi.fmi.system.sil import write_sil_ssp
from ballbot_casadi.fmi.system.ssp_check import MAX_STEPS
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, ESTIMATOR_FILTERS
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario
from ballbot_casadi.studies.sil import SIL_OUTPUTS, run_sil

__all__ = ["add_parser"]


def _default_fmu() -> Path:
    return build_root() / "fmu" / "BallbotPlant.fmu"


def _cmd_build(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_output_dir(args.out, "--out")
    b = build_fmu(args.out, fmi_version=args.fmi_version)
    print(f"{b.fmu}  (FMI {b.fmi_version}.0, GUID {b.guid}, cache {b.digest}, {b.status})")
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


def _default_ssp() -> Path:
    return build_root() / "fmu" / "BallbotSIL.ssp"


def _cmd_build_controller(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_output_dir(args.out, "--out")
    if args.scenario is not None:  # the path-following variant of a scenario with a [path]
        sc = load_scenario_file(resolve_scenario(args.scenario)).scenario
        spec = controller_spec(path=sc)
    else:
        spec = controller_spec(args.controller, args.estimator)
    b = build_fmu_from_spec(spec, args.out, fmi_version=args.fmi_version)
    print(f"{b.fmu}  (FMI {b.fmi_version}.0, GUID {b.guid}, cache {b.digest}, {b.status})")
    return 0


def _cmd_ssp(args: argparse.Namespace) -> int:
    out = Path(args.out) if args.out is not None else _default_ssp()
    check_output_dir(out.parent, "--out")
    plant = check_input_file(args.plant, "--plant") if args.plant else None
    source = load_scenario_file(resolve_scenario(args.scenario))
    sc = source.scenario if args.duration is None else source.scenario.replace(
        duration=args.duration)
    path = write_sil_ssp(sc, out, plant, specs=source.specs, source=str(source.path))
    guided = f", path following ({sc.guidance})" if sc.route.build() is not None else ""
    print(f"{path}  (scenario {sc.name}: {sc.controller}, estimator {sc.estimator}{guided}, "
          f"seed {sc.seed}, {sc.duration:g} s; plant {plant or 'BallbotPlant.fmu'})")
    return 0


def _cmd_cosim(args: argparse.Namespace) -> int:
    ssp = check_input_file(args.ssp, "SSP")
    check_output_dir(args.out, "--out", owned=SIL_OUTPUTS)
    result = run_sil(ssp, args.out, args.duration, args.master, plot=not args.no_plot,
                     compare=not args.no_compare, allow_long=args.allow_long)
    sil = result["sil"]
    line = (f"{args.out}: {sil['steps']} steps ({sil['master']}) in {sil['wall_s']:.3g} s; "
            f"specs {'passed' if result['passed'] else 'MISSED'}")
    if "vs_mission" in sil:
        v = sil["vs_mission"]
        line += (f"; vs the {v['reference']}: states {v['state_max']:.3g}, torques "
                 f"{v['tau_max']:.3g}")
    print(line)
    return 0 if result["passed"] else 1


def _cmd_container(args: argparse.Namespace) -> int:
    ssp = check_input_file(args.ssp, "SSP") if args.ssp else _default_ssp()
    if not Path(ssp).is_file():
        raise PathError(f"{ssp} does not exist; run 'make sil' (or 'ballbot fmu ssp') first")
    out = Path(args.out) if args.out else build_root() / "fmu" / f"{CONTAINER_NAME}.fmu"
    check_output_dir(out.parent, "--out")
    print(build_container(ssp, out))
    return 0


def _version_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fmi-version", type=int, choices=FMI_VERSIONS, default=2,
                   help="FMI version: 2 (default) or 3 (the same model behind FMI 3.0 entry "
                   "points)")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot fmu build|info|validate``."""
    p = sub.add_parser("fmu", help="the plant and controller FMUs and the software-in-the-loop "
                       "system (SSP, libcosim, container FMU)")
    fsub = p.add_subparsers(dest="fmu_command", required=True, metavar="ACTION")
    b = fsub.add_parser("build", help="build BallbotPlant.fmu (gcc)")
    b.add_argument("--out", default=None, help="output directory (default build/fmu, FMI 3.0: "
                   "build/fmu3)")
    _version_arg(b)
    b.set_defaults(func=_cmd_build)
    i = fsub.add_parser("info", help="print the FMU's model description")
    i.add_argument("fmu", nargs="?", help="FMU file (default build/fmu/BallbotPlant.fmu)")
    i.set_defaults(func=_cmd_info)
    v = fsub.add_parser("validate", help="validate the FMU with fmpy")
    v.add_argument("fmu", nargs="?", help="FMU file (default build/fmu/BallbotPlant.fmu)")
    v.set_defaults(func=_cmd_validate)
    c = fsub.add_parser("build-controller", help="build BallbotController.fmu (the embedded "
                        "software; other controller/estimator pairs as separate FMUs)")
    c.add_argument("--controller", default="flc", help="balance controller: "
                   + ", ".join(f"{n} (default)" if n == "flc" else n for n in BALANCE_CONTROLLERS))
    c.add_argument("--estimator", default=DEFAULT_ESTIMATOR, choices=list(ESTIMATOR_FILTERS),
                   help=f"filters (default {DEFAULT_ESTIMATOR})")
    c.add_argument("--scenario", default=None, help="a scenario file or shipped name with a "
                   "[path] (guidance mpc): build the path-following variant "
                   "BallbotControllerPath with its path, obstacles and gains as start values "
                   "(its controller and estimator replace --controller, --estimator)")
    c.add_argument("--out", default=None, help="output directory (default build/fmu, FMI 3.0: "
                   "build/fmu3)")
    _version_arg(c)
    c.set_defaults(func=_cmd_build_controller)
    s = fsub.add_parser("ssp", help="write the SIL system (plant + controller + reference FMUs, "
                        "connections, parameter set) as an SSP 1.0 archive")
    s.add_argument("--scenario", default="full_sine", help="scenario file or shipped name with "
                   "an estimator (default full_sine: roll sine, noise, QUKF + VUKF); one with a "
                   "[path] gets the path-following controller FMU (e.g. path_fig8_mpc_ukf)")
    s.add_argument("--plant", default=None, help="your plant FMU with the variable names of "
                   "BallbotPlant.fmu (default: BallbotPlant.fmu)")
    s.add_argument("--duration", type=float, default=None, help="simulated time (s; default the "
                   "scenario's)")
    s.add_argument("--out", default=None, help="the .ssp file (default build/fmu/BallbotSIL.ssp)")
    s.set_defaults(func=_cmd_ssp)
    k = fsub.add_parser("cosim", help="run an SSP in libcosim; log every connection, write "
                        "metrics.json, plots and report.md")
    k.add_argument("ssp", help="the .ssp file (e.g. build/fmu/BallbotSIL.ssp)")
    k.add_argument("--duration", type=float, default=None, help="simulated time (s; default "
                   "the SSP's stop time)")
    k.add_argument("--out", required=True, help="output directory")
    k.add_argument("--master", choices=MASTERS, default="libcosim", help="libcosim (default; "
                   "Jacobi: one period of actuation delay) or gauss-seidel (controller before "
                   "plant: the compiled mission exactly)")
    k.add_argument("--allow-long", action="store_true", help="run an SSP stop time beyond "
                   f"{MAX_STEPS} steps when --duration is not given (refused otherwise)")
    k.add_argument("--no-plot", action="store_true", help="skip the plots")
    k.add_argument("--no-compare", action="store_true", help="skip the comparison with the "
                   "compiled mission")
    k.set_defaults(func=_cmd_cosim)
    t = fsub.add_parser("container", help="build one container FMU of the SSP's FMUs (fmpy "
                        "container) for tools without SSP")
    t.add_argument("ssp", nargs="?", help="the .ssp file (default build/fmu/BallbotSIL.ssp)")
    t.add_argument("--out", default=None, help="the .fmu file (default "
                   "build/fmu/BallbotSILContainer.fmu)")
    t.set_defaults(func=_cmd_container)
