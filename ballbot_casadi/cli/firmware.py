"""``ballbot firmware``: the Cortex-M7 firmware library of the embedded software, optionally
verified in QEMU against the host (issue 21)."""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

import numpy as np

from ballbot_casadi.core.files import check_output_dir
from ballbot_casadi.firmware.build import build_firmware
from ballbot_casadi.firmware.cost import CLOCK_HZ_MAX, firmware_cost, guided_cost, split_cost
from ballbot_casadi.firmware.replay import (
    GUIDED_REPLAY_ATOL,
    REPLAY_ATOL,
    record_guided_log,
    record_log,
    replay_scenario,
    run_host,
    run_qemu,
)
from ballbot_casadi.firmware.sources import SPLIT_LATENCY, firmware_guidance, guidance_every
from ballbot_casadi.firmware.toolchain import PRECISIONS, ToolchainMissing
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, ESTIMATOR_FILTERS
from ballbot_casadi.sim.guided import GUIDANCE_LAWS

__all__ = ["add_parser"]


def _cmd_firmware(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_output_dir(args.out, "--out")
    if args.latency and args.guidance != "mpc":
        print(f"ballbot firmware: error: --latency {args.latency} needs --guidance mpc (the "
              "background sample is the MPC's)", file=sys.stderr)
        return 2
    try:
        fw = build_firmware(args.controller, args.estimator, args.precision, guidance=args.guidance,
                            latency=args.latency)
        print(f"{fw.library}  ({fw.status})\n  headers {fw.include}\n  example {fw.example_elf}")
        if args.out is not None:
            out = Path(args.out)
            shutil.copytree(fw.include, out / "include", dirs_exist_ok=True)
            for p in (fw.library, fw.folder / "src" / "example_main.c"):
                shutil.copy2(p, out / p.name)
            print(f"  copied to {out}")
        if not args.verify:
            return 0
        if args.guidance is None:
            rec = record_log(replay_scenario(args.verify, estimator=args.estimator))
        else:
            rec = record_guided_log(args.verify, guidance=args.guidance, latency=args.latency,
                                    estimator=args.estimator)
        double = build_firmware(args.controller, args.estimator, "double", guidance=args.guidance,
                                latency=args.latency)
        host = run_host(double, rec)
        qemu = run_qemu(fw, rec)
    except ToolchainMissing as exc:
        print(f"ballbot firmware: error: {exc}", file=sys.stderr)
        return 3
    err = float(np.max(np.abs(qemu.tau - host.tau)))
    tol = REPLAY_ATOL[args.precision]
    if args.latency:
        if args.precision == "double":
            tol = GUIDED_REPLAY_ATOL
        law = firmware_guidance(args.guidance, args.controller, args.latency)
        sc = split_cost(fw, qemu, law.latency, law.first_latency)
        print(f"split guidance, latency {sc.latency} periods (the first sample "
              f"{sc.first_latency}): max |v_ref_qemu - v_ref_host(double)| = "
              f"{float(np.max(np.abs(qemu.v_ref - host.v_ref))):.3g} m/s, host vs the mission "
              f"with that latency {float(np.max(np.abs(host.v_ref - rec.v_ref_mission))):.3g} m/s; "
              f"interrupt step {sc.isr_instructions_max:.0f} instructions (worst; median "
              f"{sc.isr_instructions_median:.0f}); background sample "
              f"{sc.sample_instructions_max:.0f} (the cold first {sc.first_sample_instructions:.0f}), "
              f"fits {sc.margin():.2f} x (first {sc.first_margin():.2f} x) into its latency at "
              f"480 MHz and 1 IPC; RAM {sc.ram_bytes} B; flash {sc.flash_bytes} B")
    elif args.guidance is not None:
        if args.precision == "double":
            tol = GUIDED_REPLAY_ATOL
        g = guided_cost(fw, qemu, guidance_every(firmware_guidance(args.guidance)),
                        rec.values.guidance.size)
        print(f"guidance {args.guidance}: max |v_ref_qemu - v_ref_host(double)| = "
              f"{float(np.max(np.abs(qemu.v_ref - host.v_ref))):.3g} m/s; a period with a "
              f"sample {g.solve_instructions_max:.0f} instructions (worst; median "
              f"{g.solve_instructions_median:.0f}; the cold first {g.first_instructions:.0f}), "
              f"{g.solve_ms(CLOCK_HZ_MAX):.1f} ms at 480 MHz and 1 IPC; without "
              f"{g.hold_instructions_max:.0f}; RAM {g.ram_bytes} B (.data + .bss "
              f"{g.static_ram_bytes}, stack {g.stack_bytes}); flash {g.flash_bytes} B")
    c = firmware_cost(fw, qemu)
    print(f"QEMU replay of {rec.n} periods: max |tau_qemu - tau_host(double)| = {err:.3g} N m "
          f"(tolerance {tol:g}); host replay vs compiled mission "
          f"{float(np.max(np.abs(host.tau - rec.tau_mission))):.3g} N m")
    print(f"cost: {c.step_instructions_max:.0f} instructions per period (worst), "
          f"{c.step_us:.0f} us at 400 MHz and 1 IPC ({100 * c.period_fraction:.1f} % of 5 ms); "
          f"RAM {c.ram_bytes} B (context {c.context_bytes}, stack {c.stack_bytes}); "
          f"flash {c.image_flash_bytes} B (library {c.library_flash_bytes})")
    return 0 if err <= tol else 1


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``firmware``."""
    p = sub.add_parser("firmware", help="cross-compile the embedded software for Cortex-M7 "
                       "(static library, C API header, 200 Hz example); --verify: QEMU replay")
    p.add_argument("--controller", default="flc", help="balance controller (default flc)")
    p.add_argument("--estimator", default=DEFAULT_ESTIMATOR, choices=list(ESTIMATOR_FILTERS),
                   help=f"filters (default {DEFAULT_ESTIMATOR})")
    p.add_argument("--precision", default="double", choices=list(PRECISIONS),
                   help="casadi_real: double (fpv5-d16) or single (float, fpv5-sp-d16)")
    p.add_argument("--guidance", choices=list(GUIDANCE_LAWS), default=None,
                   help="put the guided mission's guidance block (10 Hz) in the period; "
                   "--verify then replays the guided figure-eight")
    p.add_argument("--latency", type=int, default=0, metavar="L",
                   help="with --guidance mpc: run the MPC's sample in a background task, its "
                   f"reference applied L periods after its snapshot (0: inside the period; "
                   f"{SPLIT_LATENCY} fits at 480 MHz, README firmware)")
    p.add_argument("--out", help="also copy the library, headers and example into this folder")
    p.add_argument("--verify", type=int, default=0, metavar="N",
                   help="replay N periods of a recorded mission in QEMU and compare with the host")
    p.set_defaults(func=_cmd_firmware)
