"""Linear analysis on hand-built reduced models with known eigenvectors (closed-form references).

A reduced model is built in scaled coordinates as ``A_s = V diag(a) V^-1`` with a chosen
right eigenvector, then unscaled with :data:`STATE_SCALE`, so the modal energies, the
dominant states and the Gramian horizon of :func:`controllability` have closed forms:
for a simple real eigenvalue ``a`` with unit left eigenvector ``u``,
``u^T W(T) u = |u^T B|^2 (e^{2 a T} - 1) / (2 a)``.
"""

from __future__ import annotations

from dataclasses import replace

import control
import numpy as np
import pytest

from ballbot_casadi import load_params
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.errors import ShapeError
from ballbot_casadi.model import linearization as lz

NAMES = lz.REDUCED_STATE_NAMES


@pytest.fixture(scope="module")
def lin():
    return lz.linearize(load_params())


def _model(lin, a, V, B_s, tau_max=2.0):
    """LinearModel whose *scaled* reduced model is ``(V diag(a) V^-1, B_s)``."""
    S = an.STATE_SCALE
    A_s = V @ np.diag(a) @ np.linalg.inv(V)
    Ar = A_s * S[:, None] / S[None, :]
    Br = B_s * S[:, None] / tau_max
    return replace(lin, Ar=Ar, Br=Br, tau_max=tau_max)


def _energy(a, u, B, T):
    u = u / np.linalg.norm(u)
    return 1.0 / (float(np.sum((u @ B) ** 2)) * (np.exp(2 * a * T) - 1) / (2 * a))


A_EIG = np.array([0.7, -0.4, -1.1, -1.6, 1.9, -2.3, -2.9, -3.4, 0.3, -4.2])


def _setup(lin):
    v = np.zeros(10)
    v[[0, 1, 2]] = np.sqrt([0.8, 0.11, 0.09])  # mode 0 lives on x (80 %), y (11 %), v1 (9 %)
    V = np.eye(10)
    V[:, 0] = v
    rng = np.random.default_rng(5)
    B_s = rng.normal(size=(10, 3))
    return V, B_s, _model(lin, A_EIG, V, B_s)


def test_state_scaling_round_trips_the_hand_built_model(lin):
    V, B_s, m = _setup(lin)
    A, B = an.state_scaling(m)
    np.testing.assert_allclose(A, V @ np.diag(A_EIG) @ np.linalg.inv(V), atol=1e-12)
    np.testing.assert_allclose(B, B_s, atol=1e-12)


def test_state_scale_is_the_documented_envelope():
    """1 m, 5 deg tilt (quaternion units sin(2.5 deg)), 1 rad heading, 0.5 m/s, 20 deg/s, 1 rad/s."""
    t, r = np.sin(np.radians(2.5)), 0.5 * np.radians(20.0)
    np.testing.assert_allclose(an.STATE_SCALE, [1, 1, t, t, np.sin(0.5), 0.5, 0.5, r, r, 0.5],
                               rtol=1e-15)


def test_modal_energies_dominant_states_and_weakest_mode_match_closed_form(lin):
    V, B_s, m = _setup(lin)
    T = 0.8
    c = an.controllability(m, horizon=T)
    assert c["horizon"] == T and c["rank"] == 10 and c["n"] == 10
    assert all(e["controllable"] for e in c["pbh"])
    U = np.linalg.inv(V)  # rows: left eigenvectors
    by_eig = {round(md["eigenvalues"][0].real, 9): md for md in c["modes"]}
    assert sorted(by_eig) == sorted(np.round(A_EIG, 9))
    for i, a in enumerate(A_EIG):
        md = by_eig[round(a, 9)]
        assert md["energy"] == pytest.approx(_energy(a, U[i], B_s, T), rel=1e-7)
        assert len(md["eigenvalues"]) == 1
        if i == 0:
            # right eigenvector weights 0.8, 0.11, 0.09: all above 10 % of the largest
            assert md["dominant_states"] == ["x", "y", "v1"]
        else:
            assert md["dominant_states"] == [NAMES[i]]
    energies = {a: _energy(a, U[i], B_s, T) for i, a in enumerate(A_EIG)}
    a_weak = max(energies, key=energies.get)
    assert c["weakest_mode"]["eigenvalues"][0].real == pytest.approx(a_weak, abs=1e-9)
    assert c["weakest_mode"]["energy"] == pytest.approx(energies[a_weak], rel=1e-7)


