"""Defaults and public names of the firmware and bench modules, read back: every name in a
module's ``__all__`` exists, the dataclasses' and functions' defaults are the documented
ones, and the refusals on the branches the other tests do not reach."""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path
from types import SimpleNamespace

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware import cost
from ballbot_casadi.firmware.build import FirmwareBuild
from ballbot_casadi.firmware.sources import background_functions, firmware_guidance

MODULES = ["ballbot_casadi.firmware", *(f"ballbot_casadi.firmware.{m}" for m in (
    "build", "closed_loop", "cost", "replay", "sources", "toolchain")),
    "ballbot_casadi.bench", *(f"ballbot_casadi.bench.{m}" for m in (
        "control", "estimation", "exports", "firmware", "fmpy_timing", "fmu", "fmu3", "guidance",
        "montecarlo"))]


@pytest.mark.parametrize("name", MODULES)
def test_every_public_name_exists(name):
    mod = importlib.import_module(name)
    names = getattr(mod, "__all__", [])
    assert [n for n in names if not hasattr(mod, n)] == []
    assert len(set(names)) == len(names)


def test_build_record_defaults():
    fw = FirmwareBuild(Path("/b"), "flc", "ukf", "double", "0" * 16)
    assert (fw.status, fw.guidance, fw.latency) == ("cached", None, 0)


def test_cost_function_defaults():
    assert cost.min_latency(0.4e6, 6.0e6) == 3  # margin 1: exactly 3 periods of 2 M free
    assert cost.min_latency(0.4e6, 6.0e6, clock_hz=400e6) == 4  # 1.6 M free a period
    assert cost.latency_margin(3, 0.4e6, 4e6) == pytest.approx(1.5, rel=1e-14)
    assert cost.latency_margin(3, 0.4e6, 4e6, ipc=0.5) == pytest.approx(3 * 0.8e6 / 4e6, rel=1e-14)
    assert cost.period_instructions(ipc=2.0) == pytest.approx(4.8e6, rel=1e-14)
    sig = inspect.signature(cost.arm_workspace_bytes)
    assert sig.parameters["precision"].default == "double"


def test_guided_cost_counts_a_missing_bss_as_zero(monkeypatch):
    import numpy as np

    monkeypatch.setattr(cost, "section_sizes", lambda p: {".data": 100})
    monkeypatch.setattr(cost, "size_text_data", lambda p: (7000, 0))
    r = SimpleNamespace(instructions_per_tick=1.0, ticks=np.array([9.0, 1, 2, 8, 1, 2]),
                        stack_bytes=40, ctx_bytes=500, real_bytes=8)
    c = cost.guided_cost(SimpleNamespace(example_elf="e"), r, 3, 10)
    assert (c.static_ram_bytes, c.flash_bytes, c.ram_bytes, c.guidance_data_bytes) == (
        100, 7100, 140, 80)
    monkeypatch.setattr(cost, "section_sizes", lambda p: {".bss": 50})
    r2 = SimpleNamespace(instructions_per_tick=1.0, ticks=np.ones(4), bg_ticks=np.array([5.0, 0, 3, 0]),
                         stack_bytes=10, bg_stack_bytes=20, ctx_bytes=1)
    s = cost.split_cost(SimpleNamespace(example_elf="e"), r2, 2, 3)
    assert (s.static_ram_bytes, s.flash_bytes, s.ram_bytes) == (50, 7000, 80)


def test_the_background_runs_only_the_split_mpcs_sample():
    with pytest.raises(ScenarioError, match=r"^the background task runs the MPC's sample, not "
                       r"'mpc''s$"):
        background_functions(SimpleNamespace(sample=None, name="mpc"))  # no sample split off
    with pytest.raises(ScenarioError, match="not 'pursuit''s"):
        background_functions(SimpleNamespace(sample=object(), name="pursuit"))
    assert [f.name() for f in background_functions(firmware_guidance("mpc", latency=2))] == [
        "ballbot_guidance_mpc_sample_next", "ballbot_guidance_mpc_sample_first"]
