"""Public API: bad input is rejected with clear errors; solve_batch agrees with solve."""

import numpy as np
import pytest

import simcalib
from simcalib import geometry as g
from simcalib.solvers import available, get
from simcalib.solvers.api import Prior, dq_cost
from solver_cases import general_case, planar_case


@pytest.fixture(scope="module")
def case():
    return general_case(np.random.default_rng(3), n=10)


def _raises(exc, match, fn, *args, **kw):
    with pytest.raises(exc, match=match):
        fn(*args, **kw)


def test_bad_shapes_and_counts(case):
    C, H, _ = case
    _raises(ValueError, r"shape \(N, 4, 4\); received shape \(4, 4\)", simcalib.solve, C[0], H[0])
    _raises(ValueError, r"shape \(N, 4, 4\); received shape \(10, 3, 4\)",
            simcalib.solve, C[:, :3], H)
    _raises(ValueError, "at least 2 transforms; received 1", simcalib.solve, C[:1], H[:1])
    _raises(ValueError, "same number of motions; received 10 and 9", simcalib.solve, C, H[:9])
    _raises(TypeError, "could not convert", simcalib.solve, "abc", H)


def test_non_finite_and_non_rigid(case):
    C, H, _ = case
    Cn = C.copy()
    Cn[3, 0, 1] = np.nan
    _raises(ValueError, r"C contains NaN or inf \(first at index 3\)", simcalib.solve, Cn, H)
    Hi = H.copy()
    Hi[2, 1, 3] = np.inf
    _raises(ValueError, "H contains NaN or inf", simcalib.solve, C, Hi)
    Cs = C.copy()
    Cs[4, :3, :3] *= 1.1
    _raises(ValueError, r"C rotation block\[4\] is not a rotation", simcalib.solve, Cs, H)
    Cb = C.copy()
    Cb[5, 3, 0] = 0.5
    _raises(ValueError, r"C\[5\] has bottom row", simcalib.solve, Cb, H)
    Cr = C.copy()
    Cr[1, :3, 0] *= -1   # reflection: det -1
    _raises(ValueError, "det", simcalib.solve, Cr, H)


def test_unknown_method_lists_valid_ones(case):
    C, H, _ = case
    with pytest.raises(ValueError) as exc:
        simcalib.solve(C, H, method="dqopr")
    msg = str(exc.value)
    assert "unknown method 'dqopr'" in msg and "did you mean 'dqopt'" in msg
    for m in available():
        assert m in msg
    _raises(TypeError, "method must be a string", simcalib.solve, C, H, method=3)


@pytest.mark.parametrize("alpha", [0.0, -1.0, np.nan, np.inf])
def test_bad_alpha(case, alpha):
    C, H, _ = case
    _raises(ValueError, "alpha must be finite and > 0", simcalib.solve, C, H, alpha=alpha)
    _raises(ValueError, "alpha must be finite and > 0", simcalib.solve_batch, C[None], H[None],
            alpha=alpha)


def test_bad_alpha_type_and_rng(case):
    C, H, _ = case
    _raises(TypeError, "alpha must be a real number", simcalib.solve, C, H, alpha="1")
    _raises(TypeError, "alpha must be a real number", simcalib.solve, C, H, alpha=True)
    _raises(ValueError, r"alpha must be a scalar or an array of shape \(2,\)",
            simcalib.solve_batch, np.stack([C, C]), np.stack([H, H]), alpha=[1.0, 2.0, 3.0])
    _raises(TypeError, "rng must be a numpy.random.Generator", simcalib.solve, C, H, rng=42)


def test_bad_prior(case):
    C, H, X = case
    bad = X.copy()
    bad[:3, :3] *= 2
    _raises(ValueError, r"Prior.X rotation block\[0\] is not a rotation", Prior, bad)
    _raises(ValueError, r"Prior.X must be one 4x4 rigid transform; received shape \(2, 4, 4\)",
            Prior, np.stack([X, X]))
    _raises(ValueError, "Prior.a must be finite and >= 0; received -1.0", Prior, X, a=-1.0)
    _raises(ValueError, "Prior.b must be finite and >= 0; received nan", Prior, X, b=np.nan)
    _raises(ValueError, "both 0", Prior, X, a=0, b=0)
    _raises(TypeError, "Prior.a must be a real number", Prior, X, a="1")
    _raises(TypeError, "prior must be a simcalib.Prior or None", simcalib.solve, C, H, prior=X)
    no_prior = [m for m in available() if not get(m).supports_prior]
    if no_prior:
        _raises(ValueError, "does not support a prior", simcalib.solve, C, H,
                method=no_prior[0], prior=Prior(X))


def test_batch_bad_input(case):
    C, H, _ = case
    CB = np.stack([C, C, C])
    HB = np.stack([H, H, H])
    _raises(ValueError, r"shape \(B, N, 4, 4\); received shape \(10, 4, 4\)",
            simcalib.solve_batch, C, H)
    _raises(ValueError, "same shape", simcalib.solve_batch, CB, HB[:2])
    _raises(ValueError, "at least 2 motions", simcalib.solve_batch, CB[:, :1], HB[:, :1])
    HB2 = HB.copy()
    HB2[1, 4, :3, :3] *= 1.5
    _raises(ValueError, r"H\[1\] rotation block\[4\] is not a rotation",
            simcalib.solve_batch, CB, HB2)
    HB3 = HB.copy()
    HB3[2, 0, 0, 0] = np.nan
    _raises(ValueError, r"H\[2\] contains NaN", simcalib.solve_batch, CB, HB3)
    _raises(ValueError, "unknown method", simcalib.solve_batch, CB, HB, method="nope")


