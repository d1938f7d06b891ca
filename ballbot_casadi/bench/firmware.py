"""Firmware benchmark (issue 21): instructions per period, RAM and flash on the Cortex-M7.

Targets: ``firmware_step_instructions`` (FLC + the default estimator
:data:`~ballbot_casadi.sim.embedded.DEFAULT_ESTIMATOR` + COM observer, worst period of
a 200-period QEMU replay) <= 200,000 per 5 ms period; ``firmware_ram_bytes`` (context +
worst stack + static) <= 32 KiB; ``firmware_flash_bytes`` (the linked 200 Hz example) <=
256 KiB.  Without the cross toolchain the group reports ``firmware_available = 0``.

Group ``firmware_mpc`` (issue 18: the path-following MPC on the Cortex-M7): the double
build with the guided mission's MPC in the period (10 Hz inside the 200 Hz step), a
:func:`~ballbot_casadi.firmware.replay.record_guided_log` replay of the figure-eight (noise,
the default estimator) in QEMU, :func:`~ballbot_casadi.firmware.cost.guided_cost`:

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

Group ``firmware_split`` (issue 18: the MPC split off the 200 Hz interrupt into a
background task, :data:`~ballbot_casadi.firmware.sources.SPLIT_LATENCY` periods from its
snapshot to its reference): the split double build replaying the guided figure-eight
with that latency (noise, the default estimator) in QEMU, :func:`~ballbot_casadi.firmware.cost.split_cost`:

``firmware_split_isr_instructions_max``, ``_median``
    The interrupt step over every period (snapshot periods included); target 200,000,
    beside ``firmware_split_period_instructions`` (a 5 ms period at 480 MHz and 1 IPC:
    2.4 M) and ``firmware_split_isr_period_fraction``.
``firmware_split_sample_instructions_max``, ``_median``, ``firmware_split_first_sample_instructions``
    The background sample (warm: one QP; the cold first: 5 QPs).
``firmware_split_latency_periods``, ``firmware_split_first_latency_periods``
    Periods from a snapshot to its due period; ``firmware_split_margin`` /
    ``firmware_split_first_margin``: how many times the worst sample fits into the time
    the interrupts leave free until then (:func:`~ballbot_casadi.firmware.cost.latency_margin`,
    target :data:`~ballbot_casadi.firmware.cost.SPLIT_MARGIN`); ``firmware_split_latency_min``:
    the smallest latency meeting it with these measurements.
``firmware_split_ram_bytes``
    ``.data + .bss`` of the linked example plus the step's stack on top of the background
    sample's (target: the 512 KiB AXI SRAM); ``firmware_split_flash_bytes`` (target 2 MiB).
``firmware_split_replay_max_abs_diff``
    QEMU against the compiled mission with that latency (torques N m, references m/s).
``firmware_split_lateral_rms_settled_m``, ``firmware_split_lateral_rms_settled_latency0_m``
    What the latency costs: the figure-eight lap (27 s, true state, the path study's
    ``path_fig8_mpc``) with the latency and without, lateral error RMS after 2 s
    (:func:`~ballbot_casadi.analysis.path_metrics.path_errors`); target 2 cm (issue 18).
"""

from __future__ import annotations

import numpy as np

from ballbot_casadi.analysis.path_metrics import SAMPLE_EVERY, path_errors
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import STATE_XY
from ballbot_casadi.firmware.build import build_firmware
from ballbot_casadi.firmware.cost import (
    CLOCK_HZ,
    CLOCK_HZ_MAX,
    IPC,
    SPLIT_MARGIN,
    arm_workspace_bytes,
    firmware_cost,
    guided_cost,
    min_latency,
    period_instructions,
    split_cost,
)
from ballbot_casadi.firmware.replay import record_guided_log, record_log, replay_scenario, run_qemu
from ballbot_casadi.firmware.sources import (
    SPLIT_LATENCY,
    default_guidance_path,
    firmware_guidance,
    guidance_every,
)
from ballbot_casadi.firmware.toolchain import missing_tools
from ballbot_casadi.sim.guided import run_guided, scenario_law
from ballbot_casadi.sim.path_following import path_scenario

