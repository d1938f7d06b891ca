"""Firmware benchmark (issue 21): instructions per period, RAM and flash on the Cortex-M7.

Targets: ``firmware_step_instructions`` (FLC + QUKF + VUKF + COM observer, worst period of
a 200-period QEMU replay) <= 200,000 per 5 ms period; ``firmware_ram_bytes`` (context +
worst stack + static) <= 32 KiB; ``firmware_flash_bytes`` (the linked 200 Hz example) <=
256 KiB.  Without the cross toolchain the group reports ``firmware_available = 0``.
"""

from __future__ import annotations

from ballbot_casadi.firmware.build import build_firmware
from ballbot_casadi.firmware.cost import CLOCK_HZ, IPC, firmware_cost
from ballbot_casadi.firmware.replay import record_log, replay_scenario, run_qemu
from ballbot_casadi.firmware.toolchain import missing_tools

__all__ = ["bench_firmware"]


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
