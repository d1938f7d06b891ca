"""The C fuzzer of the FMI API (fmu/tools/fuzz.c) counts what it does: its tallies add up.

Every counted call is exactly one of ok / error / discard / other / bad_guid (a refused
instantiation with a wrong GUID), so ``calls`` is their sum; ``n_calls = 0`` makes no call at
all, one iteration makes at most one; a usage mistake exits 2 and an unloadable binary 3."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
from _broken_fmu import build_not_an_fmu
from _fmu_support import fuzz_counts, plant_build, run_fuzz

from ballbot_casadi.fmi.build import build_tool

pytestmark = pytest.mark.needs_cc

COUNTS = ("calls", "ok", "error", "discard", "other", "silent", "null_instance", "bad_guid",
          "steps_ok", "init_ok", "log_messages", "integer_ok", "integer_error", "boolean_ok",
          "boolean_error")


def _fuzz(*args: str) -> subprocess.CompletedProcess:
    return run_fuzz(plant_build(), *args)


def _counts(n: int, seed: int) -> dict[str, int]:
    out = fuzz_counts(plant_build(), n, seed)
    assert tuple(out) == COUNTS
    return out


def test_no_iterations_make_no_call():
    assert _counts(0, 1) == dict.fromkeys(COUNTS, 0)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_one_iteration_makes_at_most_one_call(seed):
    s = _counts(1, seed)
    assert s["calls"] + s["null_instance"] <= 1
    assert s["calls"] == s["ok"] + s["error"] + s["discard"] + s["other"] + s["bad_guid"]


@pytest.mark.parametrize("seed", [5, 6])
def test_every_counted_call_has_one_outcome(seed):
    s = _counts(4000, seed)
    assert s["calls"] + s["null_instance"] <= 4000
    assert s["calls"] == s["ok"] + s["error"] + s["discard"] + s["other"] + s["bad_guid"], s
    assert s["silent"] == 0, s
    assert s["steps_ok"] <= s["ok"] and s["init_ok"] <= s["ok"], s
    assert s["error"] + s["discard"] <= s["log_messages"], s  # every refusal logged


def test_usage_and_unloadable_binary_exit_statuses(tmp_path):
    res = _fuzz("{lib}", "{guid}", "10")  # no seed
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr == f"usage: {build_tool(plant_build(), 'fuzz')} lib guid n_calls seed\n"
    res = _fuzz(str(tmp_path / "none.so"), "{guid}", "10", "1")
    assert res.returncode == 3 and "dlopen failed" in res.stderr
    res = _fuzz(str(build_not_an_fmu(tmp_path)), "{guid}", "10", "1")   # loads, no FMI function
    assert (res.returncode, res.stdout, res.stderr) == (3, "", "missing symbol fmi2GetTypesPlatform\n")


# A fuzz failure is reported by its seed, so a seed must replay the same call sequence on any
# host (the fuzzer has its own generator, no libc rand). The tallies of seed 5 over 4000
# iterations, recorded when the fuzzer's value pool and operation mix were last reviewed, are
# pinned: a changed special value, weight or operation index changes them.
SEED5_4000 = {"calls": 3734, "ok": 1079, "error": 2633, "discard": 0, "other": 2, "silent": 0,
              "null_instance": 91, "bad_guid": 20, "steps_ok": 19, "init_ok": 46,
              "log_messages": 3003, "integer_ok": 11, "integer_error": 71, "boolean_ok": 18,
              "boolean_error": 64}


# and those of seed 6 (two records: a changed weight that leaves one seed's tallies alone,
# e.g. one more NULL value buffer in a few hundred reads, shows in the other's)
SEED6_4000 = {"calls": 3696, "ok": 1074, "error": 2612, "discard": 0, "other": 1, "silent": 0,
              "null_instance": 119, "bad_guid": 9, "steps_ok": 27, "init_ok": 59,
              "log_messages": 3004, "integer_ok": 10, "integer_error": 66, "boolean_ok": 10,
              "boolean_error": 76}


def test_a_seed_replays_the_same_calls():
    assert _counts(4000, 5) == SEED5_4000
    assert _counts(4000, 6) == SEED6_4000


def _draws(n: int, seed: int) -> tuple[list[float], list[int]]:
    res = _fuzz("--draws", str(n), str(seed))
    assert res.returncode == 0 and res.stderr == "", res.stderr
    rows = [ln.split() for ln in res.stdout.splitlines()]
    assert [r[0] for r in rows] == ["r"] * n + ["i"] * n
    return [float(r[1]) for r in rows[:n]], [int(r[1]) for r in rows[n:]]


def _key(v: float) -> str:
    """A value's identity: NaN, a signed zero and each special value apart."""
    if math.isnan(v):
        return "nan"
    return repr(v) if v != 0.0 else ("-0.0" if math.copysign(1, v) < 0 else "0.0")


def test_the_drawn_argument_values_are_the_pool_with_its_weights():
    """Reals: each of the eight special values, NaN, and +-Inf (one draw in 12 each; Inf's
    sign at even odds), else uniform in (-1, 1) times 10^[-3, 1); Integers: each of the eight
    special values one draw in 10, else any 32-bit value.  Counts within 6 standard
    deviations of a binomial."""
    n = 24000
    reals, ints = _draws(n, 7)

    def near(count, p):
        assert abs(count - n * p) <= 6 * math.sqrt(n * p * (1 - p)), (count, n * p)
    keys = [_key(v) for v in reals]
    for special in ("0.0", "-0.0", "1.0", "-1.0", "1e+300", "-1e+300", "1e-300", "0.5", "nan"):
        near(keys.count(special), 1 / 12)
    near(keys.count("inf"), 1 / 24)
    near(keys.count("-inf"), 1 / 24)
    rest = [v for v, k in zip(reals, keys) if k not in {
        "0.0", "-0.0", "1.0", "-1.0", "1e+300", "-1e+300", "1e-300", "0.5", "nan", "inf", "-inf"}]
    near(len(rest), 2 / 12)
    mag = np.abs(rest)
    assert mag.max() < 10.0 and (mag < 1e-2).any() and (mag > 1.0).any()
    near(int(np.sum(np.asarray(rest) < 0)), 1 / 12)  # either sign at even odds
    for special in (0, 1, -1, 2, 7, 2**31 - 1, -2**31, 123456789):
        near(ints.count(special), 1 / 10)
    assert all(-2**31 <= i < 2**31 for i in ints)
    wide = [i for i in ints if i not in (0, 1, -1, 2, 7, 2**31 - 1, -2**31, 123456789)]
    near(len(wide), 2 / 10)
    near(sum(i < 0 for i in wide), 1 / 10)
    again, ints_again = _draws(n, 7)  # the seed replays them (NaN compared by key)
    assert [_key(v) for v in again] == keys and ints_again == ints
    assert [_key(v) for v in _draws(50, 8)[0]] != keys[:50]