def test_dominant_state_threshold_is_ten_percent_of_the_largest(lin):
    """Weights 0.8, 0.11, 0.09: 0.11 and 0.09 both exceed 0.1 * 0.8, nothing else does."""
    v = np.zeros(10)
    v[[3, 5, 9]] = np.sqrt([0.8, 0.11, 0.09])
    V = np.eye(10)
    V[:, 3] = v
    m = _model(lin, A_EIG, V, np.random.default_rng(2).normal(size=(10, 3)))
    md = {round(x["eigenvalues"][0].real, 9): x for x in an.controllability(m)["modes"]}
    assert md[round(A_EIG[3], 9)]["dominant_states"] == ["v2", "dx", "dv3"]
    # weights 0.9, 0.095, 0.005: the last is below 10 % of the largest
    v[[3, 5, 9]] = np.sqrt([0.9, 0.095, 0.005])
    V[:, 3] = v
    m = _model(lin, A_EIG, V, np.random.default_rng(2).normal(size=(10, 3)))
    md = {round(x["eigenvalues"][0].real, 9): x for x in an.controllability(m)["modes"]}
    assert md[round(A_EIG[3], 9)]["dominant_states"] == ["v2", "dx"]


def test_fast_mode_shortens_the_horizon_to_thirty_over_its_rate(lin):
    a = A_EIG.copy()
    a[7] = -60.0
    V, B_s, _ = _setup(lin)
    c = an.controllability(_model(lin, a, V, B_s), horizon=1.0)
    assert c["horizon"] == pytest.approx(30.0 / 60.0, rel=1e-12)


def test_uncontrolled_mode_is_flagged_by_pbh_and_rank(lin):
    V, B_s, _ = _setup(lin)
    B0 = B_s.copy()
    B0[6] = 0.0  # with V = I off column 0, mode 6 is decoupled: no input reaches it
    c = an.controllability(_model(lin, A_EIG, V, B0))
    assert c["rank"] == 9
    flagged = [e for e in c["pbh"] if not e["controllable"]]
    assert len(flagged) == 1 and flagged[0]["eigenvalue"].real == pytest.approx(A_EIG[6], abs=1e-9)


def test_the_rank_counts_the_singular_values_above_rtol_of_the_largest(lin):
    """Kalman rank = number of the Krylov matrix's singular values above ``rtol sigma_max``:
    with ``rtol`` set between two neighbours (geometric mean), exactly the ones above."""
    model = _setup(lin)[2]
    sv = np.asarray(an.controllability(model)["singular_values"], float)
    assert sv[0] > 1.1  # the largest is not 1: rtol * sigma_max and rtol / sigma_max differ
    # the docstring's Krylov matrix [B, A B, ..., A^9 B] of A / |A|_2, B / |B|_2 (scaled model)
    A, B = an.state_scaling(model)
    As, Bs = A / np.linalg.norm(A, 2), B / np.linalg.norm(B, 2)
    K = np.hstack([np.linalg.matrix_power(As, i) @ Bs for i in range(10)])
    np.testing.assert_allclose(sv, np.linalg.svd(K, compute_uv=False), rtol=1e-10)
    for k in range(len(sv) - 1):
        rtol = np.sqrt(sv[k] * sv[k + 1]) / sv[0]
        c = an.controllability(model, rtol=rtol)
        assert (c["rank"], c["rtol"]) == (k + 1, rtol), k


