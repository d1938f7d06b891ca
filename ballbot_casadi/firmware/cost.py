"""What the firmware costs on the Cortex-M7: flash, RAM and instructions per period.

* Flash: ``text + data`` of the library (``arm-none-eabi-size`` of ``libballbot_fw.a``) and
  of the linked 200 Hz example (library plus the newlib/libm functions it pulls in, the
  start-up code and the vector table).
* RAM: the library has no static data (``data + bss`` of the archive, checked to be 0);
  the caller-owned context ``ballbot_fw_ctx`` (parameters, state, outputs and the CasADi
  work vectors) and the worst stack of one period, measured in QEMU by painting the stack
  before a period and finding the deepest word it changed (includes libm);
  ``-fstack-usage`` gives the largest single frame of the library as a cross-check.
* Instructions per period: QEMU with ``-icount shift=0`` advances its virtual clock by
  1 ns per executed instruction; SysTick (processor clock, 25 MHz on ``mps2-an500``) is read
  before and after each ``ballbot_fw_step``.  A calibration loop of known length (1 + 2 n
  instructions) gives the instructions per tick (40).  An instruction count is a proxy
  for cycles (the M7 is dual-issue, but double-precision FPU operations, divisions,
  square roots and memory waits take several cycles): :data:`IPC` converts it to time.
"""

from __future__ import annotations

import re
import subprocess
from dataclasses import dataclass

import numpy as np

from ballbot_casadi.errors import BuildError
from ballbot_casadi.firmware.build import FirmwareBuild
from ballbot_casadi.firmware.replay import ReplayResult

__all__ = ["CLOCK_HZ", "IPC", "PERIOD_S", "FirmwareCost", "size_text_data", "max_frame", "firmware_cost"]

#: The STM32H743's core clock.
CLOCK_HZ = 400e6
#: Assumed instructions per cycle to convert the instruction count to time (stated, not measured).
IPC = 1.0
#: The embedded software's period (200 Hz).
PERIOD_S = 0.005


def size_text_data(path) -> tuple[int, int]:
    """``(text, data + bss)`` summed over ``arm-none-eabi-size`` rows of an archive or ELF."""
    try:
        out = subprocess.run(["arm-none-eabi-size", str(path)], capture_output=True, text=True,
                             check=True).stdout
    except (OSError, subprocess.CalledProcessError) as exc:
        raise BuildError(f"arm-none-eabi-size {path} failed: {exc}") from None
    text = data = 0
    for line in out.splitlines()[1:]:
        cols = line.split()
        if len(cols) >= 3 and cols[0].isdigit():
            text += int(cols[0])
            data += int(cols[1]) + int(cols[2])
    return text, data


def max_frame(build: FirmwareBuild) -> tuple[str, int]:
    """The library's largest stack frame from ``-fstack-usage``: (function, bytes)."""
    best = ("", 0)
    for line in build.stack_usage.read_text().splitlines():
        m = re.match(r".*:(\S+)\t(\d+)\t", line)
        if m and int(m.group(2)) > best[1]:
            best = (m.group(1), int(m.group(2)))
    return best


@dataclass(frozen=True)
class FirmwareCost:
    """Flash, RAM and instructions of one build (see module docstring)."""

    library_flash_bytes: int
    library_static_ram_bytes: int
    image_flash_bytes: int
    context_bytes: int
    stack_bytes: int
    max_frame_bytes: int
    max_frame_function: str
    step_instructions: float
    step_instructions_max: float

    @property
    def ram_bytes(self) -> int:
        """Static data + context + worst measured stack of one period."""
        return self.library_static_ram_bytes + self.context_bytes + self.stack_bytes

    @property
    def step_us(self) -> float:
        """Worst period's time at :data:`CLOCK_HZ` and :data:`IPC`, microseconds."""
        return self.step_instructions_max / IPC / CLOCK_HZ * 1e6

    @property
    def period_fraction(self) -> float:
        """Worst period's share of the 5 ms period."""
        return self.step_us * 1e-6 / PERIOD_S


def firmware_cost(build: FirmwareBuild, replay: ReplayResult) -> FirmwareCost:
    """Flash and RAM from the build, instructions and stack from a QEMU ``replay``."""
    lib_text, lib_ram = size_text_data(build.library)
    ex_text, _ = size_text_data(build.example_elf)
    # the example's data (not bss: heap and stack reservations of the linker script)
    out = subprocess.run(["arm-none-eabi-size", "-A", str(build.example_elf)], capture_output=True,
                         text=True, check=False).stdout
    data = sum(int(m.group(1)) for m in re.finditer(r"^\.data\s+(\d+)", out, re.M))
    ipt = replay.instructions_per_tick
    insn = replay.ticks * ipt
    fn, frame = max_frame(build)
    return FirmwareCost(lib_text, lib_ram, ex_text + data, replay.ctx_bytes, replay.stack_bytes,
                        frame, fn, float(np.median(insn)), float(np.max(insn)))
