"""Accuracy and optimality of every registered solver (loops over the registry)."""

import numpy as np
import pytest

import simcalib
from simcalib import geometry as g
from simcalib.solvers import available, get
from simcalib.solvers.api import Prior, dq_cost
from simcalib.solvers.kernels.gram import prior_terms, problem_matrices
from solver_cases import general_case, planar_case

ALL = available()
DQ = [m for m in ALL if get(m).family == "dq"]
WITH_PRIOR = [m for m in ALL if get(m).supports_prior]


def _err(X, Xt):
    return float(g.rotation_error_rad(X, Xt)), float(g.translation_error_m(X, Xt))


@pytest.mark.parametrize("method", ALL)
def test_noise_free_exact(method):
    rng = np.random.default_rng(7)
    for _ in range(3):
        C, H, X = general_case(rng, n=12)
        sol = simcalib.solve(C, H, method=method, rng=np.random.default_rng(0))
        r, t = _err(sol.X, X)
        assert sol.success
        assert r < 1e-9 and t < 1e-9, (method, r, t)
        assert sol.cost < 1e-18
        assert not sol.degenerate


@pytest.mark.parametrize("method", DQ)
def test_noise_free_exact_with_prior_and_alpha(method):
    rng = np.random.default_rng(8)
    C, H, X = general_case(rng, n=15)
    prior = Prior(X=g.transform_from_rotation_translation(np.eye(3), [1.0, 2.0, 3.0]), a=0.1, b=0.1)
    sol = simcalib.solve(C, H, method=method, alpha=3.0)
    assert max(_err(sol.X, X)) < 1e-9
    # a prior away from the truth must not move a fully determined noise-free solution much
    sol_p = simcalib.solve(C, H, method=method, prior=prior)
    assert max(_err(sol_p.X, X)) < 0.05


@pytest.mark.slow
def test_dqopt_cost_is_minimum_over_all_methods():
    """Paper Table 1: no method reaches a lower cost (8) than dqopt (to 1e-12 relative)."""
    rng = np.random.default_rng(11)
    for trial in range(3):
        C, H, X = general_case(rng, n=40, sigma_r=0.02, sigma_t=0.02)
        for alpha in (0.3, 1.0, 5.0):
            best = simcalib.solve(C, H, method="dqopt", alpha=alpha)
            assert best.certified, best.certificate
            for m in ALL:
                sol = simcalib.solve(C, H, method=m, alpha=alpha, rng=np.random.default_rng(trial))
                assert sol.cost >= best.cost * (1 - 1e-12), (m, alpha, sol.cost, best.cost)


def test_optimal_variants_agree_with_dqopt():
    rng = np.random.default_rng(12)
    C, H, X = general_case(rng, n=50, sigma_r=0.01, sigma_t=0.01)
    best = simcalib.solve(C, H, method="dqopt")
    rel = {m: (simcalib.solve(C, H, method=m).cost - best.cost) / best.cost
           for m in ("dqitr", "dq2ndord", "dq2ndord_lambda", "dqconvrlx", "dq2steps")}
    assert abs(rel["dqitr"]) < 1e-12
    assert -1e-12 <= rel["dq2ndord"] < 1e-6 and -1e-12 <= rel["dq2ndord_lambda"] < 1e-6
    assert -1e-12 <= rel["dqconvrlx"] < 1e-3 and rel["dq2steps"] > rel["dqconvrlx"]
    if "dqoptpoly" in ALL:
        assert abs(simcalib.solve(C, H, method="dqoptpoly").cost - best.cost) <= 1e-12 * best.cost


@pytest.mark.slow
def test_dqopt_matches_brute_force_minimisation():
    """Independent check: scipy minimisation of cost (8) over SE(3) from 20 random starts."""
    from scipy.optimize import minimize
    rng = np.random.default_rng(13)
    C, H, X = general_case(rng, n=25, sigma_r=0.03, sigma_t=0.03)
    alpha = 2.0
    best = simcalib.solve(C, H, method="dqopt", alpha=alpha)

    def cost(p):
        T = g.transform_from_rotation_translation(g.matrix_from_rotvec(p[:3]), p[3:])
        return dq_cost(T, (C, H), alpha)

    found = []
    for _ in range(20):
        p0 = np.concatenate([g.rotvec_from_matrix(g.random_rotation_matrices(rng)),
                             rng.normal(size=3)])
        res = minimize(cost, p0, method="BFGS", options={"gtol": 1e-12, "maxiter": 2000})
        found.append(res.fun)
    assert min(found) >= best.cost * (1 - 1e-10)
    assert min(found) <= best.cost * (1 + 1e-7)   # the brute force does reach the optimum


