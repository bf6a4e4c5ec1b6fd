"""Calibration (run-constant camera pose) bias as a known input of the covariance (issue 9):
propagation to the error of X, the sandwich / verdict terms, input checks, and the ArUco
calibration sensitivity the pipeline derives it from."""

from types import SimpleNamespace

import numpy as np
import pytest

from simcalib import geometry as g
from simcalib.solvers.api import Prior, solve
from simcalib.solvers.diagnostics import uncertainty as U


def _exp6(x):
    T = np.eye(4)
    T[:3, :3] = g.matrix_from_rotvec(x[:3])
    T[:3, 3] = x[3:]
    return T


def _problem(n=40, seed=0, sr=0.01, st=0.002):
    rng = np.random.default_rng(seed)
    X = _exp6(np.r_[rng.normal(size=3), 0.3 * rng.normal(size=3)])
    C = np.stack([_exp6(np.r_[rng.normal(size=3), 0.5 * rng.normal(size=3)]) for _ in range(n)])
    H = g.invert_transform(X) @ C @ X
    Cn = C @ np.stack([_exp6(np.r_[sr * rng.normal(size=3), st * rng.normal(size=3)])
                       for _ in range(n)])
    Hn = H @ np.stack([_exp6(np.r_[sr * rng.normal(size=3), st * rng.normal(size=3)])
                       for _ in range(n)])
    return Cn, Hn, X


def _random_psd(rng, scale=1e-4):
    A = scale * rng.normal(size=(6, 6))
    return A @ A.T


def test_jacobians_match_finite_differences():
    rng = np.random.default_rng(3)
    X = _exp6(np.r_[rng.normal(size=3), 0.5 * rng.normal(size=3)])
    Ja, Jb = U.pose_bias_jacobians(X)
    h = 1e-6
    for k in range(6):
        n = np.zeros(6)
        n[k] = h
        da = (U.pose_error(X, g.invert_transform(_exp6(n)) @ X)
              - U.pose_error(X, g.invert_transform(_exp6(-n)) @ X)) / (2 * h)
        db = (U.pose_error(X, X @ _exp6(n)) - U.pose_error(X, X @ _exp6(-n))) / (2 * h)
        np.testing.assert_allclose(da, Ja[:, k], atol=1e-8)
        np.testing.assert_allclose(db, Jb[:, k], atol=1e-8)


def test_covariance_propagation_matches_sampled_biases():
    rng = np.random.default_rng(4)
    X = _exp6(np.r_[rng.normal(size=3), 0.5 * rng.normal(size=3)])
    Pa, Pb = _random_psd(rng, 1e-3), _random_psd(rng, 1e-3)
    na = rng.multivariate_normal(np.zeros(6), Pa, size=4000)
    nb = rng.multivariate_normal(np.zeros(6), Pb, size=4000)
    Xp = np.stack([g.invert_transform(_exp6(a)) @ X @ _exp6(b) for a, b in zip(na, nb)])
    d = U.pose_error(np.broadcast_to(X, Xp.shape), Xp)
    emp = d.T @ d / d.shape[0]
    S = U.pose_bias_covariance(X, Pa, Pb)
    np.testing.assert_allclose(np.sqrt(np.diag(emp)), np.sqrt(np.diag(S)), rtol=0.05)


def test_noise_free_solver_converges_to_the_biased_X():
    """The full chain: constant pose errors N_a, N_b on noise-free poses -> dqopt finds
    X' = N_a^-1 X N_b, whose error is Ja n_a + Jb n_b to first order."""
    rng = np.random.default_rng(5)
    X = _exp6(np.r_[rng.normal(size=3), 0.3 * rng.normal(size=3)])
    Ta = np.stack([_exp6(np.r_[rng.normal(size=3), rng.normal(size=3)]) for _ in range(30)])
    Tb = Ta @ X
    na, nb = 1e-4 * rng.normal(size=6), 1e-4 * rng.normal(size=6)
    Ma, Mb = Ta @ _exp6(na), Tb @ _exp6(nb)
    C = g.invert_transform(Ma[:-1]) @ Ma[1:]
    H = g.invert_transform(Mb[:-1]) @ Mb[1:]
    sol = solve(C, H, method="dqopt", alpha=1.0)
    Ja, Jb = U.pose_bias_jacobians(X)
    np.testing.assert_allclose(U.pose_error(X, sol.X), Ja @ na + Jb @ nb, atol=1e-7)


