"""Tests of the classic / nonlinear / polynomial / OpenCV solvers (issue 2, sections 4 and 7).

Every test asserts numbers. Problems are synthetic: ``H`` random motions, ``C = X H X^-1``,
optionally perturbed with the paper's eq. (38) noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from simcalib.geometry import (invert_transform, matrix_from_rotvec, perturb_transforms,
                               random_rotation_matrices, rotation_error_rad,
                               transform_from_rotation_translation, translation_error_m)
from simcalib.solvers import get
from simcalib.solvers.api import Prior, dq_cost, solve
from simcalib.solvers.problem import build_problem

MY_METHODS = ["dqoptpoly", "daniilidis", "chvecopt", "quatvecopt", "dqnlopt", "dqnloptrnd",
              "opencv_tsai", "opencv_park", "opencv_horaud", "opencv_andreff",
              "opencv_daniilidis"]
SIGMA_R = np.deg2rad(0.57)   # paper Table 2 noise
SIGMA_T = 0.01


def random_X(rng):
    return transform_from_rotation_translation(random_rotation_matrices(rng),
                                               rng.normal(0.0, 0.3, 3))


def random_problem(rng, n=100, sigma_r=0.0, sigma_t=0.0):
    """Paper D.2 'Random': rotations uniform on SO(3), translations U(0, 1)^3."""
    X = random_X(rng)
    H = transform_from_rotation_translation(random_rotation_matrices(rng, (n,)),
                                            rng.uniform(0.0, 1.0, (n, 3)))
    C = X @ H @ invert_transform(X)
    if sigma_r or sigma_t:
        C = perturb_transforms(C, sigma_r, sigma_t, rng)
        H = perturb_transforms(H, sigma_r, sigma_t, rng)
    return X, C, H


def circle_problem(rng, n=100, poses=200):
    """Paper D.2 'Circle': one revolution of radius 2 m about z, random pairs of poses,
    jitter (0.57 deg, 1 cm) before mapping through X, then the same measurement noise."""
    X = transform_from_rotation_translation(
        matrix_from_rotvec(np.deg2rad([2.35, -0.92, -48.93])), [-0.007, 0.281, -0.001])
    th = np.linspace(0.0, 2 * np.pi, poses, endpoint=False)
    P = transform_from_rotation_translation(
        matrix_from_rotvec(np.outer(th + np.pi / 2, [0.0, 0.0, 1.0])),
        np.c_[2 * np.cos(th), 2 * np.sin(th), np.zeros(poses)])
    i = rng.integers(0, poses, n)
    j = (i + rng.integers(1, poses, n)) % poses
    dP1 = perturb_transforms(invert_transform(P[i]) @ P[j], SIGMA_R, SIGMA_T, rng)
    dP2 = X @ dP1 @ invert_transform(X)
    return (X, perturb_transforms(dP2, SIGMA_R, SIGMA_T, rng),
            perturb_transforms(dP1, SIGMA_R, SIGMA_T, rng))


def rel(a, b):
    return (a - b) / abs(b)


# --------------------------------------------------------------------- registry
def test_all_methods_registered_with_metadata():
    for name in MY_METHODS:
        info = get(name)
        assert info.name == name
    assert not any(get(m).uses_alpha for m in MY_METHODS if m.startswith("opencv_"))
    for m in ("dqoptpoly", "dqnlopt", "dqnloptrnd"):
        assert get(m).supports_prior
    assert get("dqnloptrnd").stochastic and get("dqnloptrnd").extra["n_starts"] == 20


# ---------------------------------------------------------------- noise-free
@pytest.mark.parametrize("method", MY_METHODS)
def test_noise_free_recovers_X(method):
    """Exact data: X to 1e-9 for every method (measured: <= 3e-13, OpenCV Park worst)."""
    rng = np.random.default_rng(2024)
    for alpha in (0.3, 1.0, 3.0):
        X, C, H = random_problem(rng, n=12)
        sol = solve(C, H, method, alpha=alpha, rng=np.random.default_rng(1))
        assert sol.success, sol.solver_message
        assert np.abs(sol.X - X).max() < 1e-9
        assert sol.cost < 1e-18


def test_dqoptpoly_noise_free_uses_null_space_and_is_exact():
    X, C, H = random_problem(np.random.default_rng(3), n=30)
    sol = solve(C, H, "dqoptpoly", alpha=0.7)
    assert sol.diagnostics["route"].startswith("null space")
    assert np.abs(sol.X - X).max() < 1e-12


# ---------------------------------------------------------------- noisy data
@pytest.fixture(scope="module")
def noisy_problems():
    rng = np.random.default_rng(77)
    return [random_problem(rng, 100, SIGMA_R, SIGMA_T) for _ in range(3)]


@pytest.mark.parametrize("alpha", [0.3, 1.0])
def test_dqnlopt_cost_equals_dqopt(noisy_problems, alpha):
    for X, C, H in noisy_problems:
        ref = solve(C, H, "dqopt", alpha=alpha)
        nl = solve(C, H, "dqnlopt", alpha=alpha)
        assert abs(rel(nl.cost, ref.cost)) <= 1e-12
        # the nonlinear optimiser does not find anything lower than the optimum
        assert nl.cost >= ref.cost * (1 - 1e-12)


@pytest.mark.slow
def test_dqnloptrnd_never_beats_dqopt(noisy_problems):
    for k, (X, C, H) in enumerate(noisy_problems):
        ref = solve(C, H, "dqopt", alpha=1.0)
        rnd = solve(C, H, "dqnloptrnd", alpha=1.0, rng=np.random.default_rng(100 + k))
        starts = rnd.diagnostics["start_objectives"]
        assert starts.shape == (20,)
        assert rnd.cost >= ref.cost * (1 - 1e-12)
        assert starts.min() >= ref.cost * (1 - 1e-12)
        # the best random start does reach the optimum on these problems
        assert rel(rnd.cost, ref.cost) <= 1e-10


def test_dqnloptrnd_is_deterministic_for_a_seed(noisy_problems):
    X, C, H = noisy_problems[0]
    a = solve(C, H, "dqnloptrnd", rng=np.random.default_rng(5))
    b = solve(C, H, "dqnloptrnd", rng=np.random.default_rng(5))
    assert np.array_equal(a.X, b.X)
    np.testing.assert_array_equal(a.diagnostics["start_objectives"],
                                  b.diagnostics["start_objectives"])


def test_dqnlopt_random_starts_count_and_bad_input(noisy_problems):
    from simcalib.solvers.nonlinear import dqnlopt_random_starts, make_dqnloptrnd
    X, C, H = noisy_problems[1]
    p = build_problem(C, H)
    out = dqnlopt_random_starts(p, 1.0, None, np.random.default_rng(0), n_starts=3)
    assert out.diagnostics["n_starts"] == 3 and out.diagnostics["start_objectives"].size == 3
    out5 = make_dqnloptrnd(5)(p, 1.0, None, np.random.default_rng(0))
    assert out5.diagnostics["n_starts"] == 5
    with pytest.raises(ValueError, match="n_starts"):
        dqnlopt_random_starts(p, 1.0, None, np.random.default_rng(0), n_starts=0)
    with pytest.raises(TypeError, match="Generator"):
        dqnlopt_random_starts(p, 1.0, None, None)


@pytest.mark.parametrize("alpha", [0.3, 1.0, 3.0])
def test_dqoptpoly_agrees_with_dqopt(noisy_problems, alpha):
    for X, C, H in noisy_problems:
        ref = solve(C, H, "dqopt", alpha=alpha)
        poly = solve(C, H, "dqoptpoly", alpha=alpha)
        assert abs(rel(poly.cost, ref.cost)) <= 1e-10
        assert np.abs(poly.X - ref.X).max() <= 1e-8
        d = poly.diagnostics
        assert d["count_at_lower"] == 8 and d["count_at_upper"] < 8
        # lam* is the optimal cost (eq. 9: L = lambda on the solution)
        assert abs(rel(d["lam_star"], ref.cost)) <= 1e-9


def test_dqoptpoly_low_noise_matches_nonlinear_refinement():
    """At sigma = 1e-4 .. 1e-5 (M ill-conditioned) the polynomial route still lands on the
    optimum: dqnlopt started from it cannot improve it."""
    from simcalib.solvers.dqpoly import dqoptpoly
    from simcalib.solvers.nonlinear import dqnlopt
    rng = np.random.default_rng(11)
    for sigma in (1e-4, 1e-5):
        X, C, H = random_problem(rng, 60, sigma, sigma)
        p = build_problem(C, H)
        Xp = dqoptpoly(p, 1.0).X
        Xn = dqnlopt(p, 1.0, None, None, X0=Xp).X
        cp, cn = dq_cost(Xp, p, 1.0), dq_cost(Xn, p, 1.0)
        assert rel(cp, cn) <= 1e-9
        assert np.abs(Xp - Xn).max() <= 1e-8


def test_sturm_exact_count_on_known_roots():
    from simcalib.solvers.dqpoly import sturm_real_root_count_exact
    rng = np.random.default_rng(0)
    for _ in range(300):
        n_real = 2 * int(rng.integers(0, 5))
        real = rng.normal(size=n_real) * 10.0 ** rng.uniform(-4, 3, n_real)
        n_pairs = (8 - n_real) // 2
        z = rng.normal(size=n_pairs) + 1j * (np.abs(rng.normal(size=n_pairs)) + 0.05)
        roots = np.concatenate([real, z, np.conj(z)])
        p = np.real(np.poly(roots))[::-1]
        assert sturm_real_root_count_exact(p) == n_real
    # a cluster of small roots next to large ones (where a float Sturm chain fails)
    p = np.real(np.poly([-140.0, -130.0, -120.0, 110.0, 130.0, 145.0, -3.1e-7, -2.9e-7]))[::-1]
    assert sturm_real_root_count_exact(p) == 8
    p = np.real(np.poly([-140.0, -130.0, -120.0, 110.0, 130.0, 145.0,
                         -3e-7 + 1e-8j, -3e-7 - 1e-8j]))[::-1]
    assert sturm_real_root_count_exact(p) == 6


def test_curve_coefficients_reproduce_the_determinant(noisy_problems):
    from simcalib.solvers.kernels.gram import problem_matrices
    from simcalib.solvers.dqpoly import curve_coefficients
    X, C, H = noisy_problems[0]
    S, W, M = problem_matrices(build_problem(C, H), 1.0)
    a = curve_coefficients(S, W, M, 0.05)
    assert a[0, 8] == pytest.approx(1.0, rel=1e-12)           # monic in mu
    for m in range(1, 5):
        assert np.all(a[m, 9 - 2 * m:] == 0)                   # degree 8 - 2m in lambda^m
    rng = np.random.default_rng(0)
    for lam, mu in zip(rng.uniform(0, 0.05, 5), rng.uniform(-0.01, 0.01, 5)):
        K = np.block([[S - lam * np.eye(4), W - mu * np.eye(4)], [W.T - mu * np.eye(4), M]])
        val = sum(a[m, k] * lam**m * mu**k for m in range(5) for k in range(9))
        assert val == pytest.approx(np.linalg.det(K), rel=1e-8)


# ------------------------------------------------------------------- prior
def test_prior_supported_by_dq_methods(noisy_problems):
    X, C, H = noisy_problems[2]
    X_prior = X @ transform_from_rotation_translation(matrix_from_rotvec([0.02, 0.0, 0.01]),
                                                      [0.01, 0.02, 0.0])
    for prior in (Prior(X_prior, a=10.0, b=100.0), Prior(X_prior, a=1e3, b=0.0)):
        ref = solve(C, H, "dqopt", prior=prior)
        for m in ("dqoptpoly", "dqnlopt", "dqnloptrnd"):
            s = solve(C, H, m, prior=prior, rng=np.random.default_rng(0))
            assert abs(rel(s.objective, ref.objective)) <= 1e-10, m
            assert np.abs(s.X - ref.X).max() <= 1e-7, m


def test_methods_without_prior_reject_it(noisy_problems):
    X, C, H = noisy_problems[0]
    for m in ("daniilidis", "chvecopt", "quatvecopt", "opencv_park"):
        with pytest.raises(ValueError, match="prior"):
            solve(C, H, m, prior=Prior(X))


# ------------------------------------------------------------- eq. (30) methods
@pytest.mark.parametrize("method", ["chvecopt", "quatvecopt"])
def test_vec_methods_minimise_their_own_cost(noisy_problems, method):
    from simcalib.solvers.nonlinear import chvec_cost, quatvec_cost
    cost = chvec_cost if method == "chvecopt" else quatvec_cost
    for X, C, H in noisy_problems:
        p = build_problem(C, H)
        s = solve(C, H, method, alpha=1.0)
        own = cost(s.X, p, 1.0)
        assert own == pytest.approx(s.diagnostics["own_cost"], rel=1e-12)
        # lower than at the truth, at dqopt's X, and at small perturbations of the result
        assert own <= cost(X, p, 1.0)
        assert own <= cost(solve(C, H, "dqopt").X, p, 1.0) * (1 + 1e-12)
        rng = np.random.default_rng(0)
        for _ in range(5):
            dX = transform_from_rotation_translation(
                matrix_from_rotvec(rng.normal(0, 1e-4, 3)), rng.normal(0, 1e-4, 3))
            assert own <= cost(s.X @ dX, p, 1.0)
        # accurate: comparable to the optimal DQ solution on these problems
        assert np.rad2deg(rotation_error_rad(s.X, X)) < 0.2
        assert translation_error_m(s.X, X) < 0.01


# --------------------------------------------------------------- Daniilidis
def test_daniilidis_much_worse_than_dqopt_on_circle():
    """Paper Table 2 'Circular': Daniilidis degrades badly, DQOpt does not."""
    rng = np.random.default_rng(4)
    err = {"dqopt": [], "daniilidis": []}
    for _ in range(6):
        X, C, H = circle_problem(rng)
        for m in err:
            s = solve(C, H, m, alpha=0.5)
            err[m].append((np.rad2deg(rotation_error_rad(s.X, X)), translation_error_m(s.X, X)))
    med = {m: np.median(np.array(v), axis=0) for m, v in err.items()}
    assert med["daniilidis"][0] > 3 * med["dqopt"][0]
    assert med["daniilidis"][1] > 3 * med["dqopt"][1]
    assert med["dqopt"][0] < 5.0 and med["dqopt"][1] < 0.5


def test_daniilidis_alpha_scaling_is_applied():
    X, C, H = random_problem(np.random.default_rng(8), 50, SIGMA_R, SIGMA_T)
    a = solve(C, H, "daniilidis", alpha=0.1).X
    b = solve(C, H, "daniilidis", alpha=10.0).X
    assert np.abs(a - b).max() > 1e-6
    for Xe in (a, b):
        assert np.rad2deg(rotation_error_rad(Xe, X)) < 0.5


def test_daniilidis_flags_exactly_planar_motion():
    rng = np.random.default_rng(9)
    X = random_X(rng)
    n = 20
    H = transform_from_rotation_translation(
        matrix_from_rotvec(np.outer(rng.uniform(-1, 1, n), [0.0, 0.0, 1.0])),
        np.c_[rng.normal(0, 1, (n, 2)), np.zeros(n)])
    C = X @ H @ invert_transform(X)
    s = solve(C, H, "daniilidis")
    assert not s.success
    assert "parallel" in s.solver_message and "undetermined" in s.solver_message
    assert s.diagnostics["n_null"] == 3
    # the axis named is X's image of z (the rotation axis of C)
    axis = X[:3, :3] @ np.array([0.0, 0.0, 1.0])
    shown = np.array([float(v) for v in
                      s.solver_message.split("parallel to (")[1].split(")")[0].split(",")])
    assert abs(abs(shown @ axis) - 1.0) < 1e-3
    # dqoptpoly reports the same degeneracy instead of a number presented as measured
    s2 = solve(C, H, "dqoptpoly")
    assert not s2.success and "parallel" in s2.solver_message
    # ... and every exact solution it returns still satisfies C X = X H
    assert np.abs(C @ s.X - s.X @ H).max() < 1e-9


# --------------------------------------------------------------------- OpenCV
def test_opencv_chaining_reproduces_motions_and_products():
    from simcalib.solvers.opencv import chain_motions_for_opencv
    X, C, H = random_problem(np.random.default_rng(10), 6)
    Hg, Hc = chain_motions_for_opencv(C, H)
    assert Hg.shape == Hc.shape == (7, 4, 4)
    for k in range(6):   # consecutive OpenCV pairs (i = k, j = k + 1) are the given motions
        assert np.abs(invert_transform(Hg[k + 1]) @ Hg[k] - C[k]).max() < 1e-12
        assert np.abs(Hc[k + 1] @ invert_transform(Hc[k]) - H[k]).max() < 1e-12
    # a non-consecutive pair (i = 1, j = 4) is the product C_4 C_3 C_2 (0-based: 3, 2, 1)
    A = invert_transform(Hg[4]) @ Hg[1]
    assert np.abs(A - C[3] @ C[2] @ C[1]).max() < 1e-12
    assert np.abs(A @ X - X @ (Hc[4] @ invert_transform(Hc[1]))).max() < 1e-12


@pytest.mark.slow
def test_opencv_noisy_is_reasonable(noisy_problems):
    X, C, H = noisy_problems[0]
    for m in ("opencv_park", "opencv_daniilidis", "opencv_horaud", "opencv_andreff",
              "opencv_tsai"):
        s = solve(C, H, m)
        assert s.success
        assert s.diagnostics["opencv_pairs_used"] == 100 * 101 // 2
        assert np.rad2deg(rotation_error_rad(s.X, X)) < 2.0


def test_opencv_missing_function_is_a_clear_error(monkeypatch):
    import cv2
    from simcalib.solvers.opencv import opencv_hand_eye
    X, C, H = random_problem(np.random.default_rng(1), 5)
    monkeypatch.delattr(cv2, "calibrateHandEye")
    with pytest.raises(RuntimeError, match="calibrateHandEye.*<5"):
        opencv_hand_eye(C, H, "opencv_park")
    monkeypatch.undo()
    with pytest.raises(ValueError, match="available"):
        opencv_hand_eye(C, H, "opencv_nope")


def test_pure_translation_is_reported_not_estimated():
    rng = np.random.default_rng(12)
    X = random_X(rng)
    H = transform_from_rotation_translation(np.broadcast_to(np.eye(3), (15, 3, 3)),
                                            rng.normal(size=(15, 3)))
    C = X @ H @ invert_transform(X)
    for m in ("daniilidis", "dqoptpoly"):
        s = solve(C, H, m)
        assert not s.success
        assert "rotation of X is undetermined" in s.solver_message
    # OpenCV's answers on this input are flagged as failures, not presented as estimates
    for m in ("opencv_tsai", "opencv_park", "opencv_horaud", "opencv_daniilidis"):
        assert not solve(C, H, m).success, m
