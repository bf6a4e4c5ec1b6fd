"""Compiled kernels against their numpy twins, per-motion weights, and solver defects
(sign alignment near 180 deg, alpha range, complex input, failed batch members)."""

from __future__ import annotations

import numpy as np
import pytest

import simcalib
from simcalib import geometry as g
from simcalib.solvers.kernels import dqcore, gram, linalg, quaternion
from simcalib.solvers.problem import build_problem, prepare_problem, problem_cost
from solver_cases import general_case, random_X


# ------------------------------------------------------------------ kernels vs numpy twins
def test_jacobi_matches_numpy_eigh():
    rng = np.random.default_rng(0)
    for scale in (1.0, 1e-12, 1e8):
        A = rng.normal(size=(4, 4)) * scale
        A = A + A.T
        w, V = linalg.eigh(A)
        w_np, V_np = linalg.eigh_numpy(A)
        np.testing.assert_allclose(w, w_np, rtol=1e-12, atol=1e-14 * scale)
        # same eigenvectors up to sign
        np.testing.assert_allclose(np.abs(np.sum(V * V_np, axis=0)), 1.0, atol=1e-10)


def test_quaternion_kernels_match_geometry():
    rng = np.random.default_rng(1)
    T = g.transform_from_rotation_translation(g.random_rotation_matrices(rng, 50),
                                              rng.normal(size=(50, 3)))
    T[0, :3, :3] = g.matrix_from_rotvec(np.array([np.pi, 0, 0]))   # 180 deg branch
    for X in T:
        q, qd = quaternion.dual_quat_one(X)
        q_np, qd_np = g.dual_quat_from_transform(X)
        np.testing.assert_allclose(q, q_np, atol=1e-15)
        np.testing.assert_allclose(qd, qd_np, atol=1e-14)
        assert quaternion.is_rigid(X)
    bad = T[1].copy()
    bad[:3, :3] *= -1.0     # det -1
    assert not quaternion.is_rigid(bad)


def test_gram_kernel_matches_numpy_weighted_and_not():
    rng = np.random.default_rng(2)
    C, H, _ = general_case(rng, n=40, sigma_r=0.01, sigma_t=0.01)
    p = build_problem(C, H)
    w = rng.uniform(0.0, 3.0, size=40)
    for weights in (None, w):
        comp = gram.grams_compiled(p.q_C, p.q_C_dual, p.q_H, p.q_H_dual, weights)
        twin = gram.gram_blocks(p.q_C, p.q_C_dual, p.q_H, p.q_H_dual, weights)
        for a, b in zip(comp, twin):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


_TWIN_CHECK = """
import json, sys
import numpy as np
sys.path.insert(0, "tests")
from simcalib import geometry as g
from simcalib.solvers.kernels import jit, batch, gram
from simcalib.solvers.kernels.quaternion import RIGID_TOL
from simcalib.solvers.problem import build_problem
from solver_cases import general_case, random_X

rng = np.random.default_rng(5)
n = 25
C, H, _ = general_case(rng, n=n, sigma_r=0.01, sigma_t=0.01)
bad = H.copy()
bad[7, :3, :3] *= -1.0                    # det -1: motion 7 is not rigid
nan = C.copy()
nan[3, 1, 2] = np.nan
p = build_problem(C, H)
Q = np.ascontiguousarray(np.concatenate([p.q_C.T, p.q_H.T, p.q_C_dual.T, p.q_H_dual.T]))
w = rng.uniform(0.2, 2.0, n)
q, qd = g.dual_quat_from_transform(random_X(rng))
P = rng.normal(size=(6, 4, 4))
nrm = rng.uniform(1, 2, 2)
e = np.empty
cases = {   # kernel name -> argument tuples (the arrays it writes are among them)
    "_quats_soa": [(C, H, RIGID_TOL, e((16, n))), (C, bad, RIGID_TOL, e((16, n))),
                   (nan, H, RIGID_TOL, e((16, n)))],
    "_outer_from_soa": [(Q, w, True, n, e((6, 4, 4)), e(2)),
                        (Q, np.ones(n), False, n - 3, e((6, 4, 4)), e(2))],
    "_grams_from_outer": [(gram._T, P, nrm, e((4, 4)), e((4, 4)), e((4, 4)))],
    "_fit_dots": [(Q, n, q, e(n))],
    "_cost_soa": [(Q, w, True, n, q, qd, 0.7), (Q, w, False, n, q, qd, 2.0)],
}
twins = {k.__name__: k for k in jit._KERNELS if k.twin is not None}
worst = {}
with jit.interpreted() as on:
    assert on
    for name, kernel in twins.items():
        for args in cases[name]:
            a1 = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
            a2 = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
            r1, r2 = kernel.py_func(*a1), kernel.twin(*a2)
            assert (r1 is None) == (r2 is None), (name, r1, r2)
            assert isinstance(r1, float) == isinstance(r2, float), (name, r1, r2)
            if isinstance(r1, int):   # an index: exact (-1: every motion converted)
                assert r1 == r2, (name, r1, r2)
            written = r1 is None or isinstance(r1, float) or r1 == -1
            diffs = [abs(r1 - r2) / max(abs(r1), 1.0)] if isinstance(r1, float) else []
            for x1, x2 in zip(a1, a2):   # every array (Q is undefined after a bad index)
                if written and isinstance(x1, np.ndarray) and x1.dtype == np.float64:
                    diffs.append(float(np.max(np.abs(x1 - x2)) / max(np.max(np.abs(x1)), 1.0)))
            worst[name] = max([worst.get(name, 0.0)] + diffs)
print(json.dumps({"twins": sorted(twins), "cases": sorted(cases), "worst": worst,
                  "numba": "numba" in sys.modules}))
"""