def test_certificate_readable_and_discriminating():
    rng = np.random.default_rng(14)
    C, H, X = general_case(rng, n=40, sigma_r=0.02, sigma_t=0.02)
    sol = simcalib.solve(C, H)
    cert = sol.certificate
    assert cert.certified and cert.root_bracketed and cert.f_monotone and cert.lambda0_is_max
    assert cert.bracket[0] <= cert.mu <= cert.bracket[1]
    assert cert.f_at_bracket[0] < 0 < cert.f_at_bracket[1]
    assert cert.kkt_residual < 1e-12 and abs(cert.relative_gap) < 1e-10
    assert cert.lambda1 > cert.lambda0
    assert "certified global optimum" in sol.message and "KKT" in str(cert)
    approx = simcalib.solve(C, H, method="dq2steps").certificate
    assert not approx.certified and approx.relative_gap > 1e-6
    assert simcalib.solve(C, H, method="daniilidis").certificate is None if "daniilidis" in ALL else True


def test_certified_across_alpha_range():
    rng = np.random.default_rng(20)
    C, H, X = general_case(rng, n=40, sigma_r=0.01, sigma_t=0.01)
    for alpha in (1e-3, 1e-2, 1.0, 50.0, 1e3):
        sol = simcalib.solve(C, H, alpha=alpha)
        assert sol.certified, (alpha, sol.certificate)
        nl = simcalib.solve(C, H, method="dq2ndord", alpha=alpha)
        assert nl.cost >= sol.cost * (1 - 1e-12)


def test_noise_free_certificate_is_exact_fit():
    rng = np.random.default_rng(15)
    C, H, X = general_case(rng, n=20)
    cert = simcalib.solve(C, H).certificate
    assert cert.route == "exact-fit" and cert.certified and cert.objective < 1e-20


def test_tiny_noise_stays_accurate():
    """Between noise-free and noisy (M nearly singular) the answer stays at noise level."""
    rng = np.random.default_rng(16)
    for sigma in (1e-9, 1e-7, 1e-5):
        C, H, X = general_case(rng, n=30, sigma_r=sigma, sigma_t=sigma)
        sol = simcalib.solve(C, H)
        r, t = _err(sol.X, X)
        assert r < 20 * sigma and t < 20 * sigma, (sigma, r, t)
        assert sol.cost <= dq_cost(X, (C, H), 1.0) * (1 + 1e-9)


def test_near_180_degree_pairs_are_realigned():
    """Noise can give an anti-aligned pair the same scalar sign near 180 deg; the
    re-alignment must keep it from becoming a gross outlier."""
    rng = np.random.default_rng(17)
    C, H, X = general_case(rng, n=30, sigma_r=0.01, sigma_t=0.01)
    # 10 motions rotating by pi - 1e-4 (scalar parts ~5e-5, noise ~5e-3): some pairs get
    # the same scalar sign although anti-aligned
    from simcalib.solvers.problem import build_problem
    for k in range(10):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        C[k] = g.transform_from_rotation_translation(g.matrix_from_rotvec((np.pi - 1e-4) * axis),
                                                     rng.normal(size=3))
        H[k] = g.perturb_transforms(g.invert_transform(X) @ C[k] @ X, 0.01, 0.01, rng)
    naive = build_problem(C, H)
    q, _ = g.dual_quat_from_transform(X)
    bad = [np.dot(g.quat_multiply(naive.q_C[i], q), g.quat_multiply(q, naive.q_H[i])) < 0
           for i in range(30)]
    assert any(bad)  # the scalar-part rule alone mis-aligns at least one pair here
    sol = simcalib.solve(C, H)
    r, t = _err(sol.X, X)
    assert r < 0.01 and t < 0.02
    per_motion = sol.cost / 30
    assert per_motion < 1e-3   # a flipped pair would add ~4


