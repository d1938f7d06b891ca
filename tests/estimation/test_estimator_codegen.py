"""Code generation of the estimators: strict C99 build, compiled == symbolic, 10^6-step soak."""

from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest
from _estimation_synthetic import DT, imu, truth

import ballbot_casadi.estimation as E
from ballbot_casadi import load_params
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.toolchain import build_library, load_library
from ballbot_casadi.model.dynamics import make_model_functions

pytestmark = pytest.mark.needs_cc

PAR = load_params()
PV = PAR.to_vector()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    ws = make_model_functions()["wheel_speeds"]
    funcs = {n: E.build_estimator(n, ws if n.startswith("v") else None) for n in E.ESTIMATORS}
    lib = build_library("ballbot_estimators_test", list(funcs.values()),
                        root=tmp_path_factory.mktemp("estimators"))
    compiled = load_library(lib, [f.name() for f in funcs.values()])
    return funcs, compiled, lib


def _inputs(name: str, rng: np.random.Generator, z_nan: bool) -> list:
    tun = E.DEFAULT_TUNING[name]
    P0 = E.initial_state(name)[1]
    if name in ("qukf", "qekf"):
        x = np.r_[Q.from_rpy(0.04, -0.02, 0.9), 0.1, -0.2, 0.05]
        _, P = E.initial_state(name, x)
        acc = Q.rotate_inv(Q.from_rpy(0.05, -0.02, 0.9), [0, 0, PAR.g])
        z = np.r_[acc + 0.1 * rng.standard_normal(3), 0.1, -0.19, 0.06]
        args = [x, P * 30, z, tun.Q, tun.R, DT, PV]
    elif name in ("qukf_heading", "qekf_heading"):  # bias state(s), heading reading, a
        nb = tun.x0.size - 7
        x = np.r_[Q.from_rpy(0.04, -0.02, 0.9), 0.1, -0.2, 0.05, 0.003 * np.ones(nb)]
        _, P = E.initial_state(name, x)
        acc = Q.rotate_inv(Q.from_rpy(0.05, -0.02, 0.9), [0, 0, PAR.g])
        z = np.r_[acc + 0.1 * rng.standard_normal(3), 0.1, -0.19, 0.06, 0.91]
        args = [x, P * 30, z, tun.Q, tun.R, DT, PV, np.array([0.1, -0.2, 0.0])]
    else:
        att = np.r_[Q.from_rpy(0.04, -0.02, 0.9), 0.1, -0.2, 0.05]
        x = np.r_[0.2, -0.1, 0.3, 0.1, 0.0, 0.0, 0.01]
        z = np.r_[100 * rng.standard_normal(3), 0.3, 0.2, PAR.g]
        args = [x, P0, z, att, 1e-6 * np.eye(3), tun.Q, tun.R, DT, PV]
    if z_nan:
        args[2] = np.array(args[2], dtype=float)
        args[2][[0, 4]] = np.nan
    return args


@pytest.mark.parametrize("name", list(E.ESTIMATORS))
def test_compiled_equals_symbolic(built, name):
    funcs, compiled, _ = built
    f, c = funcs[name], compiled[f"ballbot_{name}"]
    assert c.name_in() == f.name_in() and c.name_out() == f.name_out()
    rng = np.random.default_rng(1)
    for z_nan in (False, True):
        args = _inputs(name, rng, z_nan)
        for a, b in zip(f(*args), c(*args)):
            a, b = np.asarray(a), np.asarray(b)
            assert np.all(np.isfinite(b))
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-14)


def test_generated_c_is_flat_where_it_is_timed_and_never_allocates(built):
    """The filters are generated as flat SX graphs (their sub-Functions inlined, common
    subexpressions shared: estimation.core.flat_function, issue 22's cost); the
    heading-aided QUKF keeps its conditional, whose two branches are flat."""
    funcs, _, lib = built
    src = lib.source.read_text()
    assert not re.search(r"\b(malloc|calloc|realloc|free)\s*\(", src)
    names = set(re.findall(r"/\* (\w+):\(", src))
    for n in ("qukf", "qekf", "vukf", "vekf", "qekf_heading"):
        f = funcs[n]
        assert f.is_a("SXFunction"), n
        assert not any(f.instruction_id(k) == ca.OP_CALL for k in range(f.n_instructions())), n
    # the models only these filters call, and the QUKF's linear algebra, are inlined
    for sub in ("att_process", "att_measurement", "vel_process", "vel_measurement",
                "ballbot_wheel_speeds", "kf_update6x6", "spd_repair6", "chol6"):
        assert sub not in names, sub
    assert funcs["qukf_heading"].is_a("MXFunction")
    assert {"qukf_heading_with_reading", "qukf_heading_without_reading"} <= names
    assert "att_heading_process" not in names


@pytest.mark.slow
def test_soak_compiled_qukf_stays_spd_for_a_million_periods(built):
    """10^6 periods (5000 s at 200 Hz) with 1 % dropouts and 0.1 % accelerometer shocks."""
    _, compiled, _ = built
    tun = E.DEFAULT_TUNING["qukf"]
    rng = np.random.default_rng(2020)
    n_total, chunk = 1_000_000, 100_000
    tr = truth(n_total * DT)
    z = imu(tr, rng, PAR.g)[:, 1:]
    z[rng.random(z.shape) < 0.01] = np.nan
    shocks = rng.random(n_total) < 0.001
    z[:3, shocks] += 3 * PAR.g * rng.standard_normal((3, shocks.sum()))
    run = compiled["ballbot_qukf"].mapaccum("soak", chunk, 2)
    x, P = E.initial_state("qukf")
    min_eig, repairs, asym = np.inf, 0.0, 0.0
    for s in range(0, n_total, chunk):
        out = run(x, P, z[:, s:s + chunk], tun.Q, tun.R, DT, PV)
        Xs = np.asarray(out[0])
        Ps = np.asarray(out[1]).reshape(6, 6, chunk, order="F").transpose(2, 0, 1)
        assert np.all(np.isfinite(Xs)) and np.all(np.isfinite(Ps))
        min_eig = min(min_eig, np.linalg.eigvalsh(Ps).min())
        asym = max(asym, np.abs(Ps - Ps.transpose(0, 2, 1)).max())
        repairs += float(np.asarray(out[5]).sum())
        x, P = Xs[:, -1], Ps[-1]
    assert min_eig > 0 and asym == 0
    assert repairs == 0
    # no renormalisation in 10^6 periods: rounding drift only (measured ~1e-12)
    assert abs(np.linalg.norm(x[:4]) - 1) < 1e-10
