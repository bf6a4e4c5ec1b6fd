import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simcalib import geometry as g


def _random_T(rng, n):
    return g.transform_from_rotation_translation(g.random_rotation_matrices(rng, n),
                                                 rng.standard_normal((n, 3)))


def test_quat_matches_scipy_up_to_sign(rng):
    R = g.random_rotation_matrices(rng, 500)
    q = g.quat_from_matrix(R)
    q_scipy = Rotation.from_matrix(R).as_quat()  # (x, y, z, w)
    dots = np.abs(np.sum(q * q_scipy, axis=-1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-12)
    np.testing.assert_allclose(g.matrix_from_quat(q), R, atol=1e-12)


def test_left_right_matrices_match_hamilton_product(rng):
    q = rng.standard_normal((100, 4))
    p = rng.standard_normal((100, 4))
    lhs = np.einsum("nij,nj->ni", g.quat_left_matrix(q), p)
    rhs = np.einsum("nij,nj->ni", g.quat_right_matrix(p), q)
    np.testing.assert_allclose(lhs, rhs, atol=1e-12)
    qn = q / np.linalg.norm(q, axis=1, keepdims=True)
    pn = p / np.linalg.norm(p, axis=1, keepdims=True)
    expected = (Rotation.from_quat(qn) * Rotation.from_quat(pn)).as_matrix()
    np.testing.assert_allclose(g.matrix_from_quat(g.quat_multiply(qn, pn)), expected, atol=1e-12)


def test_dual_quaternion_round_trip_and_composition(rng):
    T1, T2 = _random_T(rng, 50), _random_T(rng, 50)
    q, qd = g.dual_quat_from_transform(T1)
    np.testing.assert_allclose(np.sum(q * qd, axis=-1), 0.0, atol=1e-12)
    np.testing.assert_allclose(g.transform_from_dual_quat(q, qd), T1, atol=1e-12)
    # (q1 + eps q1')(q2 + eps q2') = q1 q2 + eps (q1 q2' + q1' q2)
    q2, qd2 = g.dual_quat_from_transform(T2)
    qp = g.quat_multiply(q, q2)
    qdp = g.quat_multiply(q, qd2) + g.quat_multiply(qd, q2)
    np.testing.assert_allclose(g.transform_from_dual_quat(qp, qdp), T1 @ T2, atol=1e-12)


def test_relative_motions_satisfy_hand_eye_equation(rng):
    T_w_a = _random_T(rng, 20)
    X = _random_T(rng, 1)[0]                       # T_a_b
    T_v_w = _random_T(rng, 1)[0]                   # b lives in another world frame
    T_v_b = T_v_w @ T_w_a @ X
    i, j = np.arange(19), np.arange(1, 20)
    C, H = g.relative_motions(T_w_a, T_v_b, i, j)
    np.testing.assert_allclose(C @ X, X @ H, atol=1e-12)


def test_errors_and_rotvec(rng):
    rv = rng.standard_normal((200, 3))
    R = g.matrix_from_rotvec(rv)
    np.testing.assert_allclose(R, Rotation.from_rotvec(rv).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(g.rotvec_from_matrix(R), Rotation.from_rotvec(rv).as_rotvec(),
                               atol=1e-10)
    T = _random_T(rng, 200)
    Tp = T @ g.transform_from_rotation_translation(g.matrix_from_rotvec(np.array([0, 0, 1e-9])),
                                                   np.zeros(3))
    np.testing.assert_allclose(g.rotation_error_rad(Tp, T), 1e-9, rtol=1e-6)
    np.testing.assert_allclose(g.translation_error_m(T, T), 0.0)


def test_perturbation_statistics(rng):
    T = np.broadcast_to(np.eye(4), (20000, 4, 4))
    P = g.perturb_transforms(T, np.deg2rad(1.0), 0.01, rng)
    ang = g.rotation_angle_rad(P)
    # |N(0, s^2)| has mean s*sqrt(2/pi)
    assert abs(ang.mean() / (np.deg2rad(1.0) * np.sqrt(2 / np.pi)) - 1) < 0.03
    assert abs(P[:, :3, 3].std() / 0.01 - 1) < 0.03


@pytest.mark.parametrize("bad, match", [
    (np.zeros((3, 4, 3)), r"shape \(\.\.\., 4, 4\); received shape \(3, 4, 3\)"),
    (np.full((2, 4, 4), np.nan), "NaN or inf"),
    (np.tile(np.diag([2.0, 1, 1, 1]), (2, 1, 1)), "not a rotation"),
    (np.tile(np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]), (2, 1, 1)),
     "bottom row"),
])
def test_check_transforms_rejects_bad_input(bad, match):
    with pytest.raises(ValueError, match=match):
        g.check_transforms(bad, "C")


@pytest.mark.parametrize("bad, match", [
    (np.where(np.eye(4) == 1, np.nan, 0.0), r"^X contains NaN or inf; all entries"),
    (np.diag([2.0, 1, 1, 1]), r"^X rotation block is not a rotation: "),
    (np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]),
     r"^X has bottom row \[0.0, 0.0, 1.0, 1.0\]"),
])
def test_check_transforms_single_transform_names_no_index(bad, match):
    """A single 4x4 is named as itself (no "index ()" / "[()]" in the message)."""
    with pytest.raises(ValueError, match=match):
        g.check_transforms(bad, "X")


