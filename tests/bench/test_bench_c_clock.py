"""The benchmarks' C programs against a stand-in clock: compiled with a header that
replaces ``clock_gettime`` by a counter advancing 1 ms per reading, every timed section
lasts exactly 1 ms, so the printed figures are the program's own arithmetic: 1 ms over N
calls in microseconds, and 1 ms over the 200-period chunk (the ns -> us conversion, the
divisions by N and by the chunk, which result goes to which key)."""

from __future__ import annotations

import subprocess

import pytest

import casadi as ca

from ballbot_casadi.bench import control as bench_control_mod
from ballbot_casadi.bench import estimation as bench_estimation_mod
from ballbot_casadi.bench.exports import control_bench_library
from ballbot_casadi.core.toolchain import build_library, compiler_command
from ballbot_casadi.errors import BuildError

pytestmark = pytest.mark.needs_cc

FAKE_CLOCK = """#define _POSIX_C_SOURCE 199309L /* as the program defines it */
#include <time.h>
static long long bench_fake_ns;
static inline int bench_fake_clock(clockid_t id, struct timespec *ts) {
  (void)id;
  bench_fake_ns += 1000000;
  ts->tv_sec = (time_t)(bench_fake_ns / 1000000000);
  ts->tv_nsec = (long)(bench_fake_ns % 1000000000);
  return 0;
}
#define clock_gettime bench_fake_clock
"""


@pytest.mark.parametrize("n_calls", [50, 8])
def test_control_bench_program_reports_its_sections_in_microseconds(monkeypatch, tmp_path, n_calls):
    header = tmp_path / "fake_clock.h"
    header.write_text(FAKE_CLOCK)
    monkeypatch.setattr(bench_control_mod, "build_root", lambda: tmp_path)  # not the real bench's binary
    monkeypatch.setattr(bench_control_mod, "compiler_command", lambda: [*compiler_command(), "-include", str(header)])
    _, inputs = bench_control_mod.mission_inputs(0.1)
    data = bench_control_mod._c_bench(control_bench_library(), inputs, n_calls)
    per_call = 1e6 / n_calls / 1000.0
    assert data == pytest.approx({"control_step_us": per_call, "control_step_smc_us": per_call,
                                  "cl_period_us": per_call, "cl_chunk_period_us": 1e6 / 200 / 1000.0},
                                 rel=0, abs=5e-5)  # printed with 4 decimals


@pytest.mark.parametrize("n_calls", [1, 40])
def test_function_bench_program_reports_microseconds_per_call_down_to_one_call(monkeypatch, tmp_path, n_calls):
    """``bench_function.c`` on a small Function: 1 ms over N calls, in microseconds; a
    single call is a valid run (N >= 1)."""
    header = tmp_path / "fake_clock.h"
    header.write_text(FAKE_CLOCK)
    x = ca.SX.sym("x", 2)
    f = ca.Function("bench_probe", [x, ca.SX.sym("k")], [ca.vertcat(x[0] * x[1], x[0] - x[1])])
    lib = build_library("bench_probe", [f], root=tmp_path / "lib")
    monkeypatch.setattr(bench_estimation_mod, "build_root", lambda: tmp_path)
    monkeypatch.setattr(bench_estimation_mod, "compiler_command", lambda: [*compiler_command(), "-include", str(header)])
    us = bench_estimation_mod.c_function_us(lib, f, [[1.5, -2.0], 3.0], n_calls)
    assert us == pytest.approx(1e6 / n_calls / 1000.0, rel=0, abs=5e-5)


