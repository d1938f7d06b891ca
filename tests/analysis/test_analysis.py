"""Linear analysis: reduction, controllability, zeros (analysis), bandwidths (closed_loop_analysis)."""

from __future__ import annotations

import numpy as np
import pytest

from ballbot_casadi import load_params
from ballbot_casadi.analysis import closed_loop as cla
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.errors import StateError
from ballbot_casadi.model import linearization as lz
from ballbot_casadi.model.dynamics import make_model_functions


@pytest.fixture(scope="module")
def funcs():
    return make_model_functions()


@pytest.fixture(scope="module")
def default(funcs):
    params = load_params()
    lin, result = an.analyze_plant(params, functions=funcs)
    return params, lin, result


@pytest.fixture(scope="module")
def offset_point(funcs):
    """A non-trivial operating point: COM offset (tilted balance), friction, rolling, heading."""
    params = load_params(com_x=0.015, com_y=-0.01, Bvk=0.4, Bvm=0.01, Bvb=0.05, beta=7.0)
    x0 = lz.parse_state_spec("yaw=37,dx=0.15,dy=-0.05,x=1.5", params)
    return params, lz.linearize(params, x0, funcs)


def _match(a, b, tol):
    """Greedy one-to-one matching of two eigenvalue lists; max distance."""
    rest = list(b)
    worst = 0.0
    for z in a:
        i = int(np.argmin(np.abs(np.array(rest) - z)))
        worst = max(worst, abs(rest.pop(i) - z))
    return worst <= tol


# ----------------------------------------------------------------- reduction


def test_tangent_basis_is_orthonormal_and_tangent():
    rng = np.random.default_rng(3)
    q0 = rng.normal(size=4)
    q0 /= np.linalg.norm(q0)
    T = lz.tangent_basis(q0)
    np.testing.assert_allclose(T.T @ T, np.eye(10), atol=1e-14)
    # q0^T delta q = 0 and (dq0 = 0) q0^T delta dq = 0 for every basis vector
    np.testing.assert_allclose(q0 @ T[2:6], 0.0, atol=1e-14)
    np.testing.assert_allclose(q0 @ T[8:12], 0.0, atol=1e-14)


@pytest.mark.parametrize("which", ["default", "offset_point"])
def test_reduced_eigenvalues_are_full_minus_constraint_modes(which, default, offset_point):
    if which == "default":
        params, lin, _ = default
    else:
        params, lin = offset_point
    assert lin.invariance_error < 1e-12
    full = lin.eig_full()
    red = lin.eig_reduced()
    expected = np.concatenate([red, [-params.beta, -params.beta]])
    # -beta is a defective double eigenvalue: perturbation ~ sqrt(eps) * beta
    assert _match(full, expected, 1e-6)
    assert _match(expected, full, 1e-6)


