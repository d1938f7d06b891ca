"""The symbolic Euler-Lagrange model (thesis App. C) against physics and reference data."""

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi import load_params
from ballbot_casadi.model.numeric import make_state


def _reference_params(ref, kind="nominal", beta=0.0):
    rp = ref["params"]
    kw = {k: rp[k] for k in ("Mb", "l", "Jbx", "Jby", "Jbz", "Jw", "rw", "rk", "Mk", "Jk",
                             "alpha", "gamma", "g", "Bvk", "Bvm", "Bvb")}
    kw.update(tau_max=rp["max_output_torque"], n_ticks=rp["TicksPrRev"], beta=beta)
    if kind == "plant_friction":
        kw.update(ref["plant_friction_values"])
    return load_params(**kw)


def _integrate(ode, x0, tau, p, t_grid, tol=1e-12):
    xs, us, ps = ca.MX.sym("x", 12), ca.MX.sym("u", 3), ca.MX.sym("p", 21)
    dae = {"x": xs, "p": ca.vertcat(us, ps), "ode": ode(xs, us, ps)}
    opts = {"abstol": tol, "reltol": tol, "max_num_steps": 200000}
    F = ca.integrator("F", "cvodes", dae, 0.0, list(t_grid), opts)
    return np.array(F(x0=x0, p=np.concatenate([tau, p]))["xf"]).T


def test_accelerations_match_independent_model(kugle_reference, model_functions):
    on = [r for r in kugle_reference["records"] if r["on_manifold"]]
    assert len(on) >= 10
    for rec in on:
        P = _reference_params(kugle_reference, rec["params"], rec["beta"])
        xdot = np.array(model_functions["ode"](rec["state"], rec["tau"], P.to_vector())).ravel()
        np.testing.assert_allclose(xdot[6:], rec["ddchi"], rtol=0, atol=1e-9, err_msg=rec["name"])
        np.testing.assert_allclose(xdot[:6], rec["state"][6:], rtol=0, atol=0)


def test_trajectories_match_independent_model(kugle_reference, model_functions):
    for rec in kugle_reference["trajectory_records"]:
        P = _reference_params(kugle_reference, rec["params"], rec["beta"])
        xf = _integrate(model_functions["ode"], rec["state0"], rec["tau"], P.to_vector(),
                        [rec["t_final"]])[-1]
        np.testing.assert_allclose(xf, rec["state_final"], rtol=0, atol=1e-8)


def test_upright_rest_is_equilibrium(model_functions, default_params):
    for yaw in (0.0, 1.0, -2.5):
        xdot = model_functions["ode"](make_state(yaw=yaw), [0, 0, 0], default_params.to_vector())
        np.testing.assert_allclose(np.array(xdot).ravel(), 0, atol=1e-13)


def test_energy_conserved_without_friction(model_functions, default_params):
    """Frictionless, zero torque, 10 s from a 5 deg tilt: energy and unit norm conserved."""
    p = default_params.to_vector()
    x0 = make_state(roll=np.radians(5.0), pitch=np.radians(1.0))
    t = np.linspace(0, 10, 201)[1:]
    xs = _integrate(model_functions["ode"], x0, np.zeros(3), p, t)
    E0 = float(model_functions["energy"](x0, p)[2])
    E = np.array([float(model_functions["energy"](x, p)[2]) for x in xs])
    T = np.array([float(model_functions["energy"](x, p)[0]) for x in xs])
    assert T.max() > 50.0  # the robot really fell over: a meaningful test
    assert np.max(np.abs(E - E0)) / abs(E0) <= 1e-6
    assert np.max(np.abs(np.linalg.norm(xs[:, 2:6], axis=1) - 1)) <= 1e-9


def test_friction_dissipates(model_functions, default_params):
    P = default_params.replace(Bvk=0.5, Bvm=0.01, Bvb=0.2)
    p = P.to_vector()
    x0 = make_state(roll=np.radians(5.0), dx=0.2, omega_body=[0.1, -0.2, 0.5])
    t = np.linspace(0, 3, 301)[1:]
    xs = _integrate(model_functions["ode"], x0, np.zeros(3), p, t)
    E = np.array([float(model_functions["energy"](x, p)[2]) for x in np.vstack([x0, xs])])
    assert np.all(np.diff(E) <= 1e-9 * abs(E[0]))
    assert E[-1] < E[0] - 1e-3


