"""The pose-level error model of the estimation path (simcalib.estimation.pose_errors):
residuals, the sensitivity of X to each pose, the neighbour-correlation test, the variogram
fit and X's covariance under the model."""

import numpy as np
import pytest

import simcalib
from simcalib.estimation import pose_errors as pe
from simcalib.geometry import (invert_transform, matrix_from_rotvec,
                               transform_from_rotation_translation)
from simcalib.solvers.diagnostics.uncertainty import pose_error


def _exp6(xi):
    return transform_from_rotation_translation(matrix_from_rotvec(xi[..., :3]), xi[..., 3:])


def _station_rig(n=24, seed=0):
    """Hand poses over a 0.5 m workspace, X, Y, camera poses ``Y^-1 A X`` (noise-free)."""
    rng = np.random.default_rng(seed)
    R = matrix_from_rotvec(rng.normal(0.0, 0.6, (n, 3)))
    A = transform_from_rotation_translation(R, rng.uniform(-0.25, 0.25, (n, 3)))
    X = _exp6(np.array([0.2, -0.1, 0.3, 0.05, 0.02, 0.08]))
    Y = _exp6(np.array([0.1, 0.4, -0.2, 0.5, 0.0, -0.1]))
    return A, invert_transform(Y)[None] @ A @ X[None], X, Y


def _all_pairs(n):
    i, j = np.triu_indices(n, 1)
    return i, j


def _consecutive(n, step=3):
    i = np.arange(n - step)
    return i, i + step


@pytest.mark.parametrize("pairs", [_all_pairs, _consecutive])
def test_sensitivity_predicts_the_resolved_estimate(pairs):
    """X re-solved after small errors on b's poses moves by sum_i G_i r_i (first order),
    for every pair of stations and for overlapping consecutive motions alike."""
    A, B, _, _ = _station_rig(30)
    i, j = pairs(30)
    rng = np.random.default_rng(1)
    B0 = B @ _exp6(rng.normal(0.0, 2e-3, (30, 6)))          # a noisy data set
    C, H0 = invert_transform(A[i]) @ A[j], invert_transform(B0[i]) @ B0[j]
    X0 = simcalib.solve(C, H0, method="dqopt", alpha=1.0).X
    G = pe.pose_sensitivity(C, H0, X0, 1.0, np.stack([i, j], 1), 30)
    xi = rng.normal(0.0, 1e-5, (30, 6))
    B1 = B0 @ _exp6(xi)
    X1 = simcalib.solve(C, invert_transform(B1[i]) @ B1[j], method="dqopt", alpha=1.0).X
    moved = pose_error(X1, X0)
    predicted = np.einsum("nij,nj->i", G, xi)
    assert np.allclose(predicted, moved, rtol=2e-3, atol=1e-9 * np.abs(moved).max() + 1e-12)
    # an error common to every pose is X's own change: the sensitivities sum to it
    common = np.array([1e-5, -2e-5, 0.5e-5, 1e-5, 0.0, -1e-5])
    B2 = B0 @ _exp6(common)[None]
    X2 = simcalib.solve(C, invert_transform(B2[i]) @ B2[j], method="dqopt", alpha=1.0).X
    assert np.allclose(G.sum(0) @ common, pose_error(X2, X0), atol=1e-9)


def test_residuals_are_the_error_of_b_that_explains_each_pose():
    A, B, X, Y = _station_rig(20)
    r, Y_fit = pe.pose_residuals(A, B, X)
    assert np.abs(r).max() < 1e-12 and np.allclose(Y_fit, Y)
    xi = np.zeros((20, 6))
    xi[7] = [0.01, -0.02, 0.0, 0.003, 0.0, -0.001]
    r, _ = pe.pose_residuals(A, B @ _exp6(xi), X, Y)
    assert np.allclose(r, xi, atol=1e-6)


def _smooth_field(T, amp, rng, scale=1.0):
    """A smooth error over the pose space: low-order sinusoids of (position, rotvec)."""
    from simcalib.geometry import rotvec_from_matrix
    f = np.concatenate([T[:, :3, 3] / 0.25, rotvec_from_matrix(T[:, :3, :3])], 1)
    w = rng.normal(0.0, scale, (3, 6))
    basis = np.sin(f @ w.T + rng.uniform(0, 2 * np.pi, 3))
    return basis @ (rng.normal(0.0, 1.0, (3, 6)) * amp)