def test_bias_adds_exactly_to_the_covariance_and_zero_bias_is_identity():
    C, H, X = _problem()
    X_est = solve(C, H, method="dqopt", alpha=1.0).X
    u0 = U.covariance(C, H, X_est, 1.0)
    for zero in (None, (None, None), (np.zeros((6, 6)), None), U.PoseBias()):
        uz = U.covariance(C, H, X_est, 1.0, pose_bias=zero)
        np.testing.assert_array_equal(uz.covariance, u0.covariance)
        np.testing.assert_array_equal(uz.information, u0.information)
        assert uz.bias_covariance is None and uz.verdict == u0.verdict
    rng = np.random.default_rng(6)
    Pa, Pb = _random_psd(rng), _random_psd(rng)
    u = U.covariance(C, H, X_est, 1.0, pose_bias=(Pa, Pb))
    S = U.pose_bias_covariance(X_est, Pa, Pb)
    np.testing.assert_allclose(u.bias_covariance, S)
    np.testing.assert_allclose(u.covariance, u0.covariance + S, rtol=1e-7,
                               atol=1e-12 * np.abs(S).max())
    # the verdict's information is that of the total covariance
    F_tot = np.linalg.inv(np.linalg.inv(u0.information) + S)
    np.testing.assert_allclose(u.information, F_tot, rtol=1e-6, atol=1e-9 * np.abs(F_tot).max())
    # the same through solve / Solution, and added to the bootstrap covariance
    sol = solve(C, H, method="dqopt", alpha=1.0, pose_bias=U.PoseBias(Pa, Pb))
    np.testing.assert_allclose(sol.covariance, u.covariance, rtol=1e-9, atol=1e-15)
    assert np.all(sol.std >= solve(C, H, method="dqopt", alpha=1.0).std)
    sb = solve(C, H, method="dqopt", alpha=1.0, uncertainty="bootstrap", bootstrap_samples=20,
               pose_bias=(Pa, Pb))
    sb0 = solve(C, H, method="dqopt", alpha=1.0, uncertainty="bootstrap", bootstrap_samples=20)
    np.testing.assert_allclose(sb.covariance, sb0.covariance + u.bias_covariance, rtol=1e-9)


def test_large_bias_makes_the_verdict_poorly_determined():
    C, H, X = _problem()
    X_est = solve(C, H, method="dqopt", alpha=1.0).X
    assert U.covariance(C, H, X_est, 1.0).verdict == "determined"
    P = np.diag([1e-6] * 3 + [0.03 ** 2] * 3)      # 3 cm of run-constant camera error
    u = U.covariance(C, H, X_est, 1.0, pose_bias=(P, None))
    assert u.verdict == "poorly determined"
    assert all(d.kind == "translation" for d in u.directions)


def test_prior_holds_back_the_bias():
    C, H, X = _problem()
    P = np.diag([1e-6] * 3 + [1e-4] * 3)
    free = U.covariance(C, H, X, 1.0, pose_bias=(P, P))
    held = U.covariance(C, H, X, 1.0, prior=Prior(X, 1e6, 1e6), pose_bias=(P, P))
    assert np.all(np.diag(held.covariance) < 0.1 * np.diag(free.covariance))


