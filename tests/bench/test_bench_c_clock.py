"""The benchmarks' C programs against a stand-in clock: compiled with a header that
replaces ``clock_gettime`` by a counter advancing one step per reading (1 ms, or 1.25 s to
carry seconds into nanoseconds) and counting its readings, every timed section lasts exactly
one step, so the printed figures are the program's own arithmetic: a step over N calls in
microseconds, and a step over the 200-period chunk (the ns -> us conversion, the divisions by
N and by the chunk, which result goes to which key), each section the best of five."""

from __future__ import annotations

import subprocess

import pytest

import casadi as ca

import ballbot_casadi.bench as bench_mod
from ballbot_casadi.bench import control as bench_control_mod
from ballbot_casadi.bench import estimation as bench_estimation_mod
from ballbot_casadi.bench.exports import control_bench_library
from ballbot_casadi.core.toolchain import build_library, compiler_command
from ballbot_casadi.errors import BuildError

pytestmark = pytest.mark.needs_cc

FAKE_CLOCK = """#define _POSIX_C_SOURCE 199309L /* as the program defines it */
#include <stdio.h>
#include <time.h>
#ifndef BENCH_FAKE_STEP_NS
#define BENCH_FAKE_STEP_NS 1000000LL
#endif
static long long bench_fake_ns, bench_fake_reads;
static void bench_fake_report(void) __attribute__((destructor));
static void bench_fake_report(void) { fprintf(stderr, "clock reads %lld\\n", bench_fake_reads); }
static inline int bench_fake_clock(clockid_t id, struct timespec *ts) {
  (void)id;
  ++bench_fake_reads;
#ifdef BENCH_FAKE_GROW /* the n-th reading advances by n steps: each section its own length */
  bench_fake_ns += BENCH_FAKE_STEP_NS * bench_fake_reads;
#else
  bench_fake_ns += BENCH_FAKE_STEP_NS;
#endif
  ts->tv_sec = (time_t)(bench_fake_ns / 1000000000);
  ts->tv_nsec = (long)(bench_fake_ns % 1000000000);
  return 0;
}
#define clock_gettime bench_fake_clock
"""

#: Each timed section is the best of this many repetitions (the programs' documented count).
REPEATS = 5


def _fake_clock(monkeypatch, module, tmp_path, step_ns: float, grow: bool = False) -> None:
    """Build ``module``'s benchmark program under ``tmp_path`` on the stand-in clock of
    reading step ``step_ns`` (with ``grow``, the n-th reading advances by n steps, so a
    section timed between readings n - 1 and n lasts n steps)."""
    header = tmp_path / "fake_clock.h"
    header.write_text(("#define BENCH_FAKE_GROW\n" if grow else "")
                      + f"#define BENCH_FAKE_STEP_NS {int(step_ns)}LL\n" + FAKE_CLOCK)
    monkeypatch.setattr(module, "build_root", lambda: tmp_path)  # not the real bench's binary
    monkeypatch.setattr(module, "compiler_command", lambda: [*compiler_command(), "-include", str(header)])


def _clock_reads(res: subprocess.CompletedProcess) -> int:
    """The stand-in clock's reading count, printed by it at the program's exit."""
    assert res.returncode == 0, res.stderr
    line = res.stderr.strip().splitlines()[-1]
    assert line.startswith("clock reads "), res.stderr
    return int(line.split()[-1])


# a reading step of 1 ms, or of 1.25 s (the seconds carried into the nanoseconds)
@pytest.mark.parametrize("n_calls, step_ns", [(50, 1e6), (8, 1e6), (8, 1.25e9)])
def test_control_bench_program_reports_its_sections_in_microseconds(monkeypatch, tmp_path, n_calls,
                                                                   step_ns):
    _fake_clock(monkeypatch, bench_control_mod, tmp_path, step_ns)
    _, inputs = bench_control_mod.mission_inputs(0.1)
    data = bench_control_mod._c_bench(control_bench_library(), inputs, n_calls)
    per_call = step_ns / n_calls / 1000.0
    assert data == pytest.approx({"control_step_us": per_call, "control_step_smc_us": per_call,
                                  "cl_period_us": per_call, "cl_chunk_period_us": step_ns / 200 / 1000.0},
                                 rel=0, abs=5e-5)  # printed with 4 decimals
    # best of REPEATS: a start and a stop reading per repetition of the chunk and of each of
    # the three per-call sections
    exe, inp = tmp_path / "bench" / "bench_control", tmp_path / "bench" / "bench_control_input.txt"
    res = subprocess.run([str(exe), str(n_calls), str(inp)], capture_output=True, text=True)
    assert _clock_reads(res) == 2 * REPEATS * (1 + 3)