def test_dqopt_kept_from_the_alignment_equals_a_solve_of_the_aligned_motions():
    """simcalib.solve(dqopt) takes X and the diagnostics from the sign alignment's last
    dqopt solve (MotionProblem.kept_dqopt) instead of solving the aligned motions again:
    the two are the same bits (same kernel code, same motions), also with weights, near
    180 deg (restarts) and noise-free; another alpha is solved again."""
    from simcalib.solvers.kernels import dqcore
    from simcalib.solvers.kernels.batch import run_batch
    from simcalib.solvers.problem import prepare_problem
    rng = np.random.default_rng(23)
    for k in range(60):
        sigma = (0.0, 1e-6, 0.01, 0.05)[k % 4]
        C, H, X = general_case(rng, n=int(rng.integers(2, 60)), sigma_r=sigma, sigma_t=sigma)
        if k % 3 == 0:   # motions close to 180 deg: the alignment's restarts
            for i in range(min(5, C.shape[0])):
                axis = rng.normal(size=3)
                C[i, :3, :3] = g.matrix_from_rotvec((np.pi - 0.05) * axis / np.linalg.norm(axis))
                H[i] = g.perturb_transforms(g.invert_transform(X) @ C[i] @ X, sigma, sigma, rng)
        w = rng.uniform(0.2, 2.0, C.shape[0]) if k % 2 else None
        alpha = float(rng.uniform(0.1, 5.0))
        p = prepare_problem(C, H, alpha, w)
        X_kept, info_kept = p.kept_dqopt(alpha)
        again = run_batch(dqcore.DQOPT, np.array([alpha]), Q=p.soa()[None],
                          weights=None if w is None else w[None], align=False)
        assert np.array_equal(X_kept, again["X"][0]), k
        assert np.array_equal(info_kept, again["info"][0], equal_nan=True), k
        assert p.kept_dqopt(alpha * 1.5) is None


def test_prior_terms_reproduce_prior_cost():
    """Eqs. 26-29 (docs/paper-notes.md, misprints): quadratic form + b|q^'|^2 = cost + a|vec dq|^2 + b|dq'|^2."""
    rng = np.random.default_rng(18)
    C, H, X = general_case(rng, n=20, sigma_r=0.02, sigma_t=0.02)
    prior = Prior(X=g.transform_from_rotation_translation(g.random_rotation_matrices(rng),
                                                         rng.normal(size=3)), a=2.0, b=3.0)
    from simcalib.solvers.problem import prepare_problem as fast_build_problem
    p = fast_build_problem(C, H)
    S, W, M = problem_matrices(p, 1.5, prior)
    for _ in range(3):
        T = g.transform_from_rotation_translation(g.random_rotation_matrices(rng), rng.normal(size=3))
        q, qd = g.dual_quat_from_transform(T)
        quad = q @ S @ q + qd @ M @ qd + 2 * q @ W @ qd
        assert np.isclose(quad + prior_terms(prior)[3], dq_cost(T, p, 1.5, prior), rtol=1e-12)


@pytest.mark.parametrize("method", WITH_PRIOR)
def test_prior_pulls_planar_problem_towards_prior(method):
    rng = np.random.default_rng(19)
    axis = np.array([0.3, -0.5, 0.8])
    C, H, X, k = planar_case(rng, n=30, axis=axis, sigma_r=0.005, sigma_t=0.005)
    # prior: truth moved by 0.2 m along the undetermined axis and 0.1 m in-plane, slightly rotated
    inplane = np.cross(k, [1.0, 0.0, 0.0])
    inplane /= np.linalg.norm(inplane)
    Xp = X.copy()
    Xp[:3, 3] += 0.2 * k + 0.1 * inplane
    Xp[:3, :3] = g.matrix_from_rotvec([0.0, 0.0, 0.01]) @ Xp[:3, :3]
    prior = Prior(X=Xp, a=1.0, b=1.0)
    sol = simcalib.solve(C, H, method=method, prior=prior, rng=np.random.default_rng(0))
    # along the axis: the prior's value; in-plane: the data's value
    assert abs((sol.X[:3, 3] - Xp[:3, 3]) @ k) < 0.01, method
    if method == "dq2steps":
        return  # its rotation step (smallest eigenvector of M) is blind to S and the prior
    assert abs((sol.X[:3, 3] - X[:3, 3]) @ inplane) < 0.02, method
    assert g.rotation_error_rad(sol.X, X) < 0.01
    assert sol.degenerate
    assert all(d.determined_by_prior for d in sol.undetermined if d.kind == "translation")
    assert "prior" in sol.message
    # the objective includes the prior; without the prior the axis value is not the prior's
    assert sol.objective > sol.cost
