"""Firmware cost bookkeeping on hand-made tool outputs and replays (no cross toolchain run).

``arm-none-eabi-size`` outputs, ``-fstack-usage`` reports and QEMU replay results are
written here with known numbers; the sums, medians, the split of guided periods and the
time conversions are checked against hand arithmetic.
"""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.firmware import cost
from ballbot_casadi.firmware.build import FirmwareBuild
from ballbot_casadi.firmware.replay import ReplayResult

BERKELEY = """   text    data     bss     dec     hex filename
   1200      8      16    1224     4c8 a.o (ex libballbot_fw.a)
    300      0       4     304     130 b.o (ex libballbot_fw.a)
"""
SYSV = """example.elf  :
section              size        addr
.isr_vector           0x400  0x00000000
.text               20000     1024
.data                 512   536870912
.bss                 3072   536871424
.heap                8192   536874496
Total               31776
"""


def _size_tool(fake_run, outputs):
    """``arm-none-eabi-size`` answering ``outputs['-A']`` or ``outputs['plain']``."""
    return fake_run(lambda cmd: outputs["-A" if "-A" in cmd else "plain"], [])


def test_size_parsers_sum_rows_and_read_sections(monkeypatch, fake_run):
    monkeypatch.setattr(cost.subprocess, "run", _size_tool(fake_run, {"plain": BERKELEY, "-A": SYSV}))
    assert cost.size_text_data("lib.a") == (1500, 8 + 16 + 0 + 4)
    sec = cost.section_sizes("example.elf")
    assert sec[".text"] == 20000 and sec[".data"] == 512 and sec[".bss"] == 3072
    assert sec[".heap"] == 8192 and "Total" not in sec
    # RAM: initialised and zeroed data (not the heap reserve); flash: text and data's values
    assert cost.image_memory("example.elf") == (512 + 3072, 1500 + 512)


def test_a_missing_size_tool_is_a_build_error(monkeypatch):
    def boom(cmd, **kw):
        raise subprocess.CalledProcessError(1, cmd)
    monkeypatch.setattr(cost.subprocess, "run", boom)
    with pytest.raises(BuildError, match="arm-none-eabi-size"):
        cost.size_text_data("x.a")
    with pytest.raises(BuildError, match="arm-none-eabi-size -A"):
        cost.section_sizes("x.elf")


def test_arm_workspace_counts_reals_ints_and_pointers(monkeypatch):
    monkeypatch.setattr(cost, "generated_work", lambda f, precision: (3, 2, 5, 100))  # arg, res, iw, w
    assert cost.arm_workspace_bytes(None) == 8 * 100 + 4 * (5 + 3 + 2)
    assert cost.arm_workspace_bytes(None, "single") == 4 * 100 + 4 * (5 + 3 + 2)


def _build(tmp_path):
    b = FirmwareBuild(tmp_path, "flc", "ukf", "double", "d")
    b.stack_usage.write_text(
        "fw.c:10:5:ballbot_fw_step\t512\tstatic\n"
        "fw.c:40:6:ballbot_fw_init\t96\tstatic\n"
        "gen.c:7:1:casadi_f0\t2048\tdynamic,bounded\n"
        "gen.c:9:1:casadi_f1\t64\tstatic\n")
    return b


def test_max_frame_is_the_largest_reported_frame(tmp_path):
    assert cost.max_frame(_build(tmp_path)) == ("casadi_f0", 2048)


def _replay(ticks, stack=1200, ctx=40000):
    n = len(ticks)
    return ReplayResult(np.zeros((n, 3)), np.asarray(ticks, float), np.zeros(n, int), stack,
                        calib_ticks=5000.0, calib_instructions=200000.0,
                        ctx_bytes=ctx, real_bytes=8, v_ref=np.zeros((n, 0)),
                        bg_ticks=np.zeros(n))


def test_firmware_cost_from_sizes_and_a_replay(monkeypatch, tmp_path, fake_run):
    build = _build(tmp_path)
    sizes = {str(build.library): (1500, 0), str(build.example_elf): (22000, 600)}
    monkeypatch.setattr(cost, "size_text_data", lambda p: sizes[str(p)])
    monkeypatch.setattr(cost.subprocess, "run", _size_tool(fake_run, {"-A": SYSV, "plain": ""}))
    rep = _replay([100.0, 300.0, 200.0, 250.0, 150.0])
    ipt = 200000.0 / 5000.0  # 40 instructions per tick
    assert rep.instructions_per_tick == pytest.approx(ipt)
    c = cost.firmware_cost(build, rep)
    assert c.library_flash_bytes == 1500 and c.library_static_ram_bytes == 0
    assert c.image_flash_bytes == 22000 + 512  # text + .data (not .bss)
    assert c.context_bytes == 40000 and c.stack_bytes == 1200
    assert (c.max_frame_function, c.max_frame_bytes) == ("casadi_f0", 2048)
    assert c.step_instructions == pytest.approx(200.0 * ipt)   # median
    assert c.step_instructions_max == pytest.approx(300.0 * ipt)
    assert c.ram_bytes == 0 + 40000 + 1200
    assert c.step_us == pytest.approx(300.0 * ipt / cost.IPC / cost.CLOCK_HZ * 1e6)
    assert c.period_fraction == pytest.approx(c.step_us * 1e-6 / 0.005)


def test_guided_cost_splits_sample_and_hold_periods(monkeypatch, tmp_path):
    build = _build(tmp_path)
    monkeypatch.setattr(cost, "section_sizes", lambda p: {".data": 512, ".bss": 70000, ".text": 1})
    monkeypatch.setattr(cost, "size_text_data", lambda p: (90000, 0))
    # every 4th period (0, 4, 8) runs a sample; 0 is the cold first one
    ticks = [1000, 10, 12, 11, 500, 13, 9, 14, 700, 8]
    c = cost.guided_cost(build, _replay(ticks, stack=900, ctx=30000), every=4, guidance_values=250)
    ipt = 40.0
    assert c.first_instructions == pytest.approx(1000 * ipt)
    assert c.solve_instructions_max == pytest.approx(700 * ipt)
    assert c.solve_instructions_median == pytest.approx(600 * ipt)
    assert c.hold_instructions_max == pytest.approx(14 * ipt)
    assert c.hold_instructions_median == pytest.approx(11 * ipt)
    assert c.static_ram_bytes == 70512 and c.stack_bytes == 900 and c.context_bytes == 30000
    assert c.ram_bytes == 70512 + 900
    assert c.flash_bytes == 90000 + 512
    assert c.guidance_data_bytes == 250 * 8
    assert c.solve_ms() == pytest.approx(700 * ipt / cost.IPC / cost.CLOCK_HZ_MAX * 1e3)
    assert c.solve_ms(100e6) == pytest.approx(700 * ipt / 100e6 * 1e3)
    with pytest.raises(BuildError, match="more than 4 periods"):
        cost.guided_cost(build, _replay(ticks[:4]), every=4, guidance_values=1)


def test_clock_and_period_constants():
    assert cost.CLOCK_HZ == 400e6 and cost.CLOCK_HZ_MAX == 480e6
    assert cost.PERIOD_S == 0.005 and cost.IPC == 1.0