def test_singular_information_stays_undetermined():
    rng = np.random.default_rng(8)
    F = np.diag([1e6, 1e6, 1e6, 1e4, 1e4, 0.0])
    S = _random_psd(rng, 1e-2)
    Fe = U._woodbury_information(F, S)
    assert abs(Fe[5, 5]) < 1e-12 and np.abs(Fe[5]).max() < 1e-9
    B = np.linalg.inv(np.linalg.inv(F[:5, :5]) + S[:5, :5])
    np.testing.assert_allclose(Fe[:5, :5], B, rtol=1e-6)


@pytest.mark.parametrize("bad, err, match", [
    (np.eye(5), ValueError, "6x6"),
    (np.full((6, 6), np.nan), ValueError, "finite"),
    (np.triu(np.ones((6, 6))), ValueError, "symmetric"),
    (-np.eye(6), ValueError, "positive semi-definite"),
    (np.diag([1.0, 1, 1, 1, 1, -0.1]), ValueError, "positive semi-definite"),
    ("abc", ValueError, "6x6|could not|must be"),
])
def test_pose_bias_input_errors(bad, err, match):
    with pytest.raises((ValueError, TypeError), match=match):
        U.PoseBias(bad, None)
    C, H, X = _problem(n=10)
    with pytest.raises((ValueError, TypeError), match=match):
        U.covariance(C, H, X, 1.0, pose_bias=(None, bad))


def test_pose_bias_type_errors():
    C, H, X = _problem(n=10)
    with pytest.raises(TypeError, match="pose_bias must be a PoseBias"):
        U.covariance(C, H, X, 1.0, pose_bias=np.eye(6))
    with pytest.raises(TypeError, match="pose_bias must be a PoseBias"):
        solve(C, H, pose_bias="none")


# ------------------------------------------------------------- ArUco calibration sensitivity
def _wall_world(n_frames=6):
    """No rendering: a 3x4 wall of 10 cm markers at z=0 seen by two cameras ~1 m above."""
    from simcalib.targets.markers import MarkerField
    from simcalib.streams import CameraFrames, CameraIntrinsics, Trajectory
    Ts = []
    for i in range(3):
        for j in range(4):
            T = np.eye(4)
            T[:3, 3] = [0.3 * (j - 1.5), 0.3 * (i - 1), 0.0]
            Ts.append(T)
    field = MarkerField("DICT_4X4_250", np.arange(12), 0.1, np.stack(Ts))
    t = np.arange(n_frames) / 10.0
    down = np.diag([1.0, -1.0, -1.0])                        # camera z towards the wall
    X = _exp6(np.r_[0.0, 0.1, 0.0, 0.1, 0.0, 0.0])
    Ta = np.stack([g.transform_from_rotation_translation(
        down @ g.matrix_from_rotvec([0.1 * np.sin(k), 0.1 * np.cos(k), 0.2 * k]),
        [0.1 * np.sin(k), 0.1 * np.cos(k), 1.0]) for k in range(n_frames)])
    fr = {c: CameraFrames(c, t.copy(), T, np.zeros((n_frames, 0)), np.zeros((n_frames, 1, 3)),
                          np.tile([1.0, 0, 0, 0], (n_frames, 1, 1)))
          for c, T in (("cam_a", Ta), ("cam_b", Ta @ X))}
    return SimpleNamespace(camera_names=("cam_a", "cam_b"),
                           intrinsics={c: CameraIntrinsics.from_fovy(640, 480, 60.0)
                                       for c in fr},
                           marker_field=field,
                           trajectory=Trajectory(fr["cam_a"], fr["cam_b"], X))


