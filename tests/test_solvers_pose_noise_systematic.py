"""Systematic pose errors in the uncertainty (issue 9): pose errors shared by the poses
through common parameters (a marker map's and lens calibrations' errors), their per-pose
PnP sensitivities (simcalib.targets.pnp_sensitivity,
simcalib.sources.vision.error_model.pose_error_basis) and the simulation that draws them
(pose_noise.simulate_error(systematic=...), covariance / solve with
pose_error_basis)."""

import numpy as np
import pytest

import simcalib
from simcalib import geometry as g
from simcalib.solvers.diagnostics import pose_noise as PN
from simcalib.solvers.diagnostics import uncertainty as U

STEP = 2


def _X():
    X = np.eye(4)
    X[:3, :3] = g.matrix_from_rotvec(np.array([0.3, -0.5, 0.8]))
    X[:3, 3] = (0.12, -0.25, 0.08)
    return X


def _path(n_pose=100):
    t = np.arange(n_pose) * 0.06
    T = np.tile(np.eye(4), (n_pose, 1, 1))
    T[:, :3, :3] = g.matrix_from_rotvec(np.stack(
        [0.6 * np.sin(t), 0.5 * np.cos(0.7 * t), 0.7 * np.sin(0.5 * t + 1)], axis=1))
    T[:, :3, 3] = np.stack([0.4 * np.cos(t), 0.3 * np.sin(1.3 * t), 0.1 * t], axis=1)
    return T


def _exp6(xi):
    T = np.zeros(xi.shape[:-1] + (4, 4))
    T[..., :3, :3] = g.matrix_from_rotvec(xi[..., :3])
    T[..., :3, 3] = xi[..., 3:]
    T[..., 3, 3] = 1.0
    return T


def _motions(Pa, Pb):
    k = np.arange(Pa.shape[0] - STEP)
    return (g.invert_transform(Pa[k]) @ Pa[k + STEP], g.invert_transform(Pb[k]) @ Pb[k + STEP],
            np.stack([k, k + STEP], axis=1))


def _constant_basis(n_pose, Ga, Gb):
    """Run-constant pose errors: camera a's through parameters 0-5, b's through 6-11."""
    Ba = np.zeros((n_pose, 6, 12))
    Bb = np.zeros((n_pose, 6, 12))
    Ba[:, :, :6] = Ga
    Bb[:, :, 6:] = Gb
    return Ba, Bb


def _drifting_basis(n_pose, rng, n_param=40, scale=2e-3):
    """Pose errors that drift with the viewpoint: smooth per-pose mixtures of shared
    parameters (as markers entering and leaving the view)."""
    s = np.linspace(0, 1, n_pose)
    centres = np.linspace(0, 1, n_param)
    w = np.exp(-0.5 * ((s[:, None] - centres[None]) / 0.08) ** 2)          # (n_pose, P)
    dirs = rng.normal(size=(2, 6, n_param)) * scale
    return tuple(np.einsum("kp,ip->kip", w, d) for d in dirs)


def test_check_systematic_names_what_it_received():
    B = np.zeros((10, 6, 3))
    Ba, Bb = PN.check_systematic((B, B), 10)
    assert Ba.shape == (10, 6, 3)
    with pytest.raises(ValueError, match="pair"):
        PN.check_systematic(B, 10)
    with pytest.raises(ValueError, match=r"n_pose >= 12.*received shape \(10, 6, 3\)"):
        PN.check_systematic((B, B), 12)
    with pytest.raises(ValueError, match=r"received shape \(10, 5, 3\)"):
        PN.check_systematic((np.zeros((10, 5, 3)), B), 10)
    with pytest.raises(ValueError, match="same shape"):
        PN.check_systematic((B, np.zeros((10, 6, 4))), 10)
    bad = B.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        PN.check_systematic((bad, B), 10)


def test_run_constant_errors_simulate_to_the_change_of_x():
    """A pose error constant over the run is exactly a change of X: the simulation with a
    constant basis (and no white noise) gives the pose-bias propagation."""
    rng = np.random.default_rng(0)
    X = _X()
    Pa = _path()
    C, _, P = _motions(Pa, Pa @ X)
    Ga = rng.normal(size=(6, 6)) * 1e-3
    Gb = rng.normal(size=(6, 6)) * 1e-3
    basis = _constant_basis(Pa.shape[0], Ga, Gb)
    b, S = PN.simulate_error(C, X, 1.0, P, 1e-9, 1e-9, systematic=basis,
                             rng=np.random.default_rng(1))
    expected = U.pose_bias_covariance(X, Ga @ Ga.T, Gb @ Gb.T)
    ratio = np.sqrt(np.diag(S) / np.diag(expected))
    assert np.all((ratio > 0.85) & (ratio < 1.15)), ratio
    assert np.all(np.abs(b) < 3 * np.sqrt(np.diag(expected) / PN.N_SIM) + 1e-12)