def test_control_bench_program_reads_at_most_its_buffers_and_refuses_the_rest(monkeypatch, tmp_path):
    """The input file's five counts (parameters, FLC, SMC and velocity gains, controller
    state) are bounded by the program's buffers (128 entries; the state with the 12 plant
    states): exactly full runs, one more, a short file or no file exits 2 with one line."""
    monkeypatch.setattr(bench_control_mod, "build_root", lambda: tmp_path)
    _, inputs = bench_control_mod.mission_inputs(0.1)
    bench_control_mod._c_bench(control_bench_library(), inputs, 1)
    exe, good = tmp_path / "bench" / "bench_control", tmp_path / "bench" / "bench_control_input.txt"
    lines = good.read_text().splitlines()
    counts = [int(c) for c in lines[0].split()]
    assert len(lines) == 9 and counts[0] < 128 and counts[4] < 116

    def run(count_index: int, n: int, line: int) -> subprocess.CompletedProcess:
        c, rows = list(counts), list(lines)
        c[count_index] = n
        rows[0] = " ".join(map(str, c))
        rows[line] = " ".join(rows[line].split() + ["0.0"] * (n - counts[count_index]))
        f = tmp_path / f"in_{count_index}_{n}.txt"
        f.write_text("\n".join(rows) + "\n")
        return subprocess.run([str(exe), "1", str(f)], capture_output=True, text=True)

    malformed = "bench_control: malformed input file\n"
    for count_index, line, full in ((0, 1, 128), (3, 4, 128), (4, 6, 116)):
        assert run(count_index, full, line).returncode == 0
        res = run(count_index, full + 1, line)
        assert (res.returncode, res.stderr, res.stdout) == (2, malformed, "")
    short = tmp_path / "short.txt"
    short.write_text("\n".join(lines[:-1]) + "\n")  # no velocity reference
    res = subprocess.run([str(exe), "1", str(short)], capture_output=True, text=True)
    assert (res.returncode, res.stderr) == (2, malformed)
    for args in ([], ["1"], ["1", str(tmp_path / "missing.txt")]):
        res = subprocess.run([str(exe), *args], capture_output=True, text=True)
        assert (res.returncode, res.stderr) == (2, "usage: bench_control N_CALLS INPUT_FILE\n")


def test_function_bench_program_refuses_bad_calls_and_flags_a_nan(tmp_path, monkeypatch):
    """``bench_function.c``: usage, a call count below one, a missing or short input file exit
    2 with one line; a NaN output is refused by the caller, as is a failed run."""
    x = ca.SX.sym("x", 2)
    f = ca.Function("bench_nan_probe", [x, ca.SX.sym("k")], [ca.sqrt(x[0]) * x[1]])
    lib = build_library("bench_nan_probe", [f], root=tmp_path / "lib")
    monkeypatch.setattr(bench_estimation_mod, "build_root", lambda: tmp_path)
    assert bench_estimation_mod.c_function_us(lib, f, [[4.0, 2.0], 1.0], 3) > 0.0
    with pytest.raises(BuildError, match=r"^benchmark of bench_nan_probe produced a non-finite output$"):
        bench_estimation_mod.c_function_us(lib, f, [[-4.0, 2.0], 1.0], 3)
    exe = tmp_path / "bench" / f"bench_{f.name()}_{lib.digest}"
    data = tmp_path / "bench" / f"bench_{f.name()}_input.txt"
    short = tmp_path / "short.txt"
    short.write_text("4.0 2.0\n")  # the second input (k) missing
    for args, code, err in (
            ([], 2, "usage: bench_function N_CALLS INPUT_FILE\n"),
            (["1", str(data), "x"], 2, "usage: bench_function N_CALLS INPUT_FILE\n"),
            (["0", str(data)], 2, f"bench_function: cannot read {data}\n"),
            (["1", str(tmp_path / "none.txt")], 2, f"bench_function: cannot read {tmp_path / 'none.txt'}\n"),
            (["1", str(short)], 2, "bench_function: input 1 needs 1 numbers\n")):
        res = subprocess.run([str(exe), *args], capture_output=True, text=True)
        assert (res.returncode, res.stderr, res.stdout) == (code, err, ""), args
    short.write_text("4.0\n")
    res = subprocess.run([str(exe), "1", str(short)], capture_output=True, text=True)
    assert (res.returncode, res.stderr) == (2, "bench_function: input 0 needs 2 numbers\n")