def test_neighbour_correlation_tells_smooth_errors_from_white_ones():
    A, _, _, _ = _station_rig(40, seed=2)
    rng = np.random.default_rng(4)
    pairs = pe.neighbour_pairs(A)
    amp = np.array([1e-3] * 3 + [1e-3] * 3)
    zs_white = [pe.neighbour_correlation(rng.normal(0, 1e-3, (40, 6)), pairs["pose"])[1]
                for _ in range(20)]
    zs_field = [pe.neighbour_correlation(_smooth_field(A, amp, rng)
                                         + rng.normal(0, 3e-4, (40, 6)), pairs["pose"])[1]
                for _ in range(20)]
    assert np.mean(np.array(zs_white) > 1.645) <= 0.2
    assert np.mean(np.array(zs_field) > 1.645) >= 0.7
    # recording-order neighbours: a drift along the recording
    drift = np.cumsum(rng.normal(0, 1e-4, (40, 6)), axis=0)
    assert pe.neighbour_correlation(drift, pairs["time"])[1] > 3.0


def test_fit_finds_the_correlated_share_and_its_range():
    """Residuals with a known white part and a part correlated along the recording: the
    fitted model puts most of the variance where it is, with a range of the right order."""
    rng = np.random.default_rng(5)
    n = 400
    idx = np.arange(n)
    K = np.exp(-0.5 * ((idx[:, None] - idx[None]) / 10.0) ** 2)
    L = np.linalg.cholesky(K + 1e-9 * np.eye(n))
    corr = L @ rng.normal(0.0, 2e-3, (n, 6))
    r = corr + rng.normal(0.0, 1e-3, (n, 6))
    A = np.repeat(np.eye(4)[None], n, axis=0)                 # no pose-space structure
    A[:, :3, 3] = rng.uniform(-1, 1, (n, 3))
    m = pe.fit_error_model(r, pe.pair_design(A, idx))
    s = m.shares()
    assert s["time"] > 0.5 and s["white"] > 0.05
    assert 4.0 <= m.ell_time <= 25.0


def test_model_covariance_is_the_kernel_sum():
    """model_covariance equals sum_ij K_ij G_i M G_j^T computed densely (blocks of one
    pose when there are few poses; the recording kernel, cut at 5 ranges, to 1e-5)."""
    rng = np.random.default_rng(6)
    n = 50
    A, _, _, _ = _station_rig(n, seed=7)
    idx = np.sort(rng.choice(80, n, replace=False))
    G = rng.normal(0.0, 1.0, (n, 6, 6))
    M = [pe.psd(rng.normal(0, 1, (6, 6)) @ rng.normal(0, 1, (6, 6)).T) for _ in range(3)]
    m = pe.ErrorModel(M[0], M[1], M[2], 0.7, 4.0, M[0], n)
    q, p = pe.pose_coordinates(A)
    Kp = np.exp(-0.5 * (pe.pose_distances(q, p, q, p) / 0.7) ** 2)
    Kt = np.exp(-0.5 * ((idx[:, None] - idx[None]) / 4.0) ** 2)
    dense = (np.einsum("nij,jk,nlk->il", G, M[0], G)
             + np.einsum("nm,nij,jk,mlk->il", Kp, G, M[1], G)
             + np.einsum("nm,nij,jk,mlk->il", Kt, G, M[2], G))
    assert np.allclose(pe.model_covariance(G, m, A, idx), dense, rtol=1e-5,
                       atol=1e-5 * np.abs(dense).max())


