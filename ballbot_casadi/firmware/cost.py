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

A build with a guidance block (:func:`guided_cost`) splits the periods into those that
run a guidance sample (every ``every``-th; period 0 is the cold first sample, which
re-linearises :data:`~ballbot_casadi.guidance.mpc.FIRST_SAMPLE_QPS` times) and those that
only hold the reference; its RAM is what the linked 200 Hz example reserves statically
(``.data + .bss``: the context and the library's state) plus the measured stack, and the
guidance block's own work memory is counted from the generated Function with the
target's sizes (:func:`arm_workspace_bytes`).

A split build (guidance sample in a background task, issue 18: :func:`split_cost`) has
the interrupt step's instructions over every period, the background sample's apart, and
the latency that sample has: :func:`latency_margin` says how many times it fits into the
time the interrupts leave free until its due period, :func:`min_latency` the shortest
latency with a given margin.
"""

from __future__ import annotations

import re
import subprocess
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ballbot_casadi.errors import BuildError
from ballbot_casadi.firmware.build import FirmwareBuild
from ballbot_casadi.firmware.replay import ReplayResult
from ballbot_casadi.firmware.sources import generated_work

__all__ = ["CLOCK_HZ", "CLOCK_HZ_MAX", "IPC", "PERIOD_S", "SPLIT_MARGIN", "FirmwareCost", "GuidedCost",
           "size_text_data", "section_sizes", "image_memory", "max_frame", "firmware_cost", "guided_cost",
           "arm_workspace_bytes", "period_instructions", "latency_margin", "min_latency",
           "SplitCost", "split_cost"]

#: The STM32H743's core clock.
CLOCK_HZ = 400e6
#: The STM32H743's highest core clock (silicon revision V; a datasheet figure).
CLOCK_HZ_MAX = 480e6
#: Assumed instructions per cycle to convert the instruction count to time (stated, not measured).
IPC = 1.0
#: The embedded software's period (200 Hz).
PERIOD_S = 0.005
#: How many times a split build's background sample must fit into the time it has until
#: its due period (:func:`latency_margin`): room for the instruction count being only a
#: proxy for cycles and for the main loop's other work.
SPLIT_MARGIN = 1.5


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


def section_sizes(path) -> dict[str, int]:
    """Section name -> bytes of an ELF (``arm-none-eabi-size -A``)."""
    try:
        out = subprocess.run(["arm-none-eabi-size", "-A", str(path)], capture_output=True,
                             text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as exc:
        raise BuildError(f"arm-none-eabi-size -A {path} failed: {exc}") from None
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\.\S+)\s+(\d+)", out, re.M)}


def image_memory(path) -> tuple[int, int]:
    """``(static RAM, flash)`` bytes of an ELF image: RAM holds its ``.data`` and ``.bss``,
    flash its text (``arm-none-eabi-size``'s, read-only data included) and the initial
    values of ``.data``; a section the image lacks counts 0."""
    sec = section_sizes(path)
    text, _ = size_text_data(path)
    data = sec.get(".data", 0)
    return data + sec.get(".bss", 0), text + data


def arm_workspace_bytes(f: ca.Function, precision: str = "double") -> int:
    """Work memory of one call of ``f``'s generated C on the Cortex-M7: the ``sz_w`` reals,
    ``sz_iw`` ints and ``sz_arg + sz_res`` pointers its ``_work`` function declares
    (:func:`~ballbot_casadi.firmware.sources.generated_work`), ints and pointers of 4 bytes
    (the firmware generates with ``casadi_int = int``; 32-bit addresses)."""
    sz_arg, sz_res, sz_iw, sz_w = generated_work(f, precision)
    return (8 if precision == "double" else 4) * sz_w + 4 * (sz_iw + sz_arg + sz_res)


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


@dataclass(frozen=True)
class GuidedCost:
    """Instructions, RAM and flash of a build with a guidance block (module docstring).

    Instructions per period: ``solve_*`` over the periods with a (warm, one-QP) guidance
    sample after the first, ``first``: period 0 (the cold first sample), ``hold_*`` over the
    periods without a sample.  ``ram_bytes``: ``.data + .bss`` of the linked example plus
    the measured stack; ``flash_bytes``: its ``text + data`` (with the default guidance
    data, ``guidance_data_bytes``, a constant table)."""

    solve_instructions_max: float
    solve_instructions_median: float
    first_instructions: float
    hold_instructions_max: float
    hold_instructions_median: float
    static_ram_bytes: int
    stack_bytes: int
    context_bytes: int
    flash_bytes: int
    guidance_data_bytes: int

    @property
    def ram_bytes(self) -> int:
        """``.data + .bss`` of the example plus the worst measured stack."""
        return self.static_ram_bytes + self.stack_bytes

    def solve_ms(self, clock_hz: float = CLOCK_HZ_MAX) -> float:
        """The worst warm sample's period at ``clock_hz`` and :data:`IPC`, milliseconds."""
        return self.solve_instructions_max / IPC / clock_hz * 1e3


def guided_cost(build: FirmwareBuild, replay: ReplayResult, every: int,
                guidance_values: int) -> GuidedCost:
    """The costs of a guided build from a QEMU ``replay`` whose guidance samples run every
    ``every`` periods from period 0; ``guidance_values``: entries of the guidance data."""
    if replay.ticks.size <= every:
        raise BuildError(f"the guided replay needs more than {every} periods (two guidance "
                         f"samples), got {replay.ticks.size}")
    insn = replay.ticks * replay.instructions_per_tick
    k = np.arange(insn.size)
    solve, hold = insn[(k % every == 0) & (k > 0)], insn[k % every != 0]
    ram, flash = image_memory(build.example_elf)
    return GuidedCost(float(solve.max()), float(np.median(solve)), float(insn[0]),
                      float(hold.max()), float(np.median(hold)), ram, replay.stack_bytes,
                      replay.ctx_bytes, flash, guidance_values * replay.real_bytes)


def period_instructions(clock_hz: float = CLOCK_HZ_MAX, ipc: float = IPC) -> float:
    """Instructions one 5 ms period has at ``clock_hz`` and ``ipc`` (2.4 M at 480 MHz, 1 IPC)."""
    return PERIOD_S * clock_hz * ipc


def latency_margin(latency: int, isr_instructions: float, sample_instructions: float,
                   clock_hz: float = CLOCK_HZ_MAX, ipc: float = IPC) -> float:
    """How many times a background sample of ``sample_instructions`` fits into the time
    from its snapshot to its due period ``latency`` periods later, while the interrupt
    takes ``isr_instructions`` of each of those periods: ``latency * (period -
    isr) / sample`` (:func:`period_instructions`); >= 1 meets the deadline."""
    return latency * (period_instructions(clock_hz, ipc) - isr_instructions) / sample_instructions


def min_latency(isr_instructions: float, sample_instructions: float, margin: float = 1.0,
                clock_hz: float = CLOCK_HZ_MAX, ipc: float = IPC) -> int:
    """The smallest latency (periods) whose :func:`latency_margin` is at least ``margin``."""
    free = period_instructions(clock_hz, ipc) - isr_instructions
    if free <= 0:
        raise BuildError(f"the interrupt step's {isr_instructions:.0f} instructions leave no "
                         f"time in a {PERIOD_S * 1e3:g} ms period for the background")
    return int(np.ceil(margin * sample_instructions / free - 1e-12))


@dataclass(frozen=True)
class SplitCost:
    """Instructions, RAM and flash of a split build (guidance sample in the background).

    ``isr_*``: the interrupt step over every period (those that take a snapshot
    included); ``sample_*``: the background samples after the first (warm, one QP),
    ``first_sample``: the cold first; ``latency`` / ``first_latency``: periods from a
    snapshot to its due period; RAM: ``.data + .bss`` of the linked example plus the
    worst stack of the background sample interrupted by the step (their sum)."""

    isr_instructions_max: float
    isr_instructions_median: float
    sample_instructions_max: float
    sample_instructions_median: float
    first_sample_instructions: float
    latency: int
    first_latency: int
    static_ram_bytes: int
    stack_bytes: int
    bg_stack_bytes: int
    context_bytes: int
    flash_bytes: int

    @property
    def ram_bytes(self) -> int:
        """``.data + .bss`` plus the step's stack on top of the background's."""
        return self.static_ram_bytes + self.stack_bytes + self.bg_stack_bytes

    def margin(self, clock_hz: float = CLOCK_HZ_MAX) -> float:
        """:func:`latency_margin` of the worst warm sample."""
        return latency_margin(self.latency, self.isr_instructions_max,
                              self.sample_instructions_max, clock_hz)

    def first_margin(self, clock_hz: float = CLOCK_HZ_MAX) -> float:
        """:func:`latency_margin` of the cold first sample."""
        return latency_margin(self.first_latency, self.isr_instructions_max,
                              self.first_sample_instructions, clock_hz)


def split_cost(build: FirmwareBuild, replay: ReplayResult, latency: int,
               first_latency: int) -> SplitCost:
    """The costs of a split build from a QEMU ``replay`` (at least two background samples)."""
    ipt = replay.instructions_per_tick
    isr, bg = replay.ticks * ipt, replay.bg_ticks * ipt
    ran = np.flatnonzero(bg > 0)
    if ran.size < 2:
        raise BuildError(f"the split replay ran {ran.size} background samples; need two")
    warm = bg[ran[1:]]
    ram, flash = image_memory(build.example_elf)
    return SplitCost(float(isr.max()), float(np.median(isr)), float(warm.max()),
                     float(np.median(warm)), float(bg[ran[0]]), latency, first_latency, ram,
                     replay.stack_bytes, replay.bg_stack_bytes, replay.ctx_bytes, flash)