def test_intrinsics_sensitivity_matches_pinhole_geometry():
    from simcalib.targets.pnp_sensitivity import intrinsics_pose_sensitivity
    w = _wall_world(1)
    intr = w.intrinsics["cam_a"]
    T = w.trajectory.cam_a.T_world_cam
    pts = [w.marker_field.corners_world().reshape(-1, 3)]
    sig = np.array([1e-3, 1.0, 0.0, 0, 0, 0, 0, 0])
    J = intrinsics_pose_sensitivity(pts, T, intr.K, np.zeros(5), sig)
    assert np.all(J[:, 2:] == 0)
    depth = float(np.mean((g.invert_transform(T[0])[:3, :3] @ pts[0].T)[2]
                          + g.invert_transform(T[0])[2, 3]))
    # focal +0.1 %: the camera seems 0.1 % further from the wall (along its optical axis)
    assert J[5, 0] == pytest.approx(-1e-3 * depth, rel=0.15)
    # principal point +1 px in x, flat wall seen head-on: the image shifts by 1 px, which
    # PnP explains by moving the camera depth / f along its x (a rotation would foreshorten)
    assert abs(J[3, 1]) == pytest.approx(depth / intr.fx, rel=0.2)
    assert abs(J[1, 1]) < 0.1 / intr.fx
    # linear: a step of half a sigma moves the pose half as much
    J2 = intrinsics_pose_sensitivity(pts, T, intr.K, np.zeros(5), sig / 2)
    np.testing.assert_allclose(J2, J / 2, rtol=1e-3, atol=1e-9)


def _state(preset, sources=("aruco", "aruco"), **vision):
    from simcalib.sources.base import GroundTruth
    from simcalib.sources.vision.config import VisionConfig
    w = _wall_world()
    truth = GroundTruth(kind="sim", X_true=w.trajectory.T_a_b if hasattr(w.trajectory, "T_a_b")
                        else np.eye(4), streams={}, world=w, marker_field=w.marker_field)
    return SimpleNamespace(cfg=SimpleNamespace(vision=VisionConfig(preset=preset, **vision)),
                           truth=truth, camera_sources=dict(zip(("cam_a", "cam_b"), sources)))


def test_pipeline_sets_the_calibration_term_for_aruco_with_realistic_only():
    from simcalib.pipeline.uncertainty_inputs import calibration_bias
    pb, rep = calibration_bias(_state("realistic"))
    assert isinstance(pb, U.PoseBias) and rep["included"]
    assert set(rep["cameras"]) == {"cam_a", "cam_b"}
    for cam, cov in (("cam_a", pb.cov_a), ("cam_b", pb.cov_b)):
        s = rep["cameras"][cam]
        assert 0 < max(s["std_deg"]) < 1 and 0 < max(s["std_m"]) < 0.05
        np.testing.assert_allclose(np.asarray(s["covariance"]), cov)
    for st in (_state("ideal"), _state("realistic", ("noisy", "noisy")),
               _state("realistic", intrinsics_error=(0.0, 0.0, 0.0), map_position_std_m=0.0,
                      map_rotation_std_deg=0.0)):
        pb, rep = calibration_bias(st)
        assert pb is None and rep["included"] is False and rep["cameras"] == {}
    # the marker map's survey error alone is a term too
    pb, rep = calibration_bias(_state("realistic", intrinsics_error=(0.0, 0.0, 0.0)))
    assert rep["included"] and np.any(pb.cov_a) and np.any(pb.cov_b)
    assert all(max(rep["cameras"][c]["map_std_m"]) > 0 for c in ("cam_a", "cam_b"))
    # one ArUco stream: only that camera has a calibration term
    pb, rep = calibration_bias(_state("realistic", ("robot_fk", "aruco")))
    assert not np.any(pb.cov_a) and np.any(pb.cov_b) and set(rep["cameras"]) == {"cam_b"}
    # larger intrinsics error, larger term (harsh)
    big, _ = calibration_bias(_state("harsh"))
    small, _ = calibration_bias(_state("realistic"))
    assert np.trace(big.cov_a) > np.trace(small.cov_a)


def test_coverage_tool_row_with_the_calibration_term():
    from simcalib.studies.experiments.coverage import scenario_coverage
    P = np.diag([1e-8] * 3 + [1e-6] * 3)
    data = [(*_problem(n=20, seed=s)[:2], _problem(n=20, seed=s)[2], 0, None, U.PoseBias(P, P))
            for s in range(3)]
    r0 = scenario_coverage("x", data)
    r1 = scenario_coverage("x", data, calibration=True)
    assert r0["solved"] == r1["solved"] == 3
    assert np.all(r1["pred"] > r0["pred"]) and np.allclose(r1["rms"], r0["rms"])


