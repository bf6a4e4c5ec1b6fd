"""Outlier rejection (simcalib.solvers.robust) validated on the paper's `random` synthetic
motions (simcalib.world.synthetic) with injected outlier motions."""

import numpy as np
import pytest

import simcalib
from simcalib.geometry import (random_rotation_matrices, rotation_error_rad,
                               transform_from_rotation_translation, translation_error_m)
from simcalib.solvers.api import dq_cost
from simcalib.solvers.robust import (RobustSolution, constraint_errors,
                                     inlier_scores, irls, noise_threshold, ransac, robust_solve,
                                     screw_residuals)
from simcalib.world.synthetic import synthetic_problem

RUNS = 12


def _contaminate(C, frac, rng):
    n = C.shape[0]
    k = int(round(frac * n))
    idx = rng.choice(n, k, replace=False)
    C = C.copy()
    C[idx] = transform_from_rotation_translation(random_rotation_matrices(rng, (k,)),
                                                 rng.uniform(-1, 1, (k, 3)))
    good = np.ones(n, bool)
    good[idx] = False
    return C, good


def _trial(frac, seed, **kw):
    rng = np.random.default_rng(seed)
    p = synthetic_problem("random", n=100, rng=rng)
    C, good = _contaminate(p.C, frac, rng)
    err = lambda X: (float(rotation_error_rad(X, p.X)), float(translation_error_m(X, p.X)))  # noqa
    clean = err(simcalib.solve(p.C, p.H).X)
    plain = err(simcalib.solve(C, p.H).X)
    r = ransac(C, p.H, rng=np.random.default_rng(1000 + seed), **kw)
    return clean, plain, err(r.X), inlier_scores(r.inlier_mask, good), r


def test_residuals_are_the_per_motion_cost_terms():
    p = synthetic_problem("random", n=50, rng=np.random.default_rng(0))
    X = simcalib.solve(p.C, p.H).X
    r = screw_residuals(p.C, p.H, X, alpha=2.0)
    assert r.shape == (50,)
    assert np.isclose(np.sum(r**2), dq_cost(X, (p.C, p.H), 2.0), rtol=1e-9)
    assert np.allclose(screw_residuals(p.C, p.H, p.X[None].repeat(3, 0)),
                       screw_residuals(p.C, p.H, p.X)[None])
    exact = screw_residuals(p.X @ p.dataset.H_true[:5] @ np.linalg.inv(p.X),
                            p.dataset.H_true[:5], p.X)
    assert np.all(exact < 1e-12)
    rot, tr = constraint_errors(p.C, p.H, p.X)
    assert np.median(np.degrees(rot)) < 2.0 and np.median(tr) < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("kw", [{}, {"noise": (np.radians(0.57), 0.01)}],
                         ids=["auto-threshold", "noise-threshold"])
def test_ransac_20_percent(kw):
    rows = [_trial(0.2, s, **kw) for s in range(RUNS)]
    clean = np.median([r[0] for r in rows], axis=0)
    plain = np.median([r[1] for r in rows], axis=0)
    robust = np.median([r[2] for r in rows], axis=0)
    assert np.all(robust <= 1.5 * clean), (robust, clean)
    assert np.all(plain >= 10 * clean), (plain, clean)
    prec = np.mean([r[3]["precision"] for r in rows])
    rec = np.mean([r[3]["recall"] for r in rows])
    assert prec > 0.95 and rec > 0.9, (prec, rec)
    r = rows[0][4]
    assert isinstance(r, RobustSolution) and r.weights.shape == r.inlier_mask.shape == (100,)
    assert r.solution.method == "dqopt" and r.solution.n_motions == r.n_inliers


@pytest.mark.slow
def test_ransac_40_percent_finds_the_inliers():
    found = 0
    for s in range(RUNS):
        *_, sc, _ = _trial(0.4, s)
        found += sc["precision"] >= 0.95 and sc["recall"] >= 0.9
    assert found >= 0.9 * RUNS


