"""simcalib.solvers.diagnostics.pose_noise: motions sharing poses (white pose-noise test,
simulated bias and covariance of the alpha-cost minimiser) and solve(pose_pairs=...)."""

import numpy as np
import pytest
from scipy.special import chdtri

import simcalib
from simcalib.geometry import invert_transform, matrix_from_rotvec, perturb_transforms
from simcalib.solvers.diagnostics import pose_noise as PN
from simcalib.solvers.diagnostics.uncertainty import pose_error

STEP = 2


def _X():
    X = np.eye(4)
    X[:3, :3] = matrix_from_rotvec(np.array([0.3, -0.5, 0.8]))
    X[:3, 3] = (0.12, -0.25, 0.08)
    return X


def _path(n_pose=120):
    """A smooth 6-DoF path of camera a (poses T_world_a), sampled densely."""
    t = np.arange(n_pose) * 0.06
    T = np.tile(np.eye(4), (n_pose, 1, 1))
    T[:, :3, :3] = matrix_from_rotvec(np.stack(
        [0.6 * np.sin(t), 0.5 * np.cos(0.7 * t), 0.7 * np.sin(0.5 * t + 1)], axis=1))
    T[:, :3, 3] = np.stack([0.4 * np.cos(t), 0.3 * np.sin(1.3 * t), 0.1 * t], axis=1)
    return T


def _motions(Pa, Pb):
    k = np.arange(Pa.shape[0] - STEP)
    C = invert_transform(Pa[k]) @ Pa[k + STEP]
    H = invert_transform(Pb[k]) @ Pb[k + STEP]
    return C, H, np.stack([k, k + STEP], axis=1)


def _white_data(rng, sr=np.deg2rad(0.3), st=0.004, n_pose=120):
    X = _X()
    Pa = _path(n_pose)
    Pb = Pa @ X
    return (*_motions(perturb_transforms(Pa, sr, st, rng), perturb_transforms(Pb, sr, st, rng)),
            X)


def _correlated_data(rng, n_pose=120):
    """Pose errors that drift smoothly (AR(1), rho = 0.9): not white."""
    X = _X()
    Pa = _path(n_pose)
    Pb = Pa @ X
    out = []
    for P in (Pa, Pb):
        xi = np.zeros((n_pose, 6))
        z = rng.standard_normal((n_pose, 6)) * np.array([0.004] * 3 + [0.004] * 3)
        for j in range(1, n_pose):
            xi[j] = 0.9 * xi[j - 1] + z[j]
        E = np.tile(np.eye(4), (n_pose, 1, 1))
        E[:, :3, :3] = matrix_from_rotvec(xi[:, :3])
        E[:, :3, 3] = xi[:, 3:]
        out.append(P @ E)
    return (*_motions(*out), X)


def test_check_pose_pairs_names_what_it_received():
    with pytest.raises(ValueError, match=r"shape \(3, 2\).*received shape \(3,\)"):
        PN.check_pose_pairs(np.arange(3), 3)
    with pytest.raises(ValueError, match="integer"):
        PN.check_pose_pairs(np.array([[0, 1.5], [1, 2], [2, 3]]), 3)
    with pytest.raises(ValueError, match=">= 0; received minimum -1"):
        PN.check_pose_pairs(np.array([[-1, 1], [1, 2], [2, 3]]), 3)
    with pytest.raises(ValueError, match="motion 1 starts and ends at datapoint 2"):
        PN.check_pose_pairs(np.array([[0, 1], [2, 2], [2, 3]]), 3)
    P = PN.check_pose_pairs(np.array([[0.0, 2.0], [1.0, 3.0]]), 2)
    assert P.dtype == np.int64 and P.tolist() == [[0, 2], [1, 3]]


def test_expected_autocorrelation_of_consecutive_pairs():
    k = np.arange(100)
    exp = PN.expected_autocorrelation(np.stack([k, k + 2], 1), 4)
    np.testing.assert_allclose(exp, [0.0, -0.5 * 98 / 100, 0.0, 0.0])
    # pairs sharing their start pose correlate positively
    exp = PN.expected_autocorrelation(np.array([[0, 1], [0, 2], [0, 3], [0, 4]]), 1)
    assert exp[0] == pytest.approx(0.5 * 3 / 4)


def _whitened_residuals(sol):
    u = sol.uncertainty
    from simcalib.solvers.diagnostics.uncertainty import linear_model
    e, _, Qr, Qt = linear_model(sol.problem.C, sol.problem.H, sol.X)
    Q = u.noise.sigma_r_rad ** 2 * Qr + u.noise.sigma_t_m ** 2 * Qt
    return np.einsum("nij,nj->ni", np.linalg.inv(np.linalg.cholesky(Q)), e)


