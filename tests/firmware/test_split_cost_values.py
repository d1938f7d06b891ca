"""The split build's deadline arithmetic (firmware/cost.py) by hand: the instructions of a
period, the margin of a latency, the smallest latency meeting a margin (exact integer
ratios at the boundary), the split costs of a hand-made replay, and the shipped
SPLIT_LATENCY as the rule's answer on the README's recorded instruction counts."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.firmware import cost
from ballbot_casadi.firmware.replay import ReplayResult
from ballbot_casadi.firmware.sources import SPLIT_LATENCY


def test_period_instructions_and_margin_by_hand():
    assert cost.period_instructions() == pytest.approx(0.005 * 480e6)
    assert cost.period_instructions(400e6, 0.5) == pytest.approx(0.005 * 400e6 * 0.5)
    # 3 periods of (2.4 M - 0.4 M) free for a 4 M sample: 1.5 times
    assert cost.latency_margin(3, 0.4e6, 4e6) == pytest.approx(1.5, rel=1e-14)
    assert cost.latency_margin(3, 0.4e6, 4e6, clock_hz=400e6) == pytest.approx(
        3 * (2.0e6 - 0.4e6) / 4e6, rel=1e-14)


@pytest.mark.parametrize("isr, sample, margin, want", [
    (0.4e6, 6.0e6, 1.0, 3),      # needs exactly 3 periods of 2 M: 3, not 4
    (0.4e6, 6.0e6 + 1.0, 1.0, 4),  # one instruction more: 4
    (0.4e6, 4.0e6, 1.5, 3),      # 1.5 x 4 M = 6 M: exactly 3
    (0.4e6, 1.0e6, 1.0, 1),
])
def test_min_latency_at_exact_boundaries(isr, sample, margin, want):
    L = cost.min_latency(isr, sample, margin)
    assert L == want
    assert cost.latency_margin(L, isr, sample) >= margin - 1e-12
    if L > 1:
        assert cost.latency_margin(L - 1, isr, sample) < margin


def test_min_latency_refuses_an_interrupt_that_fills_the_period():
    with pytest.raises(BuildError, match="leave no time"):
        cost.min_latency(2.4e6, 1e6)


def test_shipped_latency_is_the_rule_on_the_recorded_counts():
    """README, firmware: the interrupt step at most 165,361 instructions, a warm sample
    7.22 M, SPLIT_MARGIN 1.5 at 480 MHz: L = 5 (margin 1.55; L = 4 only 1.24)."""
    assert cost.min_latency(165_361, 7.22e6, cost.SPLIT_MARGIN) == SPLIT_LATENCY == 5
    assert cost.latency_margin(5, 165_361, 7.22e6) == pytest.approx(1.5475, abs=1e-4)
    assert cost.latency_margin(4, 165_361, 7.22e6) == pytest.approx(1.2380, abs=1e-4)


def test_split_cost_of_a_hand_made_replay(monkeypatch, tmp_path):
    """Background samples ran after periods 0 (cold), 3 and 6: the warm ones are 3 and 6."""
    monkeypatch.setattr(cost, "section_sizes", lambda p: {".data": 100, ".bss": 900, ".text": 5})
    monkeypatch.setattr(cost, "size_text_data", lambda p: (7000, 0))
    ticks = np.array([10.0, 12, 11, 30, 9, 10, 14, 8])
    bg = np.array([500.0, 0, 0, 200, 0, 0, 260, 0])
    rep = ReplayResult(np.zeros((8, 3)), ticks, np.zeros(8, int), 640, calib_ticks=100.0,
                       calib_instructions=400.0, ctx_bytes=3000, real_bytes=8,
                       v_ref=np.zeros((8, 3)), bg_ticks=bg, bg_stack_bytes=320)
    c = cost.split_cost(SimpleNamespace(example_elf="x.elf"), rep, latency=3, first_latency=7)
    ipt = 4.0
    assert c.isr_instructions_max == pytest.approx(30 * ipt)
    assert c.isr_instructions_median == pytest.approx(10.5 * ipt)
    assert c.sample_instructions_max == pytest.approx(260 * ipt)
    assert c.sample_instructions_median == pytest.approx(230 * ipt)
    assert c.first_sample_instructions == pytest.approx(500 * ipt)
    assert (c.latency, c.first_latency) == (3, 7)
    assert c.static_ram_bytes == 1000 and c.stack_bytes == 640 and c.bg_stack_bytes == 320
    assert c.context_bytes == 3000 and c.flash_bytes == 7100
    assert c.ram_bytes == 1000 + 640 + 320
    assert c.margin() == pytest.approx(3 * (2.4e6 - 120) / 1040, rel=1e-12)
    assert c.first_margin(400e6) == pytest.approx(7 * (2.0e6 - 120) / 2000, rel=1e-12)
    # an image without initialised data: its RAM is the zeroed data alone
    monkeypatch.setattr(cost, "section_sizes", lambda p: {".bss": 900, ".text": 5})
    bare = cost.split_cost(SimpleNamespace(example_elf="x.elf"), rep, latency=3, first_latency=7)
    assert (bare.static_ram_bytes, bare.flash_bytes) == (900, 7000)
    monkeypatch.setattr(cost, "section_sizes", lambda p: {".data": 100, ".text": 5})
    assert cost.split_cost(SimpleNamespace(example_elf="x.elf"), rep, 3, 7).static_ram_bytes == 100
    one = ReplayResult(np.zeros((8, 3)), ticks, np.zeros(8, int), 640, 100.0, 400.0, 3000, 8,
                       np.zeros((8, 3)), np.where(np.arange(8) == 0, 500.0, 0.0))
    with pytest.raises(BuildError, match="ran 1 background samples"):
        cost.split_cost(SimpleNamespace(example_elf="x.elf"), one, 3, 7)


def test_solve_time_divides_by_the_instructions_per_cycle(monkeypatch):
    """At 2 instructions per cycle a sample takes half the time (IPC = 1 hides a * / mix-up)."""
    c = SimpleNamespace(solve_instructions_max=4.8e6)
    ms1 = cost.GuidedCost.solve_ms(c)
    monkeypatch.setattr(cost, "IPC", 2.0)
    assert cost.GuidedCost.solve_ms(c) == pytest.approx(ms1 / 2, rel=1e-14)
    assert ms1 == pytest.approx(4.8e6 / 480e6 * 1e3, rel=1e-14)
    assert cost.period_instructions(480e6, 2.0) == pytest.approx(4.8e6)