def test_power_balance(model_functions, default_params, rng):
    """dE/dt = tau . dphi - dissipation (work-energy theorem with Q = J_m^T tau, C.38)."""
    P = default_params.replace(Bvk=0.3, Bvm=0.02, Bvb=0.1)
    p = P.to_vector()
    xs = ca.SX.sym("x", 12)
    E = model_functions["energy"](xs, p)[2]
    dE = ca.Function("dE", [xs], [ca.jacobian(E, xs)])
    for _ in range(10):
        x = make_state(roll=rng.uniform(-0.3, 0.3), pitch=rng.uniform(-0.3, 0.3),
                       yaw=rng.uniform(-3, 3), dx=rng.normal(), dy=rng.normal(),
                       omega_body=rng.normal(size=3))
        tau = rng.normal(size=3)
        xdot = np.array(model_functions["ode"](x, tau, p)).ravel()
        dphi = np.array(model_functions["wheel_speeds"](x, p)).ravel()
        w_b = 2 * (np.array([[-x[3], x[2], x[5], -x[4]], [-x[4], -x[5], x[2], x[3]],
                             [-x[5], x[4], -x[3], x[2]]]) @ x[8:12])
        diss = P.Bvk * (x[6] ** 2 + x[7] ** 2) + P.Bvb * w_b @ w_b + P.Bvm * dphi @ dphi
        power = float(np.array(dE(x)).ravel() @ xdot)
        assert power == pytest.approx(tau @ dphi - diss, rel=1e-9, abs=1e-9)


def test_baumgarte_constraint_dynamics(model_functions, default_params, rng):
    """Off the manifold, h = |q|^2 - 1 obeys h'' + 2 beta h' + beta^2 h = 0 (C.64)."""
    p = default_params.to_vector()
    beta = default_params.beta
    for _ in range(10):
        x = rng.normal(size=12) * 0.3
        x[2:6] = x[2:6] / np.linalg.norm(x[2:6]) * rng.uniform(0.98, 1.02)
        xdot = np.array(model_functions["ode"](x, rng.normal(size=3), p)).ravel()
        q, dq, ddq = x[2:6], x[8:12], xdot[8:12]
        h, dh, ddh = q @ q - 1, 2 * q @ dq, 2 * q @ ddq + 2 * dq @ dq
        assert ddh + 2 * beta * dh + beta**2 * h == pytest.approx(0.0, abs=1e-10)


def test_jacobians_match_finite_differences(model_functions, default_params, rng):
    p = default_params.replace(Bvk=0.1, Bvm=0.01, Bvb=0.05, com_x=0.01).to_vector()
    ode, jac = model_functions["ode"], model_functions["jac"]
    for _ in range(5):
        x = make_state(roll=rng.uniform(-0.3, 0.3), pitch=rng.uniform(-0.3, 0.3),
                       yaw=rng.uniform(-3, 3), dx=rng.normal(), dy=rng.normal(),
                       omega_body=rng.normal(size=3))
        tau = rng.normal(size=3)
        A, B = (np.array(m) for m in jac(x, tau, p))
        h = 1e-6
        A_fd = np.column_stack([
            (np.array(ode(x + h * e, tau, p)) - np.array(ode(x - h * e, tau, p))).ravel() / (2 * h)
            for e in np.eye(12)])
        B_fd = np.column_stack([
            (np.array(ode(x, tau + h * e, p)) - np.array(ode(x, tau - h * e, p))).ravel() / (2 * h)
            for e in np.eye(3)])
        np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(B, B_fd, rtol=1e-6, atol=1e-7)


def test_affine_split_consistent_with_ode(model_functions, default_params, rng):
    p = default_params.to_vector()
    for _ in range(5):
        x = make_state(roll=rng.uniform(-0.3, 0.3), yaw=rng.uniform(-3, 3), dx=rng.normal(),
                       omega_body=rng.normal(size=3))
        tau = rng.normal(size=3)
        f, g = (np.array(m) for m in model_functions["affine"](x, p))
        xdot = np.array(model_functions["ode"](x, tau, p)).ravel()
        np.testing.assert_allclose(f.ravel() + g @ tau, xdot[6:], rtol=1e-12, atol=1e-12)


def test_equal_torques_at_upright_only_yaw(model_functions, default_params):
    p = default_params.to_vector()
    for yaw in (0.0, 0.8):
        xdot = np.array(model_functions["ode"](make_state(yaw=yaw), [0.5, 0.5, 0.5], p)).ravel()
        ddchi = xdot[6:]
        np.testing.assert_allclose(ddchi[:2], 0, atol=1e-13)  # no translation
        q = make_state(yaw=yaw)[2:6]
        # body angular acceleration = 2 v(q* o ddq) at rest: only the z component
        alpha_b = 2 * (np.array([[-q[1], q[0], q[3], -q[2]], [-q[2], -q[3], q[0], q[1]],
                                 [-q[3], q[2], -q[1], q[0]]]) @ ddchi[2:])
        np.testing.assert_allclose(alpha_b[:2], 0, atol=1e-13)
        assert abs(alpha_b[2]) > 1.0