def test_numpy_twins_equal_the_kernels_python_code():
    """Every kernel with a numpy twin (jit.twin_of: what interpreted calls run instead of
    the kernel's loop over the motions) gives the kernel's own results to rounding: return
    value and every array it writes; non-rigid and non-finite motions give the same index.
    (A fresh interpreter: the kernels' Python functions run, numba is not imported.)"""
    import json
    import subprocess
    import sys
    from pathlib import Path
    out = subprocess.run([sys.executable, "-c", _TWIN_CHECK], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parents[1], timeout=120)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert got["twins"] == got["cases"]   # a new twin needs its case above
    assert not got["numba"]
    for name, worst in got["worst"].items():
        assert worst < 1e-13, (name, worst)


def test_solve_core_satisfies_numpy_stationarity():
    """The compiled core's dqopt solution checked with numpy: the KKT conditions of eq. 10
    and a cost below a dense numpy scan of the constraint set; every method's cost is at or
    above dqopt's. (Through simcalib.solve: no extra compiled entry point for the test.)"""
    rng = np.random.default_rng(3)
    C, H, _ = general_case(rng, n=30, sigma_r=0.02, sigma_t=0.02)
    S, W, M = gram.problem_matrices(prepare_problem(C, H), 1.0)
    sol = simcalib.solve(C, H, method="dqopt")
    q, qd = g.dual_quat_from_transform(sol.X)
    mu = sol.diagnostics["mu"]
    lam = q @ S @ q + qd @ M @ qd + 2 * q @ W @ qd
    scale = np.abs(S).max()
    np.testing.assert_allclose(S @ q + W @ qd - lam * q - mu * qd, 0, atol=1e-9 * scale)
    np.testing.assert_allclose(M @ qd + W.T @ q - mu * q, 0, atol=1e-9 * scale)
    for method in dqcore.METHOD_CODES:
        assert simcalib.solve(C, H, method=method).cost >= sol.cost * (1 - 1e-12), method
    # numpy scan: for each unit q the best q' (q.q' = 0) is a linear solve
    best = np.inf
    for _ in range(2000):
        u = rng.normal(size=4)
        u /= np.linalg.norm(u)
        P = np.eye(4) - np.outer(u, u)
        qd_u = P @ -np.linalg.lstsq(P @ M @ P, P @ W.T @ u, rcond=None)[0]
        best = min(best, u @ S @ u + qd_u @ M @ qd_u + 2 * u @ W @ qd_u)
    assert lam <= best + 1e-12 * abs(best)