def test_mode_groups_pair_conjugates_and_repeated_eigenvalues():
    A = np.zeros((6, 6))
    A[:2, :2] = [[1.0, 2.0], [-2.0, 1.0]]  # 1 +- 2j
    A[2, 2] = A[3, 3] = -3.0
    A[4, 4], A[5, 5] = 0.5, -0.7
    groups = an.mode_groups(A)
    sizes = sorted((len(g), round(float(np.max(g.real)), 6)) for g in groups)
    assert sizes == [(1, -0.7), (1, 0.5), (2, -3.0), (2, 1.0)]
    pair = next(g for g in groups if np.any(g.imag != 0))
    np.testing.assert_allclose(sorted(pair.imag), [-2.0, 2.0], atol=1e-12)


def test_mode_groups_keep_mirrored_eigenvalues_apart():
    """The upright tilt's +-sqrt(g/l) and a mirrored complex pair (1 +- 2j, -1 +- 2j) are
    four groups: a group is a repeated value or a conjugate, never a negative."""
    A = np.zeros((6, 6))
    A[0, 0], A[1, 1] = 2.0, -2.0
    A[2:4, 2:4] = [[1.0, 2.0], [-2.0, 1.0]]
    A[4:6, 4:6] = [[-1.0, 2.0], [-2.0, -1.0]]
    sizes = sorted((len(g), round(float(np.max(g.real)), 6)) for g in an.mode_groups(A))
    assert sizes == [(1, -2.0), (1, 2.0), (2, -1.0), (2, 1.0)]


def test_unmatched_eigenvalues_are_the_full_models_own():
    """Each reduced eigenvalue takes its nearest full one (not its mirror): from a damped,
    unsymmetric spectrum the constraint's -10 and the unmatched -2 are left, in order."""
    full = [3.0, -2.0, -10.0, -1.0 + 1.5j, -1.0 - 1.5j, 2.0]
    reduced = [2.0 + 1e-9, 3.0, -1.0 - 1.5j, -1.0 + 1.5j]
    assert an.unmatched_eigenvalues(full, reduced) == [-2.0, -10.0]
    with pytest.raises(ShapeError, match=r"^3 reduced eigenvalues cannot be matched among 2$"):
        an.unmatched_eigenvalues([1.0, 2.0], [1.0, 2.0, 3.0])


def test_singular_values_of_a_known_system():
    """G(s) = diag(1/(s+1), 2/(s+3)): singular values sorted, |G(jw)| per channel."""
    sys = control.ss(np.diag([-1.0, -3.0]), np.diag([1.0, 2.0]), np.eye(2), np.zeros((2, 2)))
    w = np.array([0.0, 1.0, 10.0])
    sv = an.singular_values(sys, w)
    g1, g2 = 1 / np.sqrt(1 + w**2), 2 / np.sqrt(9 + w**2)
    np.testing.assert_allclose(sv, np.column_stack([np.maximum(g1, g2), np.minimum(g1, g2)]),
                               rtol=1e-12)


def test_singular_values_add_the_feedthrough_and_hold_for_an_unstable_pole():
    """G(s) = diag(1/(s-1) + 0.5, 2/(s+3) - 1): |G_1(jw)| = 0.5 at every w (an all-pass with
    an unstable pole), |G_2(jw)| = sqrt((1 + w^2)/(9 + w^2)); with D subtracted they differ."""
    sys = control.ss(np.diag([1.0, -3.0]), np.diag([1.0, 2.0]), np.eye(2), np.diag([0.5, -1.0]))
    w = np.array([0.0, 0.5, 2.0, 30.0])
    sv = an.singular_values(sys, w)
    g1, g2 = np.full_like(w, 0.5), np.sqrt((1 + w**2) / (9 + w**2))
    np.testing.assert_allclose(sv, np.column_stack([np.maximum(g1, g2), np.minimum(g1, g2)]),
                               rtol=1e-12)