def test_map_error_covariance_matches_pnp_monte_carlo():
    """The first-order map-error covariance against PnP on perturbed maps (cv2, no render)."""
    import cv2

    from simcalib.geometry import perturb_transforms, rotvec_from_matrix
    from simcalib.targets.markers import MarkerField
    from simcalib.targets.pnp_sensitivity import map_pose_covariance
    w = _wall_world(3)
    field = w.marker_field
    intr = w.intrinsics["cam_a"]
    T = np.asarray(w.trajectory.cam_a.T_world_cam)
    vis = np.ones((T.shape[0], field.T_world_marker.shape[0]), dtype=bool)
    pos_std, rot_std = 0.002, np.radians(0.5)
    S = map_pose_covariance(field, vis, T, intr.K, pos_std, rot_std)
    rng = np.random.default_rng(0)
    true_pts = field.corners_world().reshape(-1, 3)
    xis = []
    for _ in range(300):
        Tm = perturb_transforms(field.T_world_marker, rot_std, pos_std, rng)
        believed = MarkerField(field.dictionary, field.ids, field.side_m, Tm)
        P = believed.corners_world().reshape(-1, 3)
        xi = np.zeros(6)
        for f in range(T.shape[0]):
            T_cw = np.linalg.inv(T[f])
            rv, _ = cv2.Rodrigues(T_cw[:3, :3])
            uv, _ = cv2.projectPoints(true_pts, rv, T_cw[:3, 3], intr.K, np.zeros(5))
            ok, r2, t2 = cv2.solvePnP(P, uv, intr.K, np.zeros(5), rv.copy(),
                                      T_cw[:3, 3].reshape(3, 1).copy(), True,
                                      cv2.SOLVEPNP_ITERATIVE)
            R2, _ = cv2.Rodrigues(r2)
            T_est = np.linalg.inv(np.block([[R2, t2.reshape(3, 1)], [np.zeros((1, 3)), 1]]))
            E = np.linalg.inv(T[f]) @ T_est
            xi += np.r_[rotvec_from_matrix(E[:3, :3]), E[:3, 3]]
        xis.append(xi / T.shape[0])
    emp = np.cov(np.array(xis).T)
    ratio = np.sqrt(np.diag(S) / np.diag(emp))
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


def test_map_error_covariance_checks_inputs():
    from simcalib.targets.pnp_sensitivity import map_pose_covariance
    w = _wall_world(2)
    T = np.asarray(w.trajectory.cam_a.T_world_cam)
    K = w.intrinsics["cam_a"].K
    with pytest.raises(ValueError, match="visible must be"):
        map_pose_covariance(w.marker_field, np.ones((2, 3), bool), T, K, 0.001, 0.001)
    with pytest.raises(ValueError, match="position_std_m"):
        map_pose_covariance(w.marker_field, np.ones((2, 12), bool), T, K, -1.0, 0.001)
    assert not map_pose_covariance(w.marker_field, np.ones((2, 12), bool), T, K, 0, 0).any()


# ------------------------------------------- per-pose sensitivities (systematic pose errors)
def _pnp_pose_error(T_true, K, dist_true, pts_true, pts_believed, K_est, dist_est):
    """Exact: the pose PnP gives from the true projections (true lens) of ``pts_true``,
    undistorted with the believed calibration, against the believed points."""
    import cv2

    from simcalib.targets.marker_pnp import undistort_points
    T_cw = np.linalg.inv(T_true)
    rv, _ = cv2.Rodrigues(T_cw[:3, :3])
    img, _ = cv2.projectPoints(pts_true, rv, T_cw[:3, 3], K, dist_true)
    uv = undistort_points(img.reshape(-1, 2), K_est, dist_est)
    _, r2, t2 = cv2.solvePnP(pts_believed, uv, K_est, np.zeros(5), rv.copy(),
                             T_cw[:3, 3].reshape(3, 1).copy(), True, cv2.SOLVEPNP_ITERATIVE)
    R2, _ = cv2.Rodrigues(r2)
    T_est = np.linalg.inv(np.block([[R2, t2.reshape(3, 1)], [np.zeros((1, 3)), 1]]))
    E = np.linalg.inv(T_true) @ T_est
    return np.r_[g.rotvec_from_matrix(E[:3, :3]), E[:3, 3]]


