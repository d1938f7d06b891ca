"""Nothing the FMUs allocate outlives them: the C fuzzer of the FMI API (fmu/tools/fuzz.c),
built with AddressSanitizer, drives the plant and the controller FMU through thousands of
random calls (instances, states, steps, refusals) and frees every instance and state it
still holds at the end; LeakSanitizer then finds no leak and no bad free, in the FMUs or
in the fuzzer's own clean-up."""

from __future__ import annotations

import json
import subprocess

import pytest
from _controller_support import controller_build
from _fmu_support import plant_build, run_fuzz

from ballbot_casadi.errors import BuildError

pytestmark = pytest.mark.needs_cc

ASAN = "gcc -fsanitize=address -fno-omit-frame-pointer"


def _asan_fuzz(build, seed: int) -> subprocess.CompletedProcess:
    try:
        res = run_fuzz(build, "{lib}", "{guid}", "4000", str(seed), cc=ASAN, timeout=300,
                       env={"ASAN_OPTIONS": "detect_leaks=1:exitcode=23", "PATH": "/usr/bin:/bin"})
    except BuildError as exc:  # a compiler without the sanitizer's run-time library
        pytest.skip(f"AddressSanitizer is not available: {str(exc)[:200]}")
    for cannot in ("LeakSanitizer has encountered a fatal error", "does not work under ptrace",
                   "Shadow memory range interleaves"):
        if cannot in res.stderr:  # a sandbox where the sanitizer cannot run at all
            pytest.skip(f"AddressSanitizer cannot run here: {cannot}")
    return res


@pytest.mark.parametrize("which", ["plant", "controller"])
@pytest.mark.parametrize("seed", [5, 6])
def test_random_calls_leak_nothing(which, seed):
    build = plant_build() if which == "plant" else controller_build()
    res = _asan_fuzz(build, seed)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Sanitizer" not in res.stderr, res.stderr[-3000:]
    counts = json.loads(res.stdout)
    # the run made instances and took states, so the clean-up had something to free
    assert counts["init_ok"] > 0 and counts["ok"] > 100, counts