def test_dq_cost_inputs(case):
    C, H, X = case
    assert dq_cost(X, (C, H), 1.0) < 1e-20
    q, qd = g.dual_quat_from_transform(X)
    assert dq_cost((q, qd), (C, H), 2.0) < 1e-20
    _raises(ValueError, "two 4-vectors", dq_cost, (q[:3], qd), (C, H), 1.0)
    _raises(ValueError, "alpha must be finite", dq_cost, X, (C, H), 0.0)


def test_solution_fields(case):
    C, H, X = case
    sol = simcalib.solve(C.tolist(), H.tolist(), method="dqopt", alpha=2.0)  # array-like ok
    assert sol.X.shape == (4, 4) and sol.X.dtype == np.float64
    assert sol.method == "dqopt" and sol.alpha == 2.0 and sol.n_motions == 10
    assert sol.success and sol.runtime_s > 0 and sol.cost == sol.objective
    assert "dqopt: ok" in sol.message and "Solution(dqopt" in str(sol)
    import json
    d = json.loads(json.dumps(sol.to_dict()))
    assert d["certificate"]["certified"] and d["degenerate"] is False
    assert np.allclose(d["X"], sol.X) and len(d["singular_values"]) == 6


# ---------------------------------------------------------------------------- batch
def _batch_case(B=6, n=20, seed=4):
    """General (noise-free and noisy), near-180-degree (sign re-alignment) and planar."""
    rng = np.random.default_rng(seed)
    Cs, Hs = [], []
    for b in range(B):
        if b == B - 1:
            C, H, X, _ = planar_case(rng, n=n, sigma_r=0.01, sigma_t=0.01)
        else:
            C, H, X = general_case(rng, n=n, sigma_r=0.01 * (b % 3), sigma_t=0.01 * (b % 3))
            if b == 1:   # motions rotating by pi - 1e-4 with noise: pairs to re-align
                for k in range(8):
                    ax = rng.normal(size=3)
                    C[k] = g.transform_from_rotation_translation(
                        g.matrix_from_rotvec((np.pi - 1e-4) * ax / np.linalg.norm(ax)),
                        rng.normal(size=3))
                    H[k] = g.perturb_transforms(g.invert_transform(X) @ C[k] @ X, 0.01, 0.01, rng)
        Cs.append(C)
        Hs.append(H)
    return np.stack(Cs), np.stack(Hs)


@pytest.mark.parametrize("method", [m for m in available() if get(m).batch_fn is not None])
def test_batch_equals_single(method):
    C, H = _batch_case()
    alphas = np.array([0.5, 1.0, 2.0, 1.0, 3.0, 1.0])
    bs = simcalib.solve_batch(C, H, method=method, alpha=alphas)
    assert bs.X.shape == (6, 4, 4) and bs.cost.shape == (6,) and bs.success.all()
    assert bs.diagnostics["sign_flips"][1] > 0 and bs.diagnostics["sign_flips"][0] == 0
    assert len(bs) == 6 and np.array_equal(bs.alpha, alphas)
    for b in range(6):
        s = simcalib.solve(C[b], H[b], method=method, alpha=alphas[b])
        assert np.abs(s.X - bs.X[b]).max() < 1e-10, (method, b)
        assert abs(s.cost - bs.cost[b]) <= 1e-10 * max(s.cost, 1e-12), (method, b)
    if not get(method).supports_prior:
        return
    # with a prior and a scalar alpha
    prior = Prior(X=simcalib.solve(C[0], H[0]).X, a=0.5, b=0.5)
    bp = simcalib.solve_batch(C, H, method=method, alpha=1.5, prior=prior)
    for b in (0, 5):
        s = simcalib.solve(C[b], H[b], method=method, alpha=1.5, prior=prior)
        assert np.abs(s.X - bp.X[b]).max() < 1e-10
        assert np.isclose(s.objective, bp.objective[b], rtol=1e-10, atol=1e-15)


def test_batch_loop_fallback():
    loop = [m for m in available() if get(m).batch_fn is None and not get(m).stochastic]
    if not loop:
        pytest.skip("every registered method has a batch function")
    C, H = _batch_case(B=3, n=12)
    method = loop[0]
    bs = simcalib.solve_batch(C, H, method=method, alpha=[1.0, 2.0, 0.5])
    assert bs.diagnostics["sign_flips"][1] > 0
    for b, a in enumerate([1.0, 2.0, 0.5]):
        s = simcalib.solve(C[b], H[b], method=method, alpha=a)
        assert np.abs(s.X - bs.X[b]).max() < 1e-10
        assert np.isclose(s.cost, bs.cost[b], rtol=1e-9, atol=1e-18)