def test_map_pose_jacobians_match_exact_pnp_per_pose():
    from simcalib.targets.markers import MarkerField
    from simcalib.targets.pnp_sensitivity import map_pose_covariance, map_pose_jacobians
    w = _wall_world(4)
    field = w.marker_field
    K = w.intrinsics["cam_a"].K
    T = np.asarray(w.trajectory.cam_a.T_world_cam)
    vis = np.ones((T.shape[0], 12), dtype=bool)
    vis[1, :5] = False                                   # a pose that misses five markers
    J = map_pose_jacobians(field, vis, T, K)
    assert J.shape == (4, 12, 6, 6) and not J[1, :5].any()
    eta = np.random.default_rng(0).normal(size=(12, 6)) * np.r_[[0.004] * 3, [0.0015] * 3]
    Tm = field.T_world_marker @ _exp6s(eta)
    believed = MarkerField(field.dictionary, field.ids, field.side_m, Tm)
    for f in range(4):
        m = vis[f]
        exact = _pnp_pose_error(T[f], K, np.zeros(5), field.corners_world()[m].reshape(-1, 3),
                                believed.corners_world()[m].reshape(-1, 3), K, np.zeros(5))
        lin = np.einsum("mij,mj->i", J[f], eta)
        assert np.linalg.norm(lin - exact) < 0.03 * np.linalg.norm(exact)
    # the run-constant covariance is the frame average of the same Jacobians
    D = np.r_[[np.radians(0.5) ** 2 / 3] * 3, [0.002 ** 2] * 3]
    Jm = J.sum(0) / 4
    np.testing.assert_allclose(map_pose_covariance(field, vis, T, K, 0.002, np.radians(0.5)),
                               np.einsum("mij,j,mkj->ik", Jm, D, Jm), rtol=1e-12, atol=1e-20)


def _exp6s(x):
    return np.stack([_exp6(v) for v in x])


def test_intrinsics_pose_jacobians_match_exact_pnp_and_the_averaged_sensitivity():
    from simcalib.targets.pnp_sensitivity import (intrinsics_pose_jacobians, intrinsics_pose_sensitivity,
                                  perturbed_intrinsics)
    w = _wall_world(4)
    K = w.intrinsics["cam_a"].K
    T = np.asarray(w.trajectory.cam_a.T_world_cam)
    dist = np.array([-0.2, 0.05, 0.001, -0.001, 0.0])
    pts = [w.marker_field.corners_world().reshape(-1, 3)] * 4
    sig = np.array([5e-4, 0.35, 0.35, 0.002, 0.0005, 1e-5, 1e-5, 0.0])
    J = intrinsics_pose_jacobians(pts, T, K, dist, sig)
    assert J.shape == (4, 6, 8) and not J[:, :, 7].any()
    # per pose: the linear error of a calibration off by a random step, against exact PnP
    step = np.random.default_rng(1).normal(size=8) * sig
    K2, d2 = perturbed_intrinsics(K, dist, step)
    for f in range(4):
        exact = _pnp_pose_error(T[f], K, dist, pts[f], pts[f], K2, d2)
        lin = J[f] @ (step / np.where(sig > 0, sig, 1.0))
        assert np.linalg.norm(lin - exact) < 0.05 * np.linalg.norm(exact)
    # averaged over the poses: the PnP-based run-constant sensitivity
    np.testing.assert_allclose(J.mean(0), intrinsics_pose_sensitivity(pts, T, K, dist, sig),
                               rtol=0.05, atol=1e-3 * np.abs(J).max())
    with pytest.raises(ValueError, match="one \\(P, 3\\) array per pose"):
        intrinsics_pose_jacobians(pts[:2], T, K, dist, sig)
    with pytest.raises(ValueError, match="sigmas must be 8"):
        intrinsics_pose_jacobians(pts, T, K, dist, sig[:5])