def test_heading_invariance(model_functions, default_params, rng):
    """Rotating the whole robot about the vertical rotates its motion (isotropy of the floor)."""
    P = default_params
    p = P.to_vector()
    qz = np.array([np.cos(P.gamma / 2), 0, 0, np.sin(P.gamma / 2)])
    from ballbot_casadi.core import quaternion as Q

    Rz = Q.rotation_matrix(qz)
    x = make_state(roll=0.1, pitch=-0.07, yaw=0.3, dx=0.2, dy=-0.1, omega_body=[0.2, 0.1, -0.3])
    tau = rng.normal(size=3)
    # Rotated state: positions/velocities rotated, attitude qz o q, rates qz o dq.
    xr = x.copy()
    xr[0:2], xr[6:8] = (Rz @ np.r_[x[0:2], 0])[:2], (Rz @ np.r_[x[6:8], 0])[:2]
    xr[2:6], xr[8:12] = Q.mul(qz, x[2:6]), Q.mul(qz, x[8:12])
    a = np.array(model_functions["ode"](x, tau, p)).ravel()
    b = np.array(model_functions["ode"](xr, tau, p)).ravel()
    np.testing.assert_allclose(b[6:8], (Rz @ np.r_[a[6:8], 0])[:2], atol=1e-12)
    np.testing.assert_allclose(b[8:12], Q.mul(qz, a[8:12]), atol=1e-12)


def test_wheel_permutation_symmetry(model_functions, default_params, rng):
    """For an axisymmetric body, turning the body by gamma maps wheel i onto wheel i+1.

    With Jbx = Jby and no COM offset, a state whose body is yawed by an extra +gamma, driven
    by torques shifted one wheel (tau0, tau1, tau2) -> (tau2, tau0, tau1), moves exactly like
    the original: same ball motion, body rates rotated with it.
    """
    from ballbot_casadi.core import quaternion as Q

    P = default_params.replace(Jby=default_params.Jbx)
    p = P.to_vector()
    qg = np.array([np.cos(P.gamma / 2), 0, 0, np.sin(P.gamma / 2)])
    x = make_state(roll=0.1, pitch=-0.07, yaw=0.3, dx=0.2, dy=-0.1, omega_body=[0.2, 0.1, -0.3])
    tau = rng.normal(size=3)
    xs = x.copy()
    # body turned by -gamma about its own z: q' = q o qg*, so wheel i+1 sits where wheel i was
    xs[2:6], xs[8:12] = Q.mul(x[2:6], Q.conj(qg)), Q.mul(x[8:12], Q.conj(qg))
    a = np.array(model_functions["ode"](x, tau, p)).ravel()
    b = np.array(model_functions["ode"](xs, np.roll(tau, 1), p)).ravel()
    np.testing.assert_allclose(b[6:8], a[6:8], atol=1e-12)
    np.testing.assert_allclose(b[8:12], Q.mul(a[8:12], Q.conj(qg)), atol=1e-12)


def test_solution_satisfies_thesis_C68_form(model_functions, default_params, rng):
    """The projected LDL^T solve satisfies M~ ddchi + C~ dchi + G~ + D~ = Q~ tau (C.67, C.68)."""
    import casadi as ca

    from ballbot_casadi.model.dynamics import constrained_terms, symbols

    xs, _, ps = symbols()
    t = constrained_terms(xs, ps)
    f = ca.Function("thesis", [xs, ps], [t["Mt"], t["bt"], t["Qt"]])
    p = default_params.replace(Bvk=0.2, Bvb=0.1, Bvm=0.01, com_y=0.02).to_vector()
    for _ in range(10):
        x = rng.normal(size=12) * 0.5
        x[2:6] *= 1.0 / np.linalg.norm(x[2:6]) * rng.uniform(0.99, 1.01)
        tau = rng.normal(size=3)
        Mt, bt, Qt = (np.array(m) for m in f(x, p))
        dd = np.array(model_functions["ode"](x, tau, p)).ravel()[6:]
        np.testing.assert_allclose(Mt @ dd, bt.ravel() + Qt @ tau, rtol=1e-10, atol=1e-10)