def test_check_transforms_min_count():
    with pytest.raises(ValueError, match="at least 2"):
        g.check_transforms(np.eye(4)[None], "C", min_count=2)


def test_distort_pixels_is_opencvs_lens_model_and_undistort_inverts_it():
    cv2 = pytest.importorskip("cv2")
    from simcalib.sources.vision.camera_effects import PRESETS
    from simcalib.targets.marker_pnp import undistort_points
    K = np.array([[500.0, 0.0, 319.5], [0.0, 510.0, 239.5], [0.0, 0.0, 1.0]])
    dist = PRESETS["realistic"].distortion
    uv = np.random.default_rng(0).uniform([0, 0], [640, 480], (40, 2))
    ud, one_to_one = g.distort_pixels(uv, K, dist)
    xy1 = np.concatenate([(uv - K[:2, 2]) / [K[0, 0], K[1, 1]], np.ones((40, 1))], axis=1)
    ref, _ = cv2.projectPoints(xy1, np.zeros(3), np.zeros(3), K, np.asarray(dist))
    np.testing.assert_allclose(ud, ref[:, 0], atol=1e-9)
    np.testing.assert_allclose(undistort_points(ud, K, dist), uv, atol=1e-7)
    assert one_to_one.all()
    # far outside the field of view a barrel model (here the harsh lens) folds back:
    # flagged, not trusted
    _, ok = g.distort_pixels(np.array([[319.5 + 100.0, 239.5], [319.5 + 2500.0, 239.5]]), K,
                             PRESETS["harsh"].distortion)
    assert ok.tolist() == [True, False]
    np.testing.assert_allclose(g.distort_pixels(uv, K, (0, 0, 0, 0, 0))[0], uv)
    with pytest.raises(ValueError, match="5 finite numbers"):
        g.distort_pixels(uv, K, (0.1, 0.2))


def test_matrix_from_euler_zyx_is_z_then_new_y_then_newest_x():
    from scipy.spatial.transform import Rotation
    from simcalib.geometry import matrix_from_euler_zyx
    angles = np.random.default_rng(0).uniform(-3.0, 3.0, (2, 5, 3))
    want = Rotation.from_euler("ZYX", angles.reshape(-1, 3)).as_matrix().reshape(2, 5, 3, 3)
    assert np.allclose(matrix_from_euler_zyx(angles), want, atol=1e-14)
    assert np.allclose(matrix_from_euler_zyx([0.3, 0.0, 0.0]),
                       Rotation.from_rotvec([0, 0, 0.3]).as_matrix(), atol=1e-15)


def _quat_all_branches(R):
    """The formula quat_from_matrix had: all four branches for every element, one picked."""
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    diag = np.stack([1 + m00 - m11 - m22, 1 - m00 + m11 - m22,
                     1 - m00 - m11 + m22, 1 + m00 + m11 + m22], axis=-1)
    k = np.argmax(diag, axis=-1)
    s = 2.0 * np.sqrt(np.maximum(np.take_along_axis(diag, k[..., None], -1)[..., 0], 1e-300))
    d21, d02, d10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], \
        R[..., 1, 0] - R[..., 0, 1]
    s01, s02, s12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], \
        R[..., 1, 2] + R[..., 2, 1]
    cand = np.stack([np.stack([0.25 * s, s01 / s, s02 / s, d21 / s], -1),
                     np.stack([s01 / s, 0.25 * s, s12 / s, d02 / s], -1),
                     np.stack([s02 / s, s12 / s, 0.25 * s, d10 / s], -1),
                     np.stack([d21 / s, d02 / s, d10 / s, 0.25 * s], -1)], axis=-2)
    q = np.take_along_axis(cand, k[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0, -q, q)


def test_quat_from_matrix_is_the_all_branches_formula_to_the_bit(rng):
    R = g.random_rotation_matrices(rng, 20000)
    cases = [R, R + 1e-3 * rng.standard_normal(R.shape), rng.standard_normal((2000, 3, 3)),
             np.rint(rng.standard_normal((2000, 3, 3)) * 2) / 2,      # ties of the branches
             Rotation.from_rotvec(np.pi * g.random_rotation_matrices(rng, 50)[:, 0]).as_matrix(),
             np.eye(3), np.zeros((3, 3)), np.diag([1.0, -1, -1]), np.diag([-1.0, -1, 1]),
             R[:0], R[:600].reshape(20, 30, 3, 3)[:, ::2], np.swapaxes(R[:300], -1, -2),
             np.full((2, 3, 3), np.nan), _random_T(rng, 30)]         # 4x4: the 3x3 block
    with np.errstate(invalid="ignore", divide="ignore"):
        for M in cases:
            got, want = g.quat_from_matrix(M), _quat_all_branches(np.asarray(M, float))
            assert got.shape == want.shape and got.dtype == want.dtype
            assert got.tobytes() == want.tobytes()