def test_solve_equals_solve_batch_bitwise():
    rng = np.random.default_rng(4)
    Cs, Hs = [], []
    for _ in range(3):
        C, H, _ = general_case(rng, n=20, sigma_r=0.01, sigma_t=0.01)
        Cs.append(C)
        Hs.append(H)
    for method in ("dqopt", "dq2ndord", "dqitr"):
        b = simcalib.solve_batch(np.stack(Cs), np.stack(Hs), method=method, alpha=0.7)
        for i in range(3):
            s = simcalib.solve(Cs[i], Hs[i], method=method, alpha=0.7)
            np.testing.assert_array_equal(s.X, b.X[i])


def test_runtime_excludes_compilation():
    rng = np.random.default_rng(5)
    C, H, _ = general_case(rng, n=10)
    sol = simcalib.solve(C, H)
    assert "compile_s" in sol.diagnostics and sol.diagnostics["compile_s"] >= 0
    assert sol.runtime_s < 0.5


# ---------------------------------------------------------------------------- weights
def test_weights_equal_repeated_motions_and_zero_weight_drops_outlier():
    rng = np.random.default_rng(6)
    C, H, X = general_case(rng, n=12, sigma_r=0.01, sigma_t=0.01)
    w = np.ones(12)
    w[:3] = 2.0
    rep_C = np.concatenate([C, C[:3]])
    rep_H = np.concatenate([H, H[:3]])
    for method in ("dqopt", "dq2steps", "dqnlopt", "dqoptpoly"):
        a = simcalib.solve(C, H, method=method, weights=w)
        b = simcalib.solve(rep_C, rep_H, method=method)
        np.testing.assert_allclose(a.X, b.X, atol=1e-7, err_msg=method)
        np.testing.assert_allclose(a.cost, b.cost, rtol=1e-9, err_msg=method)
    # an outlier with weight 0 has no influence
    Hb = H.copy()
    Hb[0] = g.transform_from_rotation_translation(g.random_rotation_matrices(rng), [5, 5, 5])
    w0 = np.ones(12)
    w0[0] = 0.0
    a = simcalib.solve(C, Hb, weights=w0)
    b = simcalib.solve(C[1:], H[1:])
    np.testing.assert_allclose(a.X, b.X, atol=1e-9)
    # batch with (B, N) weights equals single solves
    bw = simcalib.solve_batch(np.stack([C, C]), np.stack([H, Hb]), weights=np.stack([w, w0]))
    np.testing.assert_array_equal(bw.X[1], a.X)
    np.testing.assert_allclose(bw.cost[1], a.cost, rtol=1e-12)


def test_weight_validation_and_unsupported_methods():
    rng = np.random.default_rng(7)
    C, H, _ = general_case(rng, n=6)
    for bad, exc, msg in (([1, 1], ValueError, r"shape \(6,\)"),
                          ([1, 1, 1, 1, 1, -1], ValueError, ">= 0"),
                          ([0.0] * 6, ValueError, "all zero"),
                          ([1, 1, 1, 1, 1, np.nan], ValueError, "finite"),
                          (np.ones(6, complex), TypeError, "complex")):
        with pytest.raises(exc, match=msg):
            simcalib.solve(C, H, weights=bad)
    with pytest.raises(ValueError, match="methods with weights: .*dqopt"):
        simcalib.solve(C, H, method="daniilidis", weights=np.ones(6))
    with pytest.raises(ValueError, match=r"shape \(2, 6\)"):
        simcalib.solve_batch(np.stack([C, C]), np.stack([H, H]), weights=np.ones(6))
    from simcalib.solvers import get
    assert get("dqopt").supports_weights and not get("daniilidis").supports_weights


# ---------------------------------------------------------------------------- defects
def _rot_err_deg(A, B):
    R = A[:3, :3].T @ B[:3, :3]
    return np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))