def test_white_noise_test_accepts_white_and_rejects_drifting_pose_errors():
    rng = np.random.default_rng(7)
    accepted = []
    for _ in range(5):
        C, H, P, _ = _white_data(rng)
        sol = simcalib.solve(C, H, alpha=1.0)
        accepted.append(PN.white_noise_test(_whitened_residuals(sol), P).accepted)
    assert all(accepted)
    rejected = []
    for _ in range(5):
        C, H, P, _ = _correlated_data(rng)
        sol = simcalib.solve(C, H, alpha=1.0)
        t = PN.white_noise_test(_whitened_residuals(sol), P)
        rejected.append(not t.accepted)
        assert t.threshold == pytest.approx(1.5 * chdtri(4, PN.WHITE_LEVEL))
    assert all(rejected)


def test_minimiser_offset_is_zero_at_dqopt_and_recovers_a_moved_estimate():
    C, H, P, X = _white_data(np.random.default_rng(1))
    sol = simcalib.solve(C, H, alpha=0.8)
    assert np.abs(PN.minimiser_offset(C, H, sol.X, 0.8)).max() < 1e-10
    moved = sol.X.copy()
    moved[:3, 3] += (0.01, -0.02, 0.005)
    off = PN.minimiser_offset(C, H, moved, 0.8)
    np.testing.assert_allclose(off[3:], (-0.01, 0.02, -0.005), atol=1e-9)


def test_simulation_needs_noise_and_is_deterministic():
    C, H, P, X = _white_data(np.random.default_rng(2))
    assert PN.simulate_error(C, X, 1.0, P, 0.0, 0.0) is None       # no noise: no covariance
    a = PN.simulate_error(C, X, 1.0, P, 0.005, 0.004, n_sim=64, n_truths=4)
    b = PN.simulate_error(C, X, 1.0, P, 0.005, 0.004, n_sim=64, n_truths=4)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert np.all(np.linalg.eigvalsh(a[1]) > 0)


@pytest.mark.slow
def test_solve_with_pose_pairs_is_calibrated_on_white_pose_noise():
    """Monte-Carlo: 30 data sets of one smooth path with white pose noise; the simulated
    covariance covers the true X in about 95 % of them and its sigma matches the RMS
    error, where the first-order model with the serial-correlation correction
    overstates it."""
    rng = np.random.default_rng(11)
    d2, err, sim_std, lag_std, methods = [], [], [], [], set()
    for _ in range(30):
        C, H, P, X = _white_data(rng, sr=np.deg2rad(0.5), st=0.006)
        sol = simcalib.solve(C, H, alpha=1.0, correlation_lag=STEP, pose_pairs=P)
        u = sol.uncertainty
        methods.add(u.method)
        d2.append(u.mahalanobis2(X))
        err.append(pose_error(X, sol.X))
        sim_std.append(np.sqrt(np.diag(u.covariance)))
        ref = simcalib.solve(C, H, alpha=1.0, correlation_lag=STEP)
        lag_std.append(np.sqrt(np.diag(ref.uncertainty.covariance)))
    assert methods == {"pose_simulation"}
    coverage = np.mean(np.array(d2) <= chdtri(6, 0.05))
    assert 0.8 <= coverage <= 1.0
    rms = np.sqrt(np.mean(np.array(err) ** 2, axis=0))
    ratio = np.sqrt(np.mean(np.array(sim_std) ** 2, axis=0)) / rms
    assert np.all((ratio > 0.6) & (ratio < 1.6)), ratio
    ratio_lag = np.sqrt(np.mean(np.array(lag_std) ** 2, axis=0)) / rms
    assert np.mean(np.abs(np.log(ratio))) < np.mean(np.abs(np.log(ratio_lag)))


def test_pose_pairs_inputs_and_fallbacks():
    C, H, P, X = _white_data(np.random.default_rng(3))
    with pytest.raises(ValueError, match="pose_pairs must have shape"):
        simcalib.solve(C, H, pose_pairs=P[:-1])
    with pytest.raises(ValueError, match="cannot be combined with robust"):
        simcalib.solve(C, H, pose_pairs=P, robust="ransac")
    prior = simcalib.Prior(X=X, a=10.0, b=10.0)
    sol = simcalib.solve(C, H, prior=prior, pose_pairs=P)
    assert sol.uncertainty.method == "sandwich"            # the simulation models no prior
    assert sol.uncertainty.pose_noise_test.accepted
    Cc, Hc, Pc, _ = _correlated_data(np.random.default_rng(4))
    sol = simcalib.solve(Cc, Hc, pose_pairs=Pc, correlation_lag=STEP)
    assert sol.uncertainty.method == "sandwich"
    assert not sol.uncertainty.pose_noise_test.accepted
    assert "correlated between poses" in sol.uncertainty.pose_noise_test.summary()