__all__ = ["bench_firmware", "bench_firmware_mpc", "bench_firmware_split", "lap_lateral_rms"]

#: The figure-eight lap of the path study (``path_fig8_mpc``), seconds.
LAP_S = 27.0
#: Start-up excluded from the settled lateral RMS (as ``path_lateral_rms_settled_m``), seconds.
SETTLE_S = 2.0


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


def lap_lateral_rms(latency: int = 0, duration: float = LAP_S) -> float:
    """Lateral error RMS (m, true position, after :data:`SETTLE_S`) of the compiled guided
    mission with guidance ``latency`` on the firmware's default figure-eight, true state."""
    path = default_guidance_path()
    sc = path_scenario(path, duration).replace(guidance="mpc")
    log = run_guided(path, scenario_law(sc, latency), duration, scenario=sc)
    xy = np.asarray(log["state"], float)[::SAMPLE_EVERY, STATE_XY]
    t = np.arange(xy.shape[0]) * SAMPLE_EVERY * TS_CONTROL
    _, lat = path_errors(path, xy)
    return float(np.sqrt(np.mean(lat[t >= SETTLE_S] ** 2)))


def bench_firmware_split(n_periods: int = 200, latency: int = SPLIT_LATENCY,
                         lap_s: float = LAP_S) -> dict[str, float]:
    """Build the split double firmware, replay ``n_periods`` of the guided figure-eight with
    ``latency`` in QEMU, and run the lap with and without it (module docstring)."""
    if missing_tools():
        return {"firmware_split_available": 0.0}
    law = firmware_guidance("mpc", latency=latency)
    rec = record_guided_log(n_periods, latency=latency)
    b = build_firmware(precision="double", guidance="mpc", latency=latency)
    q = run_qemu(b, rec)
    c = split_cost(b, q, law.latency, law.first_latency)
    diff = max(float(np.max(np.abs(q.tau - rec.tau_mission))),
               float(np.max(np.abs(q.v_ref - rec.v_ref_mission))))
    period = period_instructions(CLOCK_HZ_MAX, IPC)
    return {
        "firmware_split_available": 1.0,
        "firmware_split_isr_instructions_max": c.isr_instructions_max,
        "firmware_split_isr_instructions_median": c.isr_instructions_median,
        "firmware_split_isr_instructions_target": 200000.0,
        "firmware_split_period_instructions": period,
        "firmware_split_isr_period_fraction": c.isr_instructions_max / period,
        "firmware_split_sample_instructions_max": c.sample_instructions_max,
        "firmware_split_sample_instructions_median": c.sample_instructions_median,
        "firmware_split_first_sample_instructions": c.first_sample_instructions,
        "firmware_split_latency_periods": float(c.latency),
        "firmware_split_first_latency_periods": float(c.first_latency),
        "firmware_split_margin": c.margin(),
        "firmware_split_first_margin": c.first_margin(),
        "firmware_split_margin_target": SPLIT_MARGIN,
        "firmware_split_latency_min": float(min_latency(c.isr_instructions_max,
                                                        c.sample_instructions_max, SPLIT_MARGIN)),
        "firmware_split_ram_bytes": float(c.ram_bytes),
        "firmware_split_ram_bytes_target": 524288.0,
        "firmware_split_context_bytes": float(c.context_bytes),
        "firmware_split_stack_bytes": float(c.stack_bytes),
        "firmware_split_bg_stack_bytes": float(c.bg_stack_bytes),
        "firmware_split_flash_bytes": float(c.flash_bytes),
        "firmware_split_flash_bytes_target": 2097152.0,
        "firmware_split_replay_max_abs_diff": diff,
        "firmware_split_lateral_rms_settled_m": lap_lateral_rms(latency, lap_s),
        "firmware_split_lateral_rms_settled_latency0_m": lap_lateral_rms(0, lap_s),
        "firmware_split_lateral_rms_settled_m_target": 0.02,
        "firmware_split_ipc_assumed": IPC,
    }
