"""Firmware benchmark (issue 21): instructions per period, RAM and flash on the Cortex-M7.

Targets: ``firmware_step_instructions`` (FLC + QUKF + VUKF + COM observer, worst period of
a 200-period QEMU replay) <= 200,000 per 5 ms period; ``firmware_ram_bytes`` (context +
worst stack + static) <= 32 KiB; ``firmware_flash_bytes`` (the linked 200 Hz example) <=
256 KiB.  Without the cross toolchain the group reports ``firmware_available = 0``.

Group ``firmware_mpc`` (issue 18: the path-following MPC on the Cortex-M7): the double
build with the guided mission's MPC in the period (10 Hz inside the 200 Hz step), a
:func:`~ballbot_casadi.firmware.replay.record_guided_log` replay of the figure-eight (noise,
QUKF + VUKF) in QEMU, :func:`~ballbot_casadi.firmware.cost.guided_cost`:

``firmware_mpc_instructions_max``, ``firmware_mpc_instructions_median``
    Instructions of a period with a warm guidance sample (one QP, the real-time
    iteration), worst and median over the replay's samples after the first.
``firmware_mpc_first_instructions``
    Period 0: the cold first sample (5 QPs re-linearising the path window).
``firmware_mpc_hold_instructions_max``, ``firmware_mpc_hold_instructions_median``
    Periods without a sample (the block holds its reference).
``firmware_mpc_solve_ms_at_480mhz``
    The worst warm sample's period at 480 MHz and 1 instruction per cycle (instructions
    are not cycles: a proxy, see :mod:`~ballbot_casadi.firmware.cost`).
``firmware_mpc_ram_bytes``
    ``.data + .bss`` of the linked example (context with the work vectors) plus the
    measured stack; ``firmware_mpc_context_bytes``, ``firmware_mpc_stack_bytes`` its parts.
``firmware_mpc_workspace_bytes``
    The generated QP solver's call (``ballbot_mpc``) with the target's sizes
    (:func:`~ballbot_casadi.firmware.cost.arm_workspace_bytes`); target (issue 18) <= 64 KiB.
    ``firmware_mpc_guidance_workspace_bytes``: the whole guidance block's call (path
    window, obstacle half-planes, warm start and the solve).
``firmware_mpc_flash_bytes``
    ``text + data`` of the linked example, with the default path as a constant table of
    ``firmware_mpc_path_table_bytes``.
"""

from __future__ import annotations

from ballbot_casadi.firmware.build import build_firmware
from ballbot_casadi.firmware.cost import (
    CLOCK_HZ,
    CLOCK_HZ_MAX,
    IPC,
    arm_workspace_bytes,
    firmware_cost,
    guided_cost,
)
from ballbot_casadi.firmware.replay import record_guided_log, record_log, replay_scenario, run_qemu
from ballbot_casadi.firmware.sources import firmware_guidance, guidance_every
from ballbot_casadi.firmware.toolchain import missing_tools

__all__ = ["bench_firmware", "bench_firmware_mpc"]


def bench_firmware(n_periods: int = 200) -> dict[str, float]:
    """Build both precisions, replay ``n_periods`` in QEMU and report the costs."""
    if missing_tools():
        return {"firmware_available": 0.0}
    rec = record_log(replay_scenario(n_periods))
    out: dict[str, float] = {"firmware_available": 1.0, "firmware_clock_hz": CLOCK_HZ,
                             "firmware_ipc_assumed": IPC}
    for precision in ("double", "single"):
        c = firmware_cost(b := build_firmware(precision=precision), run_qemu(b, rec))
        pre = "firmware" if precision == "double" else "firmware_single"
        out.update({
            f"{pre}_step_instructions": c.step_instructions_max,
            f"{pre}_step_instructions_median": c.step_instructions,
            f"{pre}_step_us_at_400mhz": c.step_us,
            f"{pre}_ram_bytes": float(c.ram_bytes),
            f"{pre}_context_bytes": float(c.context_bytes),
            f"{pre}_stack_bytes": float(c.stack_bytes),
            f"{pre}_flash_bytes": float(c.image_flash_bytes),
            f"{pre}_library_flash_bytes": float(c.library_flash_bytes),
        })
    out.update({"firmware_step_instructions_target": 200000.0,
                "firmware_ram_bytes_target": 32768.0, "firmware_flash_bytes_target": 262144.0})
    return out


def bench_firmware_mpc(n_periods: int = 200) -> dict[str, float]:
    """Build the double firmware with the MPC, replay ``n_periods`` of the guided figure-eight
    in QEMU and report the costs (module docstring)."""
    if missing_tools():
        return {"firmware_mpc_available": 0.0}
    law = firmware_guidance("mpc")
    rec = record_guided_log(n_periods)
    b = build_firmware(precision="double", guidance="mpc")
    c = guided_cost(b, run_qemu(b, rec), guidance_every(law), rec.values.guidance.size)
    solver = law.function.find_function("ballbot_mpc")
    return {
        "firmware_mpc_available": 1.0,
        "firmware_mpc_instructions_max": c.solve_instructions_max,
        "firmware_mpc_instructions_median": c.solve_instructions_median,
        "firmware_mpc_first_instructions": c.first_instructions,
        "firmware_mpc_hold_instructions_max": c.hold_instructions_max,
        "firmware_mpc_hold_instructions_median": c.hold_instructions_median,
        "firmware_mpc_solve_ms_at_480mhz": c.solve_ms(CLOCK_HZ_MAX),
        "firmware_mpc_ram_bytes": float(c.ram_bytes),
        "firmware_mpc_context_bytes": float(c.context_bytes),
        "firmware_mpc_stack_bytes": float(c.stack_bytes),
        "firmware_mpc_workspace_bytes": float(arm_workspace_bytes(solver)),
        "firmware_mpc_guidance_workspace_bytes": float(arm_workspace_bytes(law.function)),
        "firmware_mpc_flash_bytes": float(c.flash_bytes),
        "firmware_mpc_path_table_bytes": float(c.guidance_data_bytes),
        "firmware_mpc_workspace_bytes_target": 65536.0,
        "firmware_mpc_ipc_assumed": IPC,
    }