def test_vision_pose_error_basis_and_the_pipeline_basis():
    from simcalib.pipeline.uncertainty_inputs import pose_error_basis
    from simcalib.sources.vision.config import VisionConfig
    from simcalib.sources.vision.error_model import pose_error_basis as vision_basis
    w = _wall_world(6)
    cfg = VisionConfig(preset="realistic")
    T = np.asarray(w.trajectory.cam_a.T_world_cam)
    B = vision_basis(w, "cam_a", T, cfg)
    assert B.shape == (6, 6, 6 * 12 + 8) and np.all(np.isfinite(B))
    # the basis of the map columns gives the map-error covariance (frame average)
    from simcalib.targets.pnp_sensitivity import map_pose_covariance
    from simcalib.world.layout import visible_markers
    eff = cfg.effects()
    # by default the markers fully inside the lens's distorted image
    vis = visible_markers(w.marker_field, T, w.intrinsics["cam_a"], distortion=eff.distortion)
    Bm = B[:, :, :72].mean(0)
    np.testing.assert_allclose(
        Bm @ Bm.T, map_pose_covariance(w.marker_field, vis, T, w.intrinsics["cam_a"].K,
                                       eff.map_position_std_m,
                                       np.radians(eff.map_rotation_std_deg)),
        rtol=1e-9, atol=1e-22)
    # the markers a pose rests on can be given (e.g. the PnP's ids_used)
    only = np.zeros((6, 12), dtype=bool)
    only[:, :4] = True
    B4 = vision_basis(w, "cam_a", T, cfg, visible=only)
    assert not B4[:, :, 24:72].any() and B4[:, :, :24].any()
    with pytest.raises(ValueError, match=r"visible must be \(6, 12\) booleans"):
        vision_basis(w, "cam_a", T, cfg, visible=np.ones((6, 3), bool))
    with pytest.raises(ValueError, match="T_world_cam must be"):
        vision_basis(w, "cam_a", T[0], cfg)
    # the pipeline: shared map columns, each camera's own calibration columns, unused
    # markers dropped; None without consecutive pairs or ArUco cameras
    st = _state("realistic")
    n = 6
    st.pairs = SimpleNamespace(start=np.arange(n - 2), end=np.arange(2, n),
                               frame_a=np.arange(n), frame_b=np.arange(n), C=None, H=None)
    st.cfg.pairing = SimpleNamespace(mode="consecutive", step=2)
    from simcalib.world.robot_error import RobotConfig
    st.cfg.robot = RobotConfig()       # an ideal arm: a robot_fk stream has no DH term
    st.source_logs = {}
    st.measured = {c: SimpleNamespace(frame_index=np.arange(n),
                                      T_world_cam=np.asarray(getattr(w.trajectory, c).T_world_cam))
                   for c in ("cam_a", "cam_b")}
    import simcalib.pipeline.uncertainty_inputs as P
    lag = P.correlation_lag
    try:
        P.correlation_lag = lambda s: 2
        Ba, Bb = pose_error_basis(st)
        st.camera_sources = {"cam_a": "robot_fk", "cam_b": "aruco"}
        Ba1, Bb1 = pose_error_basis(st)
        st.camera_sources = {"cam_a": "noisy", "cam_b": "noisy"}
        assert pose_error_basis(st) is None
        P.correlation_lag = lambda s: 0
        st.camera_sources = {"cam_a": "aruco", "cam_b": "aruco"}
        assert pose_error_basis(st) is None
    finally:
        P.correlation_lag = lag
    assert Ba.shape == Bb.shape and Ba.shape[:2] == (n, 6)
    ua, ub = Ba.any(axis=(0, 1)), Bb.any(axis=(0, 1))
    assert np.all(ua | ub)                       # columns no pose uses are dropped
    # per pose the same covariance as each camera's own basis, and a cross-covariance
    # between the cameras from the shared map only (each calibration is its camera's)
    Va = vision_basis(w, "cam_a", st.measured["cam_a"].T_world_cam, cfg)
    Vb = vision_basis(w, "cam_b", st.measured["cam_b"].T_world_cam, cfg)
    for B, V in ((Ba, Va), (Bb, Vb)):
        np.testing.assert_allclose(B @ np.swapaxes(B, 1, 2), V @ np.swapaxes(V, 1, 2),
                                   rtol=1e-9, atol=1e-24)
    np.testing.assert_allclose(Ba @ np.swapaxes(Bb, 1, 2),
                               Va[:, :, :72] @ np.swapaxes(Vb[:, :, :72], 1, 2),
                               rtol=1e-9, atol=1e-24)
    assert np.abs(Ba @ np.swapaxes(Bb, 1, 2)).max() > 0
    assert not Ba1.any() and Bb1.any()           # a robot_fk camera: no systematic part