@pytest.mark.slow
def test_model_covariance_of_a_long_recording_uses_blocks_within_a_few_percent():
    rng = np.random.default_rng(8)
    n = 3 * pe.KERNEL_BLOCKS
    t = np.linspace(0, 20, n)
    R = matrix_from_rotvec(np.stack([0.5 * np.sin(0.3 * t), 0.4 * np.cos(0.2 * t),
                                     0.3 * np.sin(0.1 * t)], 1))
    A = transform_from_rotation_translation(R, np.stack([np.sin(0.2 * t), np.cos(0.3 * t),
                                                         0.1 * t], 1))
    G = np.repeat(rng.normal(0, 1, (1, 6, 6)), n, axis=0) + 0.1 * rng.normal(0, 1, (n, 6, 6))
    M = pe.psd(np.eye(6) + 0.1 * rng.normal(0, 1, (6, 6)))
    m = pe.ErrorModel(np.zeros((6, 6)), M, np.zeros((6, 6)), 0.8, 1.0, M, n)
    q, p = pe.pose_coordinates(A)
    Kp = np.exp(-0.5 * (pe.pose_distances(q, p, q, p) / 0.8) ** 2)
    dense = np.einsum("nm,nij,jk,mlk->il", Kp, G, M, G)
    got = pe.model_covariance(G, m, A, np.arange(n))
    assert np.allclose(np.diag(got), np.diag(dense), rtol=0.05)


@pytest.mark.parametrize("tree", [True, False])
def test_nearest_poses_by_the_tree_equal_the_brute_force(tree, monkeypatch):
    """The k-d tree with the chord bound (and the search over all distances, row by row)
    finds exactly the k nearest poses of the pose metric (random poses, and a pose
    recorded twice: its twin is its nearest)."""
    from simcalib import geometry as geo
    from simcalib.estimation import pose_errors
    from simcalib.estimation.pose_errors import (_nearest_poses, pose_coordinates,
                                                 pose_distances)
    if tree:
        monkeypatch.setattr(pose_errors, "ALL_DISTANCES_POSES", 0)
    rng = np.random.default_rng(8)
    T = geo.transform_from_rotation_translation(geo.matrix_from_rotvec(rng.normal(size=(300, 3))),
                                                rng.normal(scale=0.3, size=(300, 3)))
    T[17] = T[230]
    q, p = pose_coordinates(T)
    nb = _nearest_poses(q, p, 3)
    D = pose_distances(q, p, q, p)
    np.fill_diagonal(D, np.inf)
    brute = np.sort(D, axis=1)[:, :3]
    # the same distances (which of two poses at one distance is taken is a tie)
    np.testing.assert_array_equal(np.sort(np.take_along_axis(D, nb, 1), axis=1), brute)
    assert nb[17][0] == 230 and nb[230][0] == 17


@pytest.mark.parametrize("n", [2, 5, 40, 300])
def test_nearest_poses_from_all_distances_equal_the_tree_s(n, monkeypatch):
    """Up to ALL_DISTANCES_POSES poses the nearest come from all distances, row by row:
    the very positions the k-d tree gives (ties, e.g. a pose recorded three times, go to
    the lower position in both)."""
    from simcalib import geometry as geo
    from simcalib.estimation import pose_errors as pe
    rng = np.random.default_rng(n)
    T = geo.transform_from_rotation_translation(geo.matrix_from_rotvec(rng.normal(size=(n, 3))),
                                                rng.normal(scale=0.3, size=(n, 3)))
    T[n // 2] = T[-1] = T[0]
    q, p = pe.pose_coordinates(T)
    k = min(3, n - 1)
    assert n <= pe.ALL_DISTANCES_POSES
    every = pe._nearest_poses(q, p, k)
    monkeypatch.setattr(pe, "ALL_DISTANCES_POSES", 0)
    np.testing.assert_array_equal(every, pe._nearest_poses(q, p, k))
    if n > 2:
        assert every[0][:2].tolist() == [n // 2, n - 1]


def test_neighbours_of_a_small_recording_do_not_import_scipy_spatial():
    import subprocess
    import sys
    from pathlib import Path
    code = ("import sys, numpy as np; from simcalib import geometry as geo; "
            "from simcalib.estimation.pose_errors import neighbour_pairs; "
            "rng = np.random.default_rng(0); "
            "T = geo.transform_from_rotation_translation(geo.matrix_from_rotvec("
            "rng.normal(size=(200, 3))), rng.normal(size=(200, 3))); "
            "assert neighbour_pairs(T)['pose'][0].size > 0; "
            "print('spatial' if 'scipy.spatial' in sys.modules else 'no spatial')")
    root = Path(__file__).resolve().parent.parent
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, cwd=root)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "no spatial"