def test_linearisation_matches_finite_differences(offset_point, funcs):
    params, lin = offset_point
    ode, p = funcs["ode"], params.to_vector()
    x0, u0 = lin.op.x, lin.op.tau
    h = 1e-6
    A_fd = np.zeros((12, 12))
    for i in range(12):
        e = np.zeros(12)
        e[i] = h
        A_fd[:, i] = (np.asarray(ode(x0 + e, u0, p)) - np.asarray(ode(x0 - e, u0, p))).ravel() / (2 * h)
    B_fd = np.zeros((12, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        B_fd[:, i] = (np.asarray(ode(x0, u0 + e, p)) - np.asarray(ode(x0, u0 - e, p))).ravel() / (2 * h)
    np.testing.assert_allclose(lin.A, A_fd, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(lin.B, B_fd, rtol=1e-6, atol=1e-8)


def test_compiled_jacobians_give_the_same_linearisation(offset_point):
    from ballbot_casadi.codegen.libraries import load_model_library

    params, lin = offset_point
    lin_c = lz.linearize(params, lin.op.x, load_model_library())
    np.testing.assert_allclose(lin_c.A, lin.A, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(lin_c.B, lin.B, rtol=1e-11, atol=1e-12)


def test_operating_point_is_trimmed_equilibrium(offset_point, funcs):
    params, lin = offset_point
    xdot = np.asarray(funcs["ode"](lin.op.x, lin.op.tau, params.to_vector())).ravel()
    np.testing.assert_allclose(xdot[6:], 0.0, atol=1e-8)  # accelerations vanish
    np.testing.assert_allclose(xdot[:2], lin.op.x[6:8], atol=1e-14)  # steady rolling
    # the COM offset tilts the balanced body so that the COM is above the ball centre
    com = Q.rotate(lin.op.x[2:6], np.array([params.com_x, params.com_y, params.l]))
    assert abs(lin.op.rpy_deg()[2] - 37.0) < 0.5
    assert np.linalg.norm(com[:2]) < 0.2 * np.hypot(params.com_x, params.com_y)


# ----------------------------------------------------------------- default robot


def test_default_robot_fully_controllable(default):
    params, lin, result = default
    c = an.controllability(lin)
    assert result["n_states_reduced"] == 10
    assert c["rank"] == 10 and result["controllability_rank"] == 10
    assert all(e["controllable"] for e in c["pbh"])
    # the weakest modes are the ball-position rigid-body modes (torques reach x, y only
    # through the tilt); the unstable tilt modes are the cheapest to excite
    weak = c["weakest_mode"]
    assert set(weak["weakest_direction"]) <= {"x", "y", "dx", "dy"}
    unstable = [m for m in c["modes"] if m["eigenvalues"][0].real > 1]
    assert all(m["energy"] < weak["energy"] for m in unstable)


def test_uncontrollable_system_is_detected(default):
    """Removing the torque authority on one tilt axis must drop the rank and fail PBH."""
    params, lin, _ = default
    # inputs that only act through the pitch direction: project B onto its pitch part
    Br = lin.Br.copy()
    Br[[2, 7], :] = 0.0  # no direct roll (v1, dv1) authority
    Br[[1, 6], :] = 0.0  # and none on y (which roll drives)
    from dataclasses import replace

    c = an.controllability(replace(lin, Br=Br))
    assert c["rank"] < 10
    assert not all(e["controllable"] for e in c["pbh"])


def test_one_real_unstable_pair_per_tilt_axis(default):
    params, lin, result = default
    eig = lin.eig_reduced()
    unstable = eig[eig.real > 1e-6]
    assert unstable.size == 2
    np.testing.assert_allclose(unstable.imag, 0.0, atol=1e-12)
    for p in unstable:  # each comes with its stable mirror image -p
        assert np.min(np.abs(eig + p)) < 1e-9
    # one per axis: the eigenvectors are pure roll (v1) or pure pitch (v2) motions
    w, V = np.linalg.eig(lin.Ar)
    axes = set()
    for i in np.nonzero(w.real > 1e-6)[0]:
        v = np.abs(V[:, i])
        axes.add(int(np.argmax(v[[2, 3]])))
        assert v[4] < 1e-9 * v.max()  # no heading motion
    assert axes == {0, 1}
    assert result["unstable_poles"] == pytest.approx(sorted(unstable.real, reverse=True), rel=1e-12)


def test_right_half_plane_is_relative_to_the_magnitude():
    """Re z > 1e-6 max(1, |z|): 1e-5 + 100j is round-off on the imaginary axis (limit 1e-4),
    2e-4 + 100j is not; small zeros use the absolute 1e-6."""
    z = np.array([1e-5 + 100j, 2e-4 + 100j, 5e-7, 2e-6, -3.0, 0.5 + 0.1j])
    np.testing.assert_array_equal(an.right_half_plane(z), [2e-4 + 100j, 2e-6, 0.5 + 0.1j])


def test_position_channel_has_rhp_zeros_tilt_and_heading_do_not(default):
    params, lin, result = default
    assert len(result["rhp_zeros_position"]) == 2
    assert len(result["rhp_zeros_position_2x3"]) == 2
    assert result["rhp_zeros_tilt"] == [] and result["rhp_zeros_heading"] == []
    zeros = np.array([complex(*z) for z in result["channels"]["pose"]["zeros"]])
    # mirror pairs +-z: the non-minimum-phase zero of each axis with its LHP partner
    assert zeros.size == 4
    np.testing.assert_allclose(np.sort(zeros.real), -np.sort(zeros.real)[::-1], atol=1e-9)
    # the heading channel is a pure double integrator
    poles = np.array([complex(*z) for z in result["channels"]["heading"]["poles"]])
    np.testing.assert_allclose(poles, 0.0, atol=1e-6)  # defective: ~sqrt(eps)


def test_pole_and_zero_match_planar_hand_derivation(default):
    params, lin, result = default
    hand = an.planar_reduction(params)
    np.testing.assert_allclose(
        sorted(result["unstable_poles"]), sorted([hand["pole_pitch"], hand["pole_roll"]]), rtol=1e-10
    )
    np.testing.assert_allclose(
        sorted(result["rhp_zeros_position"]), sorted([hand["zero_pitch"], hand["zero_roll"]]), rtol=1e-8
    )
    # independent numbers for the thesis App. A robot (computed by hand from the formula)
    P = params
    z_pitch = np.sqrt(P.Mb * P.g * P.l / (P.Jby + P.Mb * P.l * (P.l + P.rk)))
    assert z_pitch == pytest.approx(2.9059, abs=1e-4)
    assert hand["pole_pitch"] == pytest.approx(3.7467, abs=1e-4)


@pytest.mark.parametrize(
    "overrides",
    [{"g": 4 * 9.81}, {"l": 0.3}, {"l": 0.7}, {"Mb": 25.0, "Jby": 6.0}, {"rk": 0.1, "Jw": 5e-3}],
)
def test_pole_and_zero_follow_parameters_like_the_hand_derivation(overrides, funcs):
    params = load_params(**overrides)
    lin = lz.linearize(params, None, funcs)
    eig = lin.eig_reduced()
    poles = np.sort(eig.real[eig.real > 1e-6])
    zeros = an.channel_poles_zeros(lin, "pose")["rhp_zeros"].real
    hand = an.planar_reduction(params)
    np.testing.assert_allclose(poles, sorted([hand["pole_pitch"], hand["pole_roll"]]), rtol=1e-9)
    np.testing.assert_allclose(np.sort(zeros), sorted([hand["zero_pitch"], hand["zero_roll"]]), rtol=1e-7)


def test_pole_and_zero_scale_with_sqrt_g(default, funcs):
    params, lin, result = default
    lin4 = lz.linearize(params.replace(g=4 * params.g), None, funcs)
    p4 = np.sort(lin4.eig_reduced().real)[-2:]
    np.testing.assert_allclose(p4, 2 * np.sort(result["unstable_poles"]), rtol=1e-10)
    z4 = np.sort(an.channel_poles_zeros(lin4, "pose")["rhp_zeros"].real)
    np.testing.assert_allclose(z4, 2 * np.sort(result["rhp_zeros_position"]), rtol=1e-8)


def test_pole_versus_com_height_follows_pendulum_physics(funcs):
    """A slender body (small Jb) falls slower when the COM is higher (p ~ sqrt(g/l)); the
    thesis' bulky body (Jb = 4.2 kg m^2 >> Mb l^2) falls faster, because the gravity torque
    Mb g l grows faster than the inertia Jb + Mb l^2."""
    ls = (0.3, 0.42, 0.6)

    def pole(**kw):
        return float(np.max(lz.linearize(load_params(**kw), None, funcs).eig_reduced().real))

    slender = [pole(l=l, Jbx=1e-3, Jby=1e-3) for l in ls]
    bulky = [pole(l=l) for l in ls]
    assert slender[0] > slender[1] > slender[2]
    assert bulky[0] < bulky[1] < bulky[2]


def test_results_do_not_depend_on_heading(default, funcs):
    params, lin, result = default
    lin30 = lz.linearize(params, lz.parse_state_spec("yaw=30", params), funcs)
    assert _match(lin30.eig_reduced(), lin.eig_reduced(), 1e-6)  # defective zero modes
    z30 = an.channel_poles_zeros(lin30, "pose")["zeros"]
    z0 = an.channel_poles_zeros(lin, "pose")["zeros"]
    np.testing.assert_allclose(np.sort(z30.real), np.sort(z0.real), rtol=1e-8, atol=1e-10)


# ----------------------------------------------------------------- numerics


def test_finite_gramian_double_integrator():
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    T = 2.0
    W = an.finite_gramian(A, B, T)
    np.testing.assert_allclose(W, [[T**3 / 3, T**2 / 2], [T**2 / 2, T]], rtol=1e-12)


def test_bandwidth_helpers_first_order_lag():
    w = np.logspace(-2, 2, 2001)
    H = 1.0 / (1j * w + 1.0)
    assert cla.bandwidth_3db(w, np.abs(H)) == pytest.approx(1.0, rel=1e-3)
    # |1 - H| = w / sqrt(1 + w^2) = 1/sqrt(2) at w = 1
    assert cla.bandwidth_sensitivity(w, H) == pytest.approx(1.0, rel=1e-3)
    assert cla.bandwidth_3db(w, np.ones_like(w)) is None


def test_zoh_matches_expm_series():
    A = np.array([[0.0, 1.0], [-4.0, -0.4]])
    B = np.array([[0.0], [1.0]])
    Ts = 0.05
    Phi, Gam = cla.zoh(A, B, Ts)
    # Gamma = A^-1 (Phi - I) B for invertible A
    np.testing.assert_allclose(Gam, np.linalg.solve(A, (Phi - np.eye(2)) @ B), rtol=1e-12)


# ----------------------------------------------------------------- operating points


def test_state_spec_formats():
    params = load_params()
    x = lz.parse_state_spec("x=1, y=-2, yaw=90, dx=0.1", params)
    np.testing.assert_allclose(x[:2], [1, -2])
    np.testing.assert_allclose(x[6:8], [0.1, 0])
    np.testing.assert_allclose(np.degrees(Q.to_rpy(x[2:6])), [0, 0, 90], atol=1e-12)
    full = np.zeros(12)
    full[2] = 1.0
    np.testing.assert_allclose(lz.parse_state_spec(",".join(map(str, full)), params), full)


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "empty"),
        ("foo=1", "key=value"),
        ("roll=abc", "not a number"),
        ("yaw=1,yaw=2", "twice"),
        ("1,2,3", "expected 12"),
        ("0,0,2,0,0,0,0,0,0,0,0,0", "norm"),
        ("roll=inf", "finite"),
    ],
)
def test_state_spec_errors(text, match):
    with pytest.raises(StateError, match=match):
        lz.parse_state_spec(text, load_params())


def test_non_equilibrium_and_moving_attitude_are_rejected(funcs):
    params = load_params()
    with pytest.raises(StateError, match="not an equilibrium"):
        lz.linearize(params, lz.parse_state_spec("roll=3", params), funcs)
    x = np.zeros(12)
    x[2] = 1.0
    x[9] = 0.1
    with pytest.raises(StateError, match="at rest"):
        lz.linearize(params, x, funcs)


# ----------------------------------------------------------------- closed loop


@pytest.fixture(scope="module")
def closed(default, funcs):
    params, lin, _ = default
    cl = cla.analyze_closed_loop(params, lin, funcs)
    return params, cl


def test_closed_loop_is_stable_and_inner_matches_continuous_flc(closed):
    params, cl = closed
    d = cl["closed_loop"]
    assert d["status"] == "ok"
    for key in ("inner", "outer"):
        assert d[key]["stable_apart_from_neutral"]
        assert d[key]["max_real_pole"] < 0
        np.testing.assert_allclose(d[key]["dc_gain"], 1.0, atol=2e-3)
    # inner loop: with exact feedback linearisation the tilt follows Kp / (s^2 + Kd s + Kp);
    # sampling at 200 Hz moves the -3 dB point by ~1 %
    assert cl["bandwidth_inner_hz"] == pytest.approx(d["inner_continuous_hz"], rel=0.03)
    from ballbot_casadi.control import default_balance_gains

    k = default_balance_gains("flc")
    assert d["inner_continuous_hz"] * 2 * np.pi == pytest.approx(
        cla._second_order_bw(k[0], k[3]), rel=1e-12
    )


def test_cascade_rule_verdict_is_consistent(closed):
    params, cl = closed
    bi, bo = cl["bandwidth_sensitivity_inner_hz"], cl["bandwidth_sensitivity_outer_hz"]
    assert bi > 0 and bo > 0
    assert cl["bandwidth_sensitivity_ratio"] == pytest.approx(bi / bo)
    assert cl["cascade_rule_ok"] == (bi / bo >= 3.0)
    # the outer (velocity) tracking bandwidth lies below the RHP zero limit ~ z/2
    assert bo * 2 * np.pi < an.planar_reduction(params)["zero_roll"] / 2