def test_ransac_is_deterministic_and_checks_inputs():
    p = synthetic_problem("random", n=40, rng=np.random.default_rng(3))
    a = ransac(p.C, p.H, rng=np.random.default_rng(5))
    b = ransac(p.C, p.H, rng=np.random.default_rng(5))
    assert np.array_equal(a.X, b.X) and np.array_equal(a.inlier_mask, b.inlier_mask)
    with pytest.raises(ValueError, match="threshold"):
        ransac(p.C, p.H, threshold=-1.0)
    with pytest.raises(ValueError, match="at least 4"):
        ransac(p.C[:3], p.H[:3])
    with pytest.raises(ValueError, match="at least 4 motions; received 2"):
        ransac(p.C[:2], p.H[:2])                     # not the sample_size range
    for kw, exc, match in (
            (dict(threshold="0.1"), TypeError, "threshold must be a number or None; received str"),
            (dict(noise=(0.01,)), ValueError, r"noise must be \(sigma_r_rad, sigma_t_m\)"),
            (dict(confidence=1.0), ValueError, r"confidence must be in \(0, 1\); received 1.0"),
            (dict(max_iterations=0), ValueError, "max_iterations must be an integer >= 1"),
            (dict(min_axis_angle_deg=90), ValueError, r"min_axis_angle_deg must be in \[0, 90\)")):
        with pytest.raises(exc, match=match):
            ransac(p.C, p.H, **kw)
    # a minimal set so large that its all-inlier chance rounds 1 - p to 1: the iteration
    # budget still comes out finite (was a ZeroDivisionError)
    from simcalib.solvers.robust import _hypotheses_needed
    n = _hypotheses_needed(np.ones(40), 1e-3, 40, 39, 0.999, 64)   # p_good = 40**-39
    assert isinstance(n, int) and n >= 10**18
    assert _hypotheses_needed(np.zeros(40), 1e-3, 40, 2, 0.999, 64) == 64   # all inliers
    # a given threshold wins over the noise, and the message says which was used
    given = ransac(p.C, p.H, threshold=0.05, noise=(0.01, 0.01))
    assert "(given)" in given.message and given.threshold <= 0.05 + 1e-12
    assert "(from noise)" in ransac(p.C, p.H, noise=(0.01, 0.01)).message
    with pytest.raises(ValueError, match="available: none, ransac, irls"):
        robust_solve(p.C, p.H, "lmeds")
    assert noise_threshold(p.C, p.H, 0.01, 0.01) > 0
    none = robust_solve(p.C, p.H, "none")
    assert none.inlier_mask.all() and np.allclose(none.X, simcalib.solve(p.C, p.H).X)


def test_irls_guarded_until_solve_takes_weights():
    p = synthetic_problem("random", n=60, rng=np.random.default_rng(4))
    r = irls(p.C, p.H)
    assert r.method == "irls" and r.weights.shape == (60,)


def test_irls_20_percent():
    rng = np.random.default_rng(9)
    p = synthetic_problem("random", n=100, rng=rng)
    C, good = _contaminate(p.C, 0.2, rng)
    clean = rotation_error_rad(simcalib.solve(p.C, p.H).X, p.X)
    for init in ("ransac", "none"):
        r = irls(C, p.H, init=init)
        if init == "ransac":
            assert rotation_error_rad(r.X, p.X) <= 1.5 * clean + 1e-4
            sc = inlier_scores(r.inlier_mask, good)
            assert sc["precision"] > 0.95 and sc["recall"] > 0.9


@pytest.mark.parametrize("robust", ["ransac", "irls"])
def test_solve_robust_reports_inliers_and_weights(robust):
    """simcalib.solve(..., robust=...) is the robust method's final solve, with its inlier
    mask and weights; it recovers X under 20 % outlier motions where the plain solve fails."""
    rng = np.random.default_rng(3)
    p = synthetic_problem("random", n=100, rng=rng)
    C, good = _contaminate(p.C, 0.2, rng)
    plain = simcalib.solve(C, p.H)
    sol = simcalib.solve(C, p.H, robust=robust, rng=np.random.default_rng(0))
    clean = rotation_error_rad(simcalib.solve(p.C, p.H).X, p.X)
    assert rotation_error_rad(sol.X, p.X) <= 1.5 * clean + 1e-4
    assert rotation_error_rad(plain.X, p.X) > 10 * clean
    mask = sol.diagnostics["inlier_mask"]
    assert mask.shape == (100,) and sol.diagnostics["weights"].shape == (100,)
    sc = inlier_scores(mask, good)
    assert sc["precision"] > 0.95 and sc["recall"] > 0.9
    with pytest.raises(ValueError, match="unknown robust method 'ransc'"):
        simcalib.solve(C, p.H, robust="ransc")
    with pytest.raises(ValueError, match="needs a method that takes weights"):
        simcalib.solve(C, p.H, method="daniilidis", robust=robust)
    # the uncertainty options apply to the robust solve too (were silently ignored)
    with pytest.raises(ValueError, match="uncertainty must be 'sandwich' or 'bootstrap'"):
        simcalib.solve(C, p.H, robust=robust, uncertainty="bogus")
    with pytest.raises(ValueError, match="tolerance"):
        simcalib.solve(C, p.H, robust=robust, tolerance_deg=-1.0)
    with pytest.raises(ValueError, match="correlation_lag applies to consecutive motions"):
        simcalib.solve(C, p.H, robust=robust, correlation_lag=2)
    boot = simcalib.solve(C, p.H, robust=robust, rng=np.random.default_rng(0),
                          uncertainty="bootstrap", bootstrap_samples=20)
    assert np.array_equal(boot.X, sol.X)                  # the same robust estimate
    assert boot.uncertainty.method == "bootstrap" and boot.bootstrap_samples == 20
    assert np.all(np.isfinite(boot.std)) and boot.uncertainty.n_motions == sol.n_motions


