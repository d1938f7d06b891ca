"""BallbotPlant.fmu in independent importers against the Python model.

Scenario (open loop, reproducible fall): the robot starts at rest tilted by roll 0.2 rad
and pitch 0.1 rad with zero wheel torques and falls over; the model has no floor, so the
body swings through and oscillates under the ball.  The instability only amplifies
errors during the short fall, so tight integrators agree over the whole 5 s.
Reference: SciPy DOP853 (rtol = atol = 1e-13) on the CasADi ODE Function.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import casadi as ca
import numpy as np
import pytest
from _fmu_support import ALL_STATES, SENSORS, STATES, X0_NAMES, plant_build, python_rk4
from scipy.integrate import solve_ivp

from ballbot_casadi import load_params
from ballbot_casadi.fmi import package
from ballbot_casadi.fmi.build import build_tool
from ballbot_casadi.model.dynamics import make_model_functions
from ballbot_casadi.model.numeric import make_state

P = load_params()
PV = P.to_vector()
X0 = make_state(roll=0.2, pitch=0.1)
T_END = 5.0
DT = 0.005
N = int(round(T_END / DT))
TOL = 1e-6  # required state agreement over 5 s


@pytest.fixture(scope="module")
def plant():
    return plant_build()


@pytest.fixture(scope="module")
def reference():
    ode = make_model_functions()["ode"]
    t = np.arange(N + 1) * DT
    sol = solve_ivp(lambda _t, x: np.asarray(ode(x, np.zeros(3), PV)).ravel(), (0, T_END), X0,
                    method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    assert sol.success
    return t, sol.y.T


@pytest.fixture(scope="module")
def fmpy_cs(plant):
    from fmpy import simulate_fmu

    r = simulate_fmu(str(plant.fmu), fmi_type="CoSimulation", stop_time=T_END,
                     output_interval=DT, start_values=dict(zip(X0_NAMES, X0.tolist())),
                     output=list(STATES))
    return r["time"], np.column_stack([r[n] for n in STATES])


def test_the_scenario_really_falls(reference):
    _, X = reference
    tilt = 2 * np.arccos(np.clip(np.abs(X[:, 2]), 0, 1))
    assert tilt.max() > 2.0  # fell far past horizontal
    assert np.all(np.isfinite(X))


def test_fmpy_model_exchange_cvode_matches_python(plant, reference):
    from fmpy import simulate_fmu

    t, X = reference
    # The sensor sample instants are time events (every 5 ms): CVode restarts at each, so
    # it needs a tighter tolerance than without them (1e-12: 9.5e-7, 1e-13: 1.2e-7).
    r = simulate_fmu(str(plant.fmu), fmi_type="ModelExchange", solver="CVode",
                     relative_tolerance=1e-13, stop_time=T_END, output_interval=DT,
                     start_values=dict(zip(X0_NAMES, X0.tolist())), output=list(STATES),
                     record_events=False)
    Xm = np.column_stack([r[n] for n in STATES])
    np.testing.assert_allclose(r["time"], t, rtol=0, atol=1e-9)
    err = np.max(np.abs(Xm - X))
    print(f"fmpy ME (CVode, rtol 1e-13) vs Python DOP853: max state error {err:.3e}")
    assert err <= TOL


def test_fmpy_co_simulation_matches_python(reference, fmpy_cs):
    t, X = reference
    tc, Xc = fmpy_cs
    np.testing.assert_allclose(tc, t, rtol=0, atol=1e-9)
    err = np.max(np.abs(Xc - X))
    print(f"fmpy CS (RK4, 1 ms) vs Python DOP853: max state error {err:.3e}")
    assert err <= TOL
    # and the same RK4 in Python, step for step
    Xr = python_rk4(X0, np.zeros(3), PV, DT, N)
    np.testing.assert_allclose(Xc, Xr, rtol=0, atol=1e-10)  # rounding only


def test_libcosim_matches_fmpy(plant, fmpy_cs):
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_step_size(step_size=int(round(DT * 1e9)))
    idx = ex.add_local_slave(CosimLocalSlave(fmu_path=str(plant.fmu), instance_name="plant"))
    ref = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}
    for name, value in zip(X0_NAMES, X0):
        assert ex.real_initial_value(idx, ref[name], float(value))
    assert ex.boolean_initial_value(idx, ref["noise_on"], True)  # Integer/Boolean values too
    assert ex.integer_initial_value(idx, ref["seed"], 21)
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    vr = [ref[n] for n in STATES]
    sensors = [ref[n] for n in SENSORS]
    out, readings, samples = [], [], []
    for _ in range(N):
        assert ex.step()
        out.append(obs.last_real_values(idx, vr))
        readings.append(obs.last_real_values(idx, sensors))
        samples.append(obs.last_integer_values(idx, [ref["sensor_sample"]])[0])
    Xl = np.array(out)
    _, Xc = fmpy_cs
    err = np.max(np.abs(Xl - Xc[1:]))
    print(f"libcosim vs fmpy CS: max state difference {err:.3e}")
    np.testing.assert_allclose(Xl, Xc[1:], rtol=0, atol=1e-12)
    # the sensor readings with noise (seed 21) equal those of an fmpy run, up to the state
    # difference above amplified by the model (accelerations of the falling robot)
    from fmpy import simulate_fmu

    r = simulate_fmu(str(plant.fmu), fmi_type="CoSimulation", stop_time=T_END,
                     output_interval=DT, output=[*SENSORS, "sensor_sample"],
                     start_values={**dict(zip(X0_NAMES, X0.tolist())), "noise_on": True,
                                   "seed": 21})
    assert samples == r["sensor_sample"][1:].tolist() == list(range(1, N + 1))
    np.testing.assert_allclose(np.array(readings), np.column_stack([r[n] for n in SENSORS])[1:],
                               rtol=1e-10, atol=1e-10)


def test_casadi_daebuilder_reproduces_ode_and_jacobian(plant):
    f = make_model_functions()
    dae = ca.DaeBuilder("plant", str(plant.unzipped), {})
    assert dae.x() == list(ALL_STATES)
    assert dae.u() == ["tau0", "tau1", "tau2", "tau_dist0", "tau_dist1", "tau_dist2"]
    assert dae.provides_directional_derivatives()
    fmu_ode = dae.create("fmu_ode", ["x", "u"], ["ode"])
    fmu_jac = fmu_ode.factory("fmu_jac", ["x", "u"], ["jac:ode:x", "jac:ode:u"])
    xs = ca.SX.sym("x", 12)
    W = ca.Function("W", [xs], [ca.jacobian(f["wheel_speeds"](xs, PV), xs)])
    rng = np.random.default_rng(11)
    for _ in range(3):
        x = make_state(roll=rng.normal() * 0.2, pitch=rng.normal() * 0.2, yaw=rng.normal(),
                       dx=rng.normal(), dy=rng.normal(), omega_body=rng.normal(size=3))
        xw = np.r_[x, rng.normal(size=3) * 10]  # wheel angles: no influence on the dynamics
        u, d = rng.normal(size=3) * 0.5, rng.normal(size=3) * 0.5
        # the disturbance torque adds to the (unsaturated) motor torque
        np.testing.assert_allclose(np.asarray(fmu_ode(xw, np.r_[u, d])).ravel(),
                                   np.r_[np.asarray(f["ode"](x, u + d, PV)).ravel(),
                                         np.asarray(f["wheel_speeds"](x, PV)).ravel()],
                                   rtol=0, atol=1e-12)
        A, B = (np.asarray(m) for m in fmu_jac(xw, np.r_[u, d]))
        A0, B0 = (np.asarray(m) for m in f["jac"](x, u + d, PV))
        np.testing.assert_allclose(A, np.block([[A0, np.zeros((12, 3))],
                                                [np.asarray(W(x)), np.zeros((3, 3))]]),
                                   rtol=0, atol=1e-11)
        np.testing.assert_allclose(B, np.vstack([np.hstack([B0, B0]), np.zeros((3, 6))]),
                                   rtol=0, atol=1e-11)


def test_c_host_runs_the_binary_without_python(plant):
    exe = build_tool(plant, "host")
    tau = [0.02, -0.01, 0.005]
    res = subprocess.run([str(exe), str(plant.binary), plant.guid, "200", "0.005", *map(str, tau),
                          "0.002"], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    x0 = make_state(roll=0.002)
    ref = python_rk4(x0, np.array(tau), PV, 0.005, 200)[-1]
    assert out["t"] == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(out["x"], ref, rtol=0, atol=1e-12)
    bad = subprocess.run([str(exe), str(plant.binary), "{wrong}", "1", "0.005", "0", "0", "0",
                          "0"], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 4 and "wrong GUID" in bad.stderr


def test_c_host_is_rebuilt_when_the_shared_host_header_changes(plant, tmp_path, monkeypatch):
    exe = build_tool(plant, "host")
    src = tmp_path / "fmu"
    shutil.copytree(package.fmu_source_dir(), src)
    monkeypatch.setattr(package, "fmu_source_dir", lambda: src)
    assert build_tool(plant, "host") == exe  # same sources: the cached program
    header = src / package.HOST_HEADER
    header.write_text(header.read_text() + "\n/* changed */\n")
    changed = build_tool(plant, "host")
    assert changed != exe and changed.is_file()
