"""The C benchmarks' outputs checked against the Functions they time: the comparison by
hand (count, size, tolerance scaled by the output's magnitude, non-finite values), and a
benchmark program linked against a library whose function is not the one the caller
names stopped with BuildError."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.bench import estimation as bench_estimation_mod
from ballbot_casadi.bench.verify import C_RTOL, check_c_outputs
from ballbot_casadi.core.toolchain import build_library
from ballbot_casadi.errors import BuildError


def test_equal_outputs_give_the_largest_difference():
    e = [np.array([[1.0, 3.0], [2.0, 4.0]]), np.array([0.5])]
    # C prints column-major nonzeros: 1, 2, 3, 4
    assert check_c_outputs("b", [[1.0, 2.0, 3.0, 4.0 + 2e-9], [0.5]], e) == pytest.approx(2e-9, rel=1e-6)
    assert check_c_outputs("b", [[]], [np.zeros(0)]) == 0.0


def test_the_tolerance_scales_with_the_largest_magnitude_at_least_one():
    assert C_RTOL == 1e-9
    big = np.array([1000.0, 0.0])
    check_c_outputs("b", [[1000.0, 0.9e-6]], [big])                  # 0.9e-6 <= 1e-9 * 1000
    with pytest.raises(BuildError, match=r"^b: output 0 of the C benchmark differs from the Function by 1.1e-06"):
        check_c_outputs("b", [[1000.0, 1.1e-6]], [big])
    check_c_outputs("b", [[0.9e-9]], [np.array([0.0])])              # small outputs: 1e-9 absolute
    with pytest.raises(BuildError, match="output 0"):
        check_c_outputs("b", [[1.1e-9]], [np.array([0.0])])


@pytest.mark.parametrize("c, e, msg", [
    ([[1.0]], [np.ones(1), np.ones(1)], "printed 1 outputs, the Function has 2"),
    ([[1.0, 2.0]], [np.ones(1)], "output 0 has 2 numbers in C, 1 in the Function"),
    ([[1.0], [math.nan]], [np.ones(1), np.ones(1)], "output 1 is not finite in C or in the Function"),
    ([[math.inf]], [np.array([math.inf])], "output 0 is not finite"),
])
def test_mismatches_name_the_benchmark_and_the_output(c, e, msg):
    with pytest.raises(BuildError, match=rf"^bench x: .*{msg}"):
        check_c_outputs("bench x", c, e)


@pytest.mark.needs_cc
def test_a_function_benchmark_of_another_function_is_refused(monkeypatch, tmp_path):
    """The library holds ``bench_probe`` = (x0 x1, x0 - x1); the caller claims it is
    (x0 x1, x0 + x1): the printed outputs give it away."""
    x, k = ca.SX.sym("x", 2), ca.SX.sym("k")
    f = ca.Function("bench_probe", [x, k], [x[0] * x[1], x[0] - x[1] * k])
    lib = build_library("bench_probe", [f], root=tmp_path / "lib")
    monkeypatch.setattr(bench_estimation_mod, "build_root", lambda: tmp_path)  # not the real bench's
    assert bench_estimation_mod.c_function_us(lib, f, [[1.5, -2.0], 3.0], 3) > 0
    g = ca.Function("bench_probe", [x, k], [x[0] * x[1], x[0] + x[1] * k])
    with pytest.raises(BuildError, match=r"^benchmark of bench_probe: output 1 of the C benchmark differs "
                                         r"from the Function by 12"):
        bench_estimation_mod.c_function_us(lib, g, [[1.5, -2.0], 3.0], 3)