def test_shared_parameters_are_drawn_once_for_both_cameras():
    """Both cameras off by the same constant error through the same parameters, X = I:
    X' = N^-1 X N = I, no error at all; drawn independently it would be ~1e-3."""
    X = np.eye(4)
    Pa = _path()
    C, _, P = _motions(Pa, Pa)
    G = np.random.default_rng(2).normal(size=(6, 6)) * 1e-3
    B = np.broadcast_to(G, (Pa.shape[0], 6, 6)).copy()
    _, S = PN.simulate_error(C, X, 1.0, P, 1e-9, 1e-9, systematic=(B, B))
    assert np.sqrt(np.diag(S)).max() < 1e-7


def test_systematic_simulation_matches_direct_solves():
    """Drifting shared errors: the simulated covariance against dqopt solved on data drawn
    from the same errors (independent generator)."""
    rng = np.random.default_rng(3)
    X = _X()
    Pa = _path()
    Pb = Pa @ X
    Ba, Bb = _drifting_basis(Pa.shape[0], rng)
    C, H, P = _motions(Pa, Pb)
    _, S = PN.simulate_error(C, X, 1.0, P, 1e-9, 1e-9, systematic=(Ba, Bb))
    errs = []
    for _ in range(150):
        eta = rng.standard_normal(Ba.shape[2])
        Ca, Hb, _ = _motions(Pa @ _exp6(Ba @ eta), Pb @ _exp6(Bb @ eta))
        errs.append(-pose_error_of(simcalib.solve(Ca, Hb, alpha=1.0).X, X))
    emp = np.sqrt(np.mean(np.array(errs) ** 2, axis=0))
    ratio = np.sqrt(np.diag(S)) / emp
    assert np.all((ratio > 0.75) & (ratio < 1.33)), ratio


def pose_error_of(X_est, X):
    return U.pose_error(X, X_est)


def test_residual_power_of_the_systematic_part():
    """The expected residual share of the systematic errors: zero for run-constant errors
    (invisible in the residuals), positive for drifting ones, and the same as the measured
    residual power of data drawn from them."""
    rng = np.random.default_rng(4)
    X = _X()
    Pa = _path()
    Pb = Pa @ X
    C, H, P = _motions(Pa, Pb)
    const = _constant_basis(Pa.shape[0], rng.normal(size=(6, 6)) * 1e-3,
                            rng.normal(size=(6, 6)) * 1e-3)
    r2, t2 = PN.systematic_residual_power(C, X, 1.0, P, const)
    assert r2 < 1e-12 and t2 < 1e-12
    Ba, Bb = _drifting_basis(Pa.shape[0], rng)
    r2, t2 = PN.systematic_residual_power(C, X, 1.0, P, (Ba, Bb), n_draws=64)
    meas = []
    for _ in range(64):
        eta = rng.standard_normal(Ba.shape[2])
        Ca, Hb, _ = _motions(Pa @ _exp6(Ba @ eta), Pb @ _exp6(Bb @ eta))
        e = U.linear_model(Ca, Hb, simcalib.solve(Ca, Hb, alpha=1.0).X)[0]
        meas.append((np.mean(np.sum(e[:, :3] ** 2, 1)), np.mean(np.sum(e[:, 3:] ** 2, 1))))
    m = np.mean(meas, axis=0)
    assert r2 == pytest.approx(m[0], rel=0.3) and t2 == pytest.approx(m[1], rel=0.3)