def test_ransac_residuals_in_blocks_equal_the_whole(monkeypatch):
    """Many motions: the hypotheses' residuals are computed a few hypotheses at a time
    (memory): the same to rounding (einsum may sum in another order for other shapes;
    below 2,000,000 / 64 = 31,250 motions nothing is split)."""
    from simcalib.solvers import robust as R
    rng = np.random.default_rng(5)
    C = transform_from_rotation_translation(random_rotation_matrices(rng, 50),
                                              rng.normal(size=(50, 3)))
    H = transform_from_rotation_translation(random_rotation_matrices(rng, 50),
                                              rng.normal(size=(50, 3)))
    Xs = transform_from_rotation_translation(random_rotation_matrices(rng, 9),
                                               rng.normal(size=(9, 3)))
    mats = R._motion_matrices(C, H)
    monkeypatch.setattr(R, "_RESIDUAL_BLOCK", 120)      # 2 hypotheses at a time
    np.testing.assert_allclose(R._chunked_residuals(mats, Xs, 1.3),
                               R._residuals(mats, Xs, 1.3), rtol=1e-13, atol=0)


def test_ransac_on_pure_translation_draws_sets_by_translation_direction():
    """No motion rotates beyond the noise: the rotation axes are noise, so minimal sets are
    motions with translations apart (two fix X's rotation, t_C = R_X t_H); gross outliers
    are still rejected."""
    from simcalib.geometry import (invert_transform, matrix_from_rotvec, perturb_transforms,
                                   rotation_error_rad, transform_from_rotation_translation)
    rng = np.random.default_rng(2)
    X = transform_from_rotation_translation(matrix_from_rotvec([0.3, -0.5, 0.2]),
                                            [0.05, 0.02, 0.1])
    H = transform_from_rotation_translation(np.broadcast_to(np.eye(3), (100, 3, 3)),
                                            rng.normal(scale=0.2, size=(100, 3)))
    C = perturb_transforms(X @ H @ invert_transform(X), np.radians(0.05), 0.001, rng)
    bad = rng.random(100) < 0.2
    C[bad] = C[bad] @ transform_from_rotation_translation(
        matrix_from_rotvec(rng.normal(scale=0.5, size=(int(bad.sum()), 3))),
        rng.normal(scale=0.3, size=(int(bad.sum()), 3)))
    r = ransac(C, H, rng=np.random.default_rng(0))
    assert "pure translation" in r.message
    assert np.array_equal(r.inlier_mask, ~bad)
    assert np.degrees(rotation_error_rad(r.X, X)) < 0.1


def test_minimal_pairs_are_argpartitions_pairs_without_argpartition(monkeypatch):
    from simcalib.solvers import robust
    axes = random_rotation_matrices(np.random.default_rng(5), (300,))[:, 0]
    want = [robust._draw_minimal_sets(np.random.default_rng(s), axes, 64, 2, 0.2)
            for s in range(5)]

    def refused(*a, **k):
        raise AssertionError("argpartition called for pairs")
    monkeypatch.setattr(robust.np, "argpartition", refused)
    for s in range(5):
        keys = np.random.default_rng(s).random((64, 300))
        got = robust._two_smallest(keys)
        monkeypatch.undo()
        assert np.array_equal(got, np.argpartition(keys, 1, axis=1)[:, :2])
        monkeypatch.setattr(robust.np, "argpartition", refused)
        assert np.array_equal(
            robust._draw_minimal_sets(np.random.default_rng(s), axes, 64, 2, 0.2), want[s])
    # a tie among a row's two smallest keys: argpartition's own order (None here)
    assert robust._two_smallest(np.array([[0.5, 0.1, 0.1, 0.9]])) is None
    assert robust._two_smallest(np.array([[0.5, 0.1, 0.2, 0.2]])) is None
    assert robust._two_smallest(np.array([[0.5, 0.1, 0.2, 0.3]])).tolist() == [[1, 2]]


def test_screw_terms_score_subsets_as_screw_residuals_does():
    """The motions' terms converted once, then indexed, give screw_residuals' numbers to the
    bit for any subset and X (the mount check scores ~100 fits so)."""
    from simcalib.solvers.robust import residuals_of_terms, screw_residuals, screw_terms
    rng = np.random.default_rng(4)
    C = transform_from_rotation_translation(random_rotation_matrices(rng, (30,)),
                                            rng.normal(size=(30, 3)))
    H = transform_from_rotation_translation(random_rotation_matrices(rng, (30,)),
                                            rng.normal(size=(30, 3)))
    X = transform_from_rotation_translation(random_rotation_matrices(rng, ()),
                                            rng.normal(size=3))
    terms = screw_terms(C, H)
    idx = np.array([0, 3, 4, 17, 29])
    got = residuals_of_terms(tuple(t[idx] for t in terms), X, 0.7)
    assert got.tobytes() == screw_residuals(C[idx], H[idx], X, 0.7).tobytes()
    with pytest.raises(ValueError, match=r"received \(30, 4, 4\), \(29, 4, 4\)"):
        screw_terms(C, H[:29])