def test_channel_outputs_pick_the_named_reduced_states(lin):
    for name, (idx, outs) in an.CHANNELS.items():
        sys = an.channel_system(lin, name)
        C = np.asarray(sys.C)
        assert C.shape == (len(idx), 10) and list(sys.output_labels) == list(outs)
        np.testing.assert_array_equal(np.argmax(C, axis=1), idx)
        assert np.count_nonzero(C) == len(idx)
    with pytest.raises(ShapeError, match=r"^unknown channel 'speed'; known: position, tilt, heading, pose$"):
        an.channel_system(lin, "speed")


def test_mode_groups_tolerance_scales_with_the_eigenvalue_above_one():
    """tol * max(1, |ref|): 100 and 100 + 5e-5 are one group (5e-5 <= 1e-4), 3 and 3 + 5e-6 are
    two (5e-6 > 3e-6), -0.5 and -0.5 - 5e-7 are one (5e-7 <= 1e-6, the floor of 1)."""
    A = np.diag([100.0, 100.0 + 5e-5, 3.0, 3.0 + 5e-6, -0.5, -0.5 - 5e-7])
    sizes = sorted((len(g), round(float(np.min(g.real)), 3)) for g in an.mode_groups(A))
    assert sizes == [(1, 3.0), (1, 3.0), (2, -0.5), (2, 100.0)]


def test_mode_groups_with_zero_tolerance_group_exactly_repeated_eigenvalues_only():
    """The bound is inclusive: with ``tol = 0`` an eigenvalue equal to a group's joins it,
    one 1 ulp away does not."""
    A = np.diag([2.0, 2.0, 2.0, np.nextafter(2.0, 3.0), -1.0])
    sizes = sorted(len(g) for g in an.mode_groups(A, tol=0.0))
    assert sizes == [1, 1, 3]


def _projector(V: np.ndarray) -> np.ndarray:
    Qm, _ = np.linalg.qr(V)
    return Qm @ Qm.T


def test_invariant_subspaces_of_a_complex_pair_and_a_real_mode_against_eigenvectors():
    """A non-normal 4 x 4 (a rotation block coupled into two real modes): the left and right
    invariant subspaces of the complex pair are spanned by the real and imaginary parts of
    its left / right eigenvectors (scipy's), of the real mode by its eigenvector."""
    import scipy.linalg as sla

    from ballbot_casadi.analysis.linear import _left_invariant_subspace, _right_invariant_subspace

    a, b = -0.5, 2.0
    A = np.array([[a, b, 0.7, -0.3], [-b, a, 0.2, 0.9], [0.0, 0.0, -1.0, 0.4], [0.0, 0.0, 0.0, -3.0]])
    T = np.array([[1.0, 0.3, 0.0, 0.2], [0.0, 1.0, 0.5, 0.0], [0.1, 0.0, 1.0, 0.0], [0.0, 0.2, 0.0, 1.0]])
    A = T @ A @ np.linalg.inv(T)                      # no structure left to lean on
    w, vl, vr = sla.eig(A, left=True, right=True)
    pair = np.abs(w.imag) > 1e-9
    assert pair.sum() == 2
    group = w[pair]
    k = np.flatnonzero(pair)[0]
    U = _left_invariant_subspace(A, group)
    V = _right_invariant_subspace(A, group)
    assert U.shape == (4, 2) and V.shape == (4, 2)
    np.testing.assert_allclose(U.T @ U, np.eye(2), rtol=0, atol=1e-12)
    np.testing.assert_allclose(_projector(U), _projector(np.column_stack([vl[:, k].real, vl[:, k].imag])),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(_projector(V), _projector(np.column_stack([vr[:, k].real, vr[:, k].imag])),
                               rtol=0, atol=1e-9)
    assert np.linalg.norm(_projector(U) - _projector(V)) > 0.1   # non-normal: they differ
    j = int(np.argmin(np.abs(w - (-3.0))))
    u = _left_invariant_subspace(A, w[j:j + 1])
    np.testing.assert_allclose(_projector(u), _projector(vl[:, j:j + 1].real), rtol=0, atol=1e-9)