def test_covariance_and_solve_with_a_pose_error_basis():
    rng = np.random.default_rng(5)
    X = _X()
    Pa = _path()
    Pb = Pa @ X
    Ba, Bb = _drifting_basis(Pa.shape[0], rng)
    eta = rng.standard_normal(Ba.shape[2])
    white = [_exp6(np.concatenate([rng.normal(0, 2e-4, (Pa.shape[0], 3)),
                                   rng.normal(0, 2e-4, (Pa.shape[0], 3))], 1))
             for _ in range(2)]
    C, H, P = _motions(Pa @ _exp6(Ba @ eta) @ white[0], Pb @ _exp6(Bb @ eta) @ white[1])
    plain = simcalib.solve(C, H, alpha=1.0, pose_pairs=P)
    sol = simcalib.solve(C, H, alpha=1.0, pose_pairs=P, pose_error_basis=(Ba, Bb))
    u = sol.uncertainty
    assert u.method == "pose_simulation" and u.systematic_parameters == Ba.shape[2]
    # the white noise is what the residuals leave beyond the systematic share: far below
    # the level fitted to all of the residuals
    assert u.white_pose_noise[0] < plain.uncertainty.noise.sigma_r_rad / np.sqrt(2)
    assert np.all(np.isfinite(u.covariance)) and u.dof == 6
    assert plain.uncertainty.systematic_parameters == 0
    with pytest.raises(ValueError, match="needs pose_pairs"):
        simcalib.solve(C, H, alpha=1.0, pose_error_basis=(Ba, Bb))
    with pytest.raises(ValueError, match="needs pose_pairs"):
        U.covariance(C, H, sol.X, 1.0, pose_error_basis=(Ba, Bb))
    with pytest.raises(ValueError, match=r"n_pose >= 100"):
        simcalib.solve(C, H, alpha=1.0, pose_pairs=P, pose_error_basis=(Ba[:50], Bb[:50]))
    # with a prior the simulation (which does not model the prior's cost) is not used
    pri = simcalib.Prior(X=sol.X, a=1e-4, b=1e-2)
    assert simcalib.solve(C, H, alpha=1.0, prior=pri, pose_pairs=P,
                          pose_error_basis=(Ba, Bb)).uncertainty.method == "sandwich"


def test_a_simulation_is_reused_for_another_estimate_of_the_same_motions():
    rng = np.random.default_rng(6)
    X = _X()
    Pa = _path()
    Ba, Bb = _drifting_basis(Pa.shape[0], rng)
    eta = rng.standard_normal(Ba.shape[2])
    C, H, P = _motions(Pa @ _exp6(Ba @ eta), Pa @ X @ _exp6(Bb @ eta))
    first = simcalib.solve(C, H, alpha=1.0, pose_pairs=P, pose_error_basis=(Ba, Bb))
    sim = first.uncertainty.simulation
    assert isinstance(sim, PN.SimulatedError) and sim.alpha == 1.0
    other = simcalib.solve(C, H, method="daniilidis", alpha=1.0, pose_pairs=P,
                           pose_error_basis=(Ba, Bb), pose_simulation=sim)
    u = other.uncertainty
    assert u.simulation is sim and u.method == "pose_simulation"
    np.testing.assert_array_equal(u.simulated_bias, sim.bias)
    # its own offset from the minimiser is still added: not tighter than the minimiser's
    assert np.all(np.diag(u.covariance) >= np.diag(first.uncertainty.covariance) * 0.999)
    with pytest.raises(ValueError, match="simulated at alpha = 1"):
        U.covariance(C, H, other.X, 2.0, pose_pairs=P, pose_simulation=sim)
    with pytest.raises(ValueError, match="needs pose_pairs"):
        U.covariance(C, H, other.X, 1.0, pose_simulation=sim)
    with pytest.raises(TypeError, match="SimulatedError"):
        U.covariance(C, H, other.X, 1.0, pose_pairs=P, pose_error_basis=(Ba, Bb),
                     pose_simulation=(1, 2))


def test_solve_checks_a_reused_simulation():
    C, H, P = _motions(_path(30), _path(30) @ _X())
    with pytest.raises(TypeError, match="SimulatedError"):
        simcalib.solve(C, H, pose_pairs=P, pose_simulation="sim")
    sim = PN.SimulatedError(np.zeros(6), np.eye(6) * 1e-8, 1.0, (1e-3, 1e-3))
    with pytest.raises(ValueError, match="needs pose_pairs"):
        simcalib.solve(C, H, pose_simulation=sim)
    # a simulation at another alpha is refused by solve itself (the uncertainty property
    # would otherwise turn the error into a silent None)
    with pytest.raises(ValueError, match="simulated at alpha = 1"):
        simcalib.solve(C, H, alpha=2.0, pose_pairs=P, pose_simulation=sim)