@pytest.mark.slow
def test_coverage_tool_aruco_trial_records():
    """The docs command's ArUco trial (a short 3d run): the run's model simulates the
    systematic pose errors; the first-order model beside it; records aggregate to rows."""
    import os
    os.environ.setdefault("MUJOCO_GL", "egl")
    from simcalib.studies.experiments.coverage import aruco_trial, coverage_row
    t = aruco_trial(0, keep_data=True, overrides=["world.duration_s=6", "pairing.step=1"])
    assert t["run"]["simulated"]
    assert not np.allclose(t["run"]["pred"], t["first_order"]["pred"])
    assert len(t["data"]) == 7 and t["data"][6] is not None
    for key in ("run", "observable", "first_order"):
        r = t[key]
        assert np.isfinite(r["d2"]) and r["err"].shape == (6,) and np.all(r["pred"] > 0)
    row = coverage_row("x", [t["run"], None], 2)
    assert row["solved"] == 1 and row["trials"] == 2 and row["simulated"] == 1
    assert row["coverage"] in (0.0, 1.0) and np.all(row["ratio"] > 0)


def test_calibration_bias_rests_on_the_markers_the_lens_shows():
    """The run-constant calibration bias (mean over the frames) and the per-frame error basis
    rest on the same markers — those fully inside the camera's *distorted* image: with the
    camera close to the wall the barrel lens shows markers past the pinhole image's edge,
    and the two agree to first order only when both count them."""
    from simcalib.sources.vision.config import VisionConfig
    from simcalib.sources.vision.error_model import calibration_pose_bias, pose_error_basis
    from simcalib.world.layout import visible_markers
    w = _wall_world(6)
    w.trajectory.cam_a.T_world_cam[:, 2, 3] = 0.45
    T = np.asarray(w.trajectory.cam_a.T_world_cam)
    cfg = VisionConfig(preset="realistic")
    dist = cfg.effects().distortion
    intr = w.intrinsics["cam_a"]
    lens = visible_markers(w.marker_field, T, intr, distortion=dist)
    assert lens.sum() > visible_markers(w.marker_field, T, intr).sum()   # the test bites
    bias = calibration_pose_bias(w, cfg, cameras=["cam_a"], max_frames=30)["cam_a"]
    per_frame = pose_error_basis(w, "cam_a", T, cfg)[:, :, -8:]           # calibration columns
    mean = per_frame.sum(0) / int((lens.sum(1) > 0).sum())
    np.testing.assert_allclose(bias.jacobian, mean, atol=1e-4 * np.abs(mean).max())