@pytest.mark.parametrize("seed", range(6))
def test_near_180_motions_pick_the_right_alignment(seed):
    """All motions within ~0.5 deg of 180 deg with 0.57 deg noise: the scalar-part rule is
    a coin flip per motion; the solvers must still find X (and never certify a wrong X)."""
    rng = np.random.default_rng(seed)
    n = 50
    ax = rng.normal(size=(n, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    ang = np.pi - np.abs(rng.normal(0, 0.005, size=n))
    C = g.transform_from_rotation_translation(g.matrix_from_rotvec(ax * ang[:, None]),
                                              rng.normal(size=(n, 3)))
    X = random_X(rng)
    H = g.perturb_transforms(g.invert_transform(X)[None] @ C @ X[None], np.radians(0.57),
                             0.01, rng)
    for method in ("dqopt", "dqnlopt", "dqoptpoly", "dq2ndord"):
        sol = simcalib.solve(C, H, method=method)
        assert _rot_err_deg(sol.X, X) < 3.0, method
    b = simcalib.solve_batch(C[None], H[None])
    assert _rot_err_deg(b.X[0], X) < 3.0


def test_alpha_range_and_types():
    rng = np.random.default_rng(8)
    C, H, X = general_case(rng, n=15)
    from simcalib.solvers.problem import ALPHA_MAX, ALPHA_MIN
    for a in (ALPHA_MIN, 1.0, ALPHA_MAX):      # exact recovery across the accepted range
        for sol in (simcalib.solve(C, H, alpha=a),):
            assert _rot_err_deg(sol.X, X) < 1e-6 and np.abs(sol.X[:3, 3] - X[:3, 3]).max() < 1e-9
    for a in (1e-8, 1e100, 1e200):
        with pytest.raises(ValueError, match=r"alpha must lie in \[1e-06, 1e\+06\]"):
            simcalib.solve(C, H, alpha=a)
        with pytest.raises(ValueError, match=r"alpha must lie in"):
            simcalib.solve_batch(C[None], H[None], alpha=a)
    for a in ("1", 1 + 0j, True):
        with pytest.raises(TypeError, match="alpha must be a real number"):
            simcalib.solve(C, H, alpha=a)
        with pytest.raises(TypeError, match="alpha must be a real number"):
            simcalib.solve_batch(C[None], H[None], alpha=a)


def test_complex_input_and_determinant_message():
    rng = np.random.default_rng(9)
    C, H, _ = general_case(rng, n=5)
    with pytest.raises(TypeError, match="complex"):
        simcalib.solve(C.astype(complex), H)
    with pytest.raises(TypeError, match="complex"):
        simcalib.solve_batch(C[None].astype(complex), H[None])
    bad = C.copy()
    bad[2, :3, :3] = -bad[2, :3, :3]          # orthonormal, det -1
    with pytest.raises(ValueError, match=r"det = -1 "):
        simcalib.solve(bad, H)


def test_batch_member_without_information_fails_with_reason():
    rng = np.random.default_rng(10)
    C, H, _ = general_case(rng, n=8)
    ident = np.broadcast_to(np.eye(4), (8, 4, 4))
    for method in ("dqopt", "dq2ndord", "dqitr", "dq2ndord_lambda", "dqconvrlx", "dq2steps"):
        for order in ((C, ident), (ident, C)):
            Cs = np.stack([order[0], order[1]])
            Hs = np.stack([H if order[0] is C else ident, ident if order[0] is C else H])
            b = simcalib.solve_batch(Cs, Hs, method=method)
            for i in range(2):
                if b.success[i]:
                    assert np.isfinite(b.X[i]).all(), method
                else:
                    assert b.diagnostics["failure_reason"][i], method
            real = 0 if order[0] is C else 1
            assert b.success[real], method


def test_dqitr_succeeds_on_exact_data():
    from simcalib.world.synthetic import SyntheticConfig, synthetic_problem
    for motion in ("line", "circle", "random"):
        for seed in range(4):
            cfg = SyntheticConfig(motion=motion, sigma_r_rad=0.0, sigma_t_m=0.0)
            p = synthetic_problem(cfg, n=20, rng=np.random.default_rng(seed))
            sol = simcalib.solve(p.C, p.H, method="dqitr")
            assert sol.success, (motion, seed, sol.solver_message)


def test_problem_cost_weighted_matches_definition():
    rng = np.random.default_rng(11)
    C, H, _ = general_case(rng, n=7, sigma_r=0.05, sigma_t=0.05)
    w = rng.uniform(0.1, 2.0, 7)
    p = prepare_problem(C, H, 1.3, w)
    q, qd = g.dual_quat_from_transform(random_X(rng))
    per = [problem_cost(prepare_problem(C[[i, i]], H[[i, i]], 1.3), q, qd, 1.3) / 2
           for i in range(7)]
    # the pair-problems may align a motion differently only near 180 deg; these are generic
    np.testing.assert_allclose(problem_cost(p, q, qd, 1.3), np.dot(w, per), rtol=1e-12)


def test_threaded_batch_equals_serial_and_single_solves(monkeypatch):
    """solve_batch runs chunks of the batch on threads: same bits as one thread and as
    single solves, whatever the number of threads and chunks."""
    from simcalib.solvers.kernels import batch as kb
    rng = np.random.default_rng(21)
    B, n = 200, 8
    C = g.transform_from_rotation_translation(g.random_rotation_matrices(rng, (B, n)),
                                              rng.normal(size=(B, n, 3)))
    X = random_X(rng)
    H = g.perturb_transforms(g.invert_transform(X) @ C @ X, 0.01, 0.01, rng)
    alphas = rng.uniform(0.5, 2.0, B)
    out = {}
    for threads in (1, 3):
        monkeypatch.setattr(kb, "_threads", lambda t=threads: t)
        out[threads] = simcalib.solve_batch(C, H, alpha=alphas)
    np.testing.assert_array_equal(out[1].X, out[3].X)
    np.testing.assert_array_equal(out[1].cost, out[3].cost)
    for b in (0, kb._CHUNK - 1, kb._CHUNK, B - 1):   # chunk boundaries
        s = simcalib.solve(C[b], H[b], alpha=float(alphas[b]))
        np.testing.assert_array_equal(s.X, out[3].X[b])


def test_chunk_starts_cover_the_batch_and_shrink_at_the_end():
    """The threads' chunks cover problems 0..B-1 once, in order; full chunks while many
    problems remain, then smaller ones down to _MIN_CHUNK (only the very last may be
    smaller), never growing again."""
    from simcalib.solvers.kernels import batch as kb
    for nb in (65, 200, 1000, 1001, 20000):
        for threads in (2, 3, 8):
            starts = kb._chunk_starts(nb, threads)
            assert starts[0] == 0 and starts[-1] == nb
            sizes = np.diff(starts)
            assert (sizes[:-1] >= kb._MIN_CHUNK).all() and (sizes >= 1).all()
            assert (sizes <= kb._CHUNK).all()
            assert (np.diff(sizes) <= 0).all()   # non-increasing
            if nb >= 8 * threads * kb._CHUNK:
                assert sizes[0] == kb._CHUNK


def _batch_in_child(C, H, X_parent, conn):
    conn.send(bool(np.array_equal(simcalib.solve_batch(C, H).X, X_parent)))


def test_threaded_batch_in_a_forked_child(monkeypatch):
    """A child forked after a threaded batch (it inherits the pool object, not its
    threads) still solves batches on threads."""
    import multiprocessing
    from simcalib.solvers.kernels import batch as kb
    monkeypatch.setattr(kb, "_threads", lambda: 2)
    rng = np.random.default_rng(23)
    C, H, _ = general_case(rng, n=6)
    C = np.repeat(C[None], 130, axis=0)
    H = np.repeat(H[None], 130, axis=0)
    X = simcalib.solve_batch(C, H).X          # the pool exists now
    ctx = multiprocessing.get_context("fork")
    parent, child = ctx.Pipe()
    p = ctx.Process(target=_batch_in_child, args=(C, H, X, child))
    p.start()
    assert parent.poll(120), "the forked child's batch did not finish"
    assert parent.recv() is True
    p.join(30)
    assert p.exitcode == 0


@pytest.mark.parametrize("where", [(0, 0), (1, 2), (2, 3), (3, 1), (3, 3)])
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_entries_are_not_rigid(where, value):
    """The branch-free rigidity test rejects a NaN or infinite entry anywhere (rotation,
    translation, last row), alone and inside a batch (the first bad motion is named)."""
    rng = np.random.default_rng(22)
    C, H, _ = general_case(rng, n=6)
    bad = H[4].copy()
    bad[where] = value
    assert not quaternion.is_rigid(bad)
    H2 = H.copy()
    H2[4] = bad
    from simcalib.solvers.kernels.batch import run_batch
    r = run_batch(0, np.ones(2), C=np.ascontiguousarray(np.stack([C, C])),
                  H=np.ascontiguousarray(np.stack([H, H2])))
    assert list(r["bad"]) == [-1, 4]
    with pytest.raises(ValueError, match=r"H\[1\] contains NaN or inf \(first at index 4\)"):
        simcalib.solve_batch(np.stack([C, C]), np.stack([H, H2]))


def test_read_only_motions_use_the_loaded_kernel_signature():
    """A batch of one problem given as a read-only view (``np.broadcast_to``, as the
    scale's jackknife passes a's motions) runs on the signature load_every_kernel loaded:
    no second specialisation (its load from numba's cache cost ~0.2 s of every
    ``calibrate``), and the same X as the writable copy's."""
    from simcalib.solvers.kernels import batch, jit
    batch.load_every_kernel()
    if jit.interpreting():
        pytest.skip("interpreted kernels have no signatures")
    before = list(batch._one.signatures)
    C, H = batch.random_motions_for_warm_up()
    C_view = np.broadcast_to(C, (1,) + C.shape)
    assert not C_view.flags.writeable
    sol = simcalib.solve_batch(C_view, H[None], weights=np.ones((1, C.shape[0])))
    assert list(batch._one.signatures) == before
    np.testing.assert_array_equal(sol.X, simcalib.solve_batch(C[None].copy(), H[None],
                                                              weights=np.ones((1, 8))).X)


# ----------------------------------------------- scratch arrays, 4x4 Jacobi, scalar parts
def test_eigh_is_for_4x4_matrices():
    with pytest.raises(ValueError, match=r"4x4 matrix; received shape \(3, 3\)"):
        linalg.eigh(np.eye(3))


@pytest.mark.parametrize("method", sorted(dqcore.METHOD_CODES))
def test_solve_core_does_not_depend_on_its_scratch(method):
    """_solve_core takes its work arrays from the caller (no allocation per solve): their
    contents before the call (NaN, zeros, another problem's) change no bit of the result."""
    rng = np.random.default_rng(31)
    C, H, _ = general_case(rng, n=12, sigma_r=0.01, sigma_t=0.01)
    p = prepare_problem(C, H, 1.0)
    S, W, M = gram.problem_matrices(p, 1.0)
    S, W, M = (np.ascontiguousarray(a) for a in (S, W, M))
    results = []
    for fill in (np.nan, 0.0, 1e300):
        wk = np.full((dqcore.N_WORK, 4, 4), fill)
        q, qd, info = np.empty(4), np.empty(4), np.empty(dqcore.N_INFO)
        dqcore._solve_core(dqcore.METHOD_CODES[method], S, W, M, q, qd, info, wk)
        results.append((q, qd, info))
    for q, qd, info in results[1:]:
        np.testing.assert_array_equal(q, results[0][0])
        np.testing.assert_array_equal(qd, results[0][1])
        np.testing.assert_array_equal(info, results[0][2])
    q_ref, qd_ref, _ = dqcore.solve_matrices(method, S, W, M)
    np.testing.assert_array_equal(q_ref, results[0][0])


def test_converted_scalar_parts_are_never_negative():
    """_quats_soa has no sign pass: the conversion gives every scalar part w >= 0 (a
    rotation of exactly 180 deg has w = 0), so each pair's scalar parts agree in sign."""
    rng = np.random.default_rng(32)
    C, H, _ = general_case(rng, n=40, sigma_r=0.01, sigma_t=0.01)
    axes = rng.normal(size=(10, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    C[:10, :3, :3] = g.matrix_from_rotvec(np.pi * axes)           # exactly 180 deg
    C[10:20, :3, :3] = g.matrix_from_rotvec((np.pi - 1e-9) * axes)
    C[20:23, :3, :3] = np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), \
        np.diag([-1.0, -1.0, 1.0])
    Q = np.empty((16, 40))
    assert gram._quats_soa(np.ascontiguousarray(C), np.ascontiguousarray(C), 1e-6, Q) == -1
    assert (Q[3] >= 0.0).all() and (Q[7] >= 0.0).all()
    assert not (np.signbit(Q[3]) & (Q[3] != 0.0)).any()