@pytest.mark.parametrize("n_calls", [8, 50])
def test_control_bench_program_gives_each_section_its_own_key(monkeypatch, tmp_path, n_calls):
    """On a clock whose n-th reading advances n steps, each timed section lasts its stop
    reading's number of steps, so the keys tell the sections apart: the chunk's five
    repetitions take readings 1-10, then each repetition times the FLC step, the SMC step and
    the closed-loop period in turn (readings 11-12, 13-14, 15-16 the first time); the best of
    five is each section's first repetition."""
    step_ns = 1e6
    _fake_clock(monkeypatch, bench_control_mod, tmp_path, step_ns, grow=True)
    _, inputs = bench_control_mod.mission_inputs(0.1)
    data = bench_control_mod._c_bench(control_bench_library(), inputs, n_calls)
    us = step_ns / 1000.0
    assert data == pytest.approx({"control_step_us": 12 * us / n_calls, "control_step_smc_us": 14 * us / n_calls,
                                  "cl_period_us": 16 * us / n_calls, "cl_chunk_period_us": 2 * us / 200},
                                 rel=0, abs=5e-5)  # printed with 4 decimals


@pytest.mark.parametrize("n_calls, step_ns", [(1, 1e6), (40, 1e6), (40, 1.25e9)])
def test_function_bench_program_reports_microseconds_per_call_down_to_one_call(monkeypatch, tmp_path, n_calls,
                                                                               step_ns):
    """``bench_function.c`` on a small Function: one reading step over N calls, in
    microseconds; a single call is a valid run (N >= 1)."""
    x = ca.SX.sym("x", 2)
    f = ca.Function("bench_probe", [x, ca.SX.sym("k")], [ca.vertcat(x[0] * x[1], x[0] - x[1])])
    lib = build_library("bench_probe", [f], root=tmp_path / "lib")
    _fake_clock(monkeypatch, bench_estimation_mod, tmp_path, step_ns)
    us = bench_estimation_mod.c_function_us(lib, f, [[1.5, -2.0], 3.0], n_calls)
    assert us == pytest.approx(step_ns / n_calls / 1000.0, rel=0, abs=5e-5)
    exe = tmp_path / "bench" / f"bench_{f.name()}_{lib.digest}"
    res = subprocess.run([str(exe), str(n_calls), str(tmp_path / "bench" / f"bench_{f.name()}_input.txt")],
                         capture_output=True, text=True)
    assert _clock_reads(res) == 2 * REPEATS  # best of REPEATS


@pytest.mark.parametrize("n_calls", [3, 40])
def test_model_bench_program_reports_nanoseconds_per_call(monkeypatch, tmp_path, n_calls):
    """``bench_model.c``: the ODE timed over N calls, the Jacobian over N / 4 + 1, each the
    best of REPEATS; a reading step of 1.25 s carries the seconds into the nanoseconds."""
    _fake_clock(monkeypatch, bench_mod, tmp_path, 1.25e9)
    monkeypatch.setattr(bench_mod, "_python_call_ns", lambda: 7.0)  # not timed here
    data = bench_mod.bench_model(n_calls)
    assert data["ode_ns"] == pytest.approx(1.25e9 / n_calls, rel=0, abs=0.005)  # 2 decimals
    assert data["jac_ns"] == pytest.approx(1.25e9 / (n_calls // 4 + 1), rel=0, abs=0.005)
    assert data["python_over_c_ratio"] == pytest.approx(7.0 / data["ode_ns"], rel=1e-12)
    exe = tmp_path / "bench" / "bench_model"
    args = [repr(float(v)) for v in (*bench_mod.BENCH_STATE, *bench_mod.BENCH_TAU,
                                      *bench_mod.load_params().to_vector())]
    res = subprocess.run([str(exe), str(n_calls), *args], capture_output=True, text=True)
    assert _clock_reads(res) == 2 * REPEATS * 2  # the ODE's and the Jacobian's sections
    # exactly the model's parameters: one fewer or one more is refused, not zero-filled or cut
    n_p = bench_mod.load_params().to_vector().size
    for given in (args[:-1], [*args, "1.0"]):
        res = subprocess.run([str(exe), str(n_calls), *given], capture_output=True, text=True)
        assert (res.returncode, res.stdout, res.stderr) == (
            2, "", f"bench_model: expected {n_p} parameters, got {len(given) - 15}\n"
                   "clock reads 0\n")  # refused before anything is timed (the stand-in's count)


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
