"""How errors of the camera calibration and of the marker map move a PnP camera pose:
first-order sensitivities, nothing rendered.

The calibration (:data:`INTRINSICS_PARAMETERS`: focal length, principal point, distortion)
and the map (each marker's surveyed pose) are constant over a run, so the pose errors they
cause are shared by its frames: :func:`intrinsics_pose_sensitivity` (re-estimated by PnP
from the true pose) and :func:`intrinsics_pose_jacobians` (per frame, linear) for the
calibration; :func:`map_pose_jacobians`, :func:`map_pose_covariance` with
:func:`map_error_variances` for the map. Pose error ``xi = (rotvec, t)`` of
``T_true^-1 T_est`` (right-multiplied, camera frame) throughout.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import invert_transform
from simcalib.targets.marker_pnp import transform_from_rvec_tvec, undistort_points
from simcalib.targets.markers import MarkerField, marker_corners_local

__all__ = ["INTRINSICS_PARAMETERS", "check_camera_poses", "intrinsics_pose_jacobians",
           "intrinsics_pose_sensitivity", "map_error_variances", "map_pose_covariance",
           "map_pose_jacobians", "perturbed_intrinsics"]

#: Parameters of :func:`intrinsics_pose_sensitivity`, in its column order: focal length
#: (relative, fx and fy together), principal point cx, cy (px), distortion k1, k2, p1, p2, k3.
INTRINSICS_PARAMETERS = ("focal_fraction", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3")


def perturbed_intrinsics(K, dist, step) -> tuple[np.ndarray, np.ndarray]:
    """``(K', dist')``: ``K``, ``dist`` moved by ``step`` (8,) in the parameters of
    :data:`INTRINSICS_PARAMETERS` (focal scaled by ``1 + step[0]``, the others added)."""
    step = np.asarray(step, dtype=np.float64)
    K2 = np.array(K, dtype=np.float64, copy=True)
    K2[0, 0] *= 1.0 + step[0]
    K2[1, 1] *= 1.0 + step[0]
    K2[0, 2] += step[1]
    K2[1, 2] += step[2]
    return K2, np.asarray(dist, dtype=np.float64) + step[3:8]


def check_camera_poses(T_world_cam, nonempty: bool = False) -> np.ndarray:
    """``(F, 4, 4)`` float camera poses of the pose-error sensitivities, or a ValueError
    naming the received shape (``nonempty``: at least one pose)."""
    T = np.asarray(T_world_cam, dtype=np.float64)
    if T.ndim != 3 or T.shape[1:] != (4, 4) or (nonempty and T.shape[0] == 0) \
            or not np.isfinite(T).all():
        raise ValueError(f"T_world_cam must be (F, 4, 4) finite poses"
                         f"{', F >= 1' if nonempty else ''}; received shape {T.shape}")
    return T


def _check_intrinsics_inputs(points_world, T_world_cam, K, dist, sigmas,
                             nonempty: bool = False) -> tuple:
    """``(T, K, dist, sigmas)`` as float arrays for the calibration sensitivities, or a
    ValueError naming what was received (``nonempty``: at least one pose)."""
    T = check_camera_poses(T_world_cam, nonempty)
    if len(points_world) != T.shape[0]:
        raise ValueError(f"points_world must hold one (P, 3) array per pose ({T.shape[0]}); "
                         f"received {len(points_world)}")
    K = np.asarray(K, dtype=np.float64)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    sig = np.asarray(sigmas, dtype=np.float64).ravel()
    if K.shape != (3, 3) or not np.isfinite(K).all() or dist.shape != (5,) \
            or not np.isfinite(dist).all():
        raise ValueError(f"K must be finite (3, 3) and dist 5 finite coefficients; received "
                         f"shapes {K.shape}, {dist.shape}")
    if sig.shape != (8,) or not np.isfinite(sig).all() or (sig < 0).any():
        raise ValueError(f"sigmas must be 8 finite numbers >= 0 "
                         f"({', '.join(INTRINSICS_PARAMETERS)}); received {sigmas!r}")
    return T, K, dist, sig


def intrinsics_pose_sensitivity(points_world, T_world_cam, K, dist, sigmas) -> np.ndarray:
    """How an error of the camera calibration moves the PnP camera poses: ``J`` (6, 8).

    ``points_world``: per frame the ``(P_f, 3)`` world points seen (marker corners, >= 4);
    ``T_world_cam``: ``(F, 4, 4)`` the camera's true poses; ``K``, ``dist`` (5,): the true
    calibration; ``sigmas`` (8,): the 1-sigma of each parameter of
    :data:`INTRINSICS_PARAMETERS` (0: skipped, column 0). The points are projected with the
    true calibration (no image is rendered), undistorted with a calibration moved by
    ``+-sigma`` of one parameter (as the pipeline undistorts with its believed calibration)
    and the pose is re-estimated (``solvePnPRefineLM`` from the true pose, pinhole ``K'``).
    Column ``j`` is the central difference ``(xi(+s_j) - xi(-s_j)) / 2`` averaged over the
    frames, ``xi = (rotvec, t)`` of ``T_true^-1 T_est`` (right-multiplied, camera frame): the
    pose error per 1-sigma of parameter ``j`` that is common to the frames (a calibration
    error is constant over a run). The pose error covariance is ``J J^T`` (independent
    parameters)."""
    import cv2  # noqa: PLC0415
    from simcalib.geometry import rotvec_from_matrix  # noqa: PLC0415
    T, K, dist, sig = _check_intrinsics_inputs(points_world, T_world_cam, K, dist, sigmas,
                                               nonempty=True)
    zero = np.zeros(5)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-14)
    J = np.zeros((6, 8))
    n_used = 0
    for f in range(T.shape[0]):
        seen = _frame_projection(cv2, points_world[f], T[f], K, dist)
        if seen is None:
            continue
        Pw, T_cw, rvec0, img = seen
        tvec0 = T_cw[:3, 3].reshape(3, 1)
        col = np.zeros((6, 8))
        for j in np.flatnonzero(sig > 0):
            xi = []
            for K2, uv in _undistorted_at_plus_minus_sigma(img, K, dist, sig, j):
                rvec, tvec = cv2.solvePnPRefineLM(Pw, uv, K2, zero, rvec0.copy(), tvec0.copy(),
                                                  criteria=crit)
                T_est = invert_transform(transform_from_rvec_tvec(rvec, tvec))
                E = invert_transform(T[f]) @ T_est
                xi.append(np.concatenate([rotvec_from_matrix(E[:3, :3]), E[:3, 3]]))
            col[:, j] = 0.5 * (xi[0] - xi[1])
        J += col
        n_used += 1
    if n_used == 0:
        raise ValueError("no pose sees 4 or more points; the calibration sensitivity is "
                         "undefined")
    return J / n_used


def _frame_projection(cv2, points_world_f, T_world_cam_f, K, dist):
    """One frame's world points ``(P, 3)``, ``T_cam_world``, its Rodrigues vector and the
    points' pixels with the calibration ``(K, dist)`` ``(P, 2)``; None below 4 points."""
    Pw = np.asarray(points_world_f, dtype=np.float64).reshape(-1, 3)
    if Pw.shape[0] < 4:
        return None
    T_cw = invert_transform(T_world_cam_f)
    rvec, _ = cv2.Rodrigues(T_cw[:3, :3])
    img, _ = cv2.projectPoints(Pw, rvec, T_cw[:3, 3].reshape(3, 1), K, dist)
    return Pw, T_cw, rvec, img.reshape(-1, 2)


def _undistorted_at_plus_minus_sigma(img, K, dist, sig, j):
    """``[(K', points)]`` for the calibration moved by ``+sigma_j`` and by ``-sigma_j``:
    the pixels ``img`` undistorted as the pipeline would with that believed calibration."""
    out = []
    for s in (1.0, -1.0):
        step = np.zeros(8)
        step[j] = s * sig[j]
        K2, d2 = perturbed_intrinsics(K, dist, step)
        out.append((K2, undistort_points(img, K2, d2)))
    return out


def _pose_from_point_jacobian(pc: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For camera-frame points ``pc`` (..., 3): ``d uv / d pc`` (..., 2, 3) of the pinhole
    pixels (``K``) and ``d pc / d xi`` (..., 3, 6) for the pose error ``xi = (rotvec, t)``
    of ``T_true^-1 T_est`` (``pc = exp(-xi) pc_true``, first order ``[p]x omega - t``)."""
    x, y, z = pc[..., 0], pc[..., 1], pc[..., 2]
    duv_dpc = np.zeros(pc.shape[:-1] + (2, 3))
    duv_dpc[..., 0, 0] = K[0, 0] / z
    duv_dpc[..., 0, 2] = -K[0, 0] * x / z ** 2
    duv_dpc[..., 1, 1] = K[1, 1] / z
    duv_dpc[..., 1, 2] = -K[1, 1] * y / z ** 2
    dpc_dxi = np.zeros(pc.shape[:-1] + (3, 6))
    dpc_dxi[..., 0, 1], dpc_dxi[..., 0, 2] = -z, y          # [p]x
    dpc_dxi[..., 1, 0], dpc_dxi[..., 1, 2] = z, -x
    dpc_dxi[..., 2, 0], dpc_dxi[..., 2, 1] = -y, x
    dpc_dxi[..., :, 3:] = -np.eye(3)
    return duv_dpc, dpc_dxi


def _check_map_inputs(field, visible, T_world_cam, K):
    T = check_camera_poses(T_world_cam)
    vis = np.asarray(visible, dtype=bool)
    M = field.T_world_marker.shape[0]
    if vis.shape != (T.shape[0], M):
        raise ValueError(f"visible must be (F, M) = ({T.shape[0]}, {M}) booleans; received "
                         f"shape {vis.shape}")
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.isfinite(K).all():
        raise ValueError(f"K must be a finite (3, 3) matrix; received shape {K.shape}")
    return T, vis, K


def map_pose_jacobians(field: MarkerField, visible: np.ndarray, T_world_cam, K) -> np.ndarray:
    """``(F, M, 6, 6)``: per frame ``f`` and marker ``m``, the first-order PnP pose error
    ``xi_f = (rotvec, t)`` of ``T_true^-1 T_est`` (right-multiplied, camera frame) per unit
    map error ``eta_m = (omega, dt)`` of marker ``m`` (the estimator's map holds the marker
    at ``T_world_marker @ [exp(omega) | dt]``, marker frame): ``xi_f = sum_m J[f, m] eta_m``.
    Multi-marker PnP on the undistorted pinhole corners of the markers ``visible[f]``
    (``K``): ``J[f, m] = -A_f^+ B_fm`` with ``A_f`` the Jacobian of the corners' pixels
    w.r.t. ``xi`` and ``B_fm`` w.r.t. ``eta_m``. Zero for markers not seen and for frames
    that see none."""
    T, vis, K = _check_map_inputs(field, visible, T_world_cam, K)
    M = field.T_world_marker.shape[0]
    local = marker_corners_local(field.side_m)                  # (4, 3)
    Pw = field.corners_world()                                  # (M, 4, 3)
    R_wm = field.T_world_marker[:, :3, :3]
    # d P_w / d eta per marker corner: (M, 4, 3, 6) = R_wm [ -[c]x , I ]
    skew_c = np.zeros((4, 3, 3))
    skew_c[:, 0, 1], skew_c[:, 0, 2] = -local[:, 2], local[:, 1]
    skew_c[:, 1, 0], skew_c[:, 1, 2] = local[:, 2], -local[:, 0]
    skew_c[:, 2, 0], skew_c[:, 2, 1] = -local[:, 1], local[:, 0]
    dP_deta = np.concatenate([np.einsum("mij,cjk->mcik", R_wm, -skew_c),
                              np.broadcast_to(R_wm[:, None], (M, 4, 3, 3))], axis=-1)
    J = np.zeros((T.shape[0], M, 6, 6))
    for f in np.flatnonzero(vis.any(axis=1)):
        ms = np.flatnonzero(vis[f])
        T_cw = invert_transform(T[f])
        pc = np.einsum("ij,mcj->mci", T_cw[:3, :3], Pw[ms]) + T_cw[:3, 3]      # (m, 4, 3)
        duv_dpc, dpc_dxi = _pose_from_point_jacobian(pc, K)
        A = (duv_dpc @ dpc_dxi).reshape(-1, 6)                              # (2P, 6)
        B = duv_dpc @ T_cw[:3, :3] @ dP_deta[ms]                           # (m, 4, 2, 6)
        Apinv = np.linalg.pinv(A)                                           # (6, 2P)
        Bm = B.reshape(len(ms), -1, 6)                                      # (m, 8, 6)
        Ap = Apinv.reshape(6, len(ms), 8).transpose(1, 0, 2)                # (m, 6, 8)
        J[f, ms] = -(Ap @ Bm)
    return J


def map_error_variances(position_std_m: float, rotation_std_rad: float) -> np.ndarray:
    """``(6,)`` variances of one marker's map error ``eta = (omega, dt)``: an angle
    ``~ N(0, rotation_std^2)`` about a uniform axis (``rotation_std^2 / 3`` per axis) and
    ``dt ~ N(0, position_std^2 I)``."""
    for name, v in (("position_std_m", position_std_m), ("rotation_std_rad", rotation_std_rad)):
        if isinstance(v, bool) or not np.isfinite(v) or v < 0:
            raise ValueError(f"{name} must be a finite number >= 0; received {v!r}")
    return np.array([rotation_std_rad ** 2 / 3.0] * 3 + [position_std_m ** 2] * 3)


def map_pose_covariance(field: MarkerField, visible: np.ndarray, T_world_cam, K,
                        position_std_m: float, rotation_std_rad: float) -> np.ndarray:
    """Covariance (6, 6) of the part of a camera's PnP pose error that a marker-map error
    makes common to its frames (constant over a run: the map is surveyed once).

    The estimator's map holds each marker at ``T_world_marker @ [dR | dt]`` (marker frame,
    ``dt ~ N(0, position_std_m^2 I)``, ``dR`` by an angle ``~ N(0, rotation_std_rad^2)``
    about a uniform axis, independent per marker; :func:`map_error_variances`). First
    order, per frame (:func:`map_pose_jacobians`), averaged over the frames that see a
    marker: ``J_m`` (6, 6) per marker; the covariance is ``sum_m J_m D J_m^T``,
    ``D = diag(rotation_std^2 / 3 (x3), position_std^2 (x3))``. Cross-covariance between
    two cameras seeing the same markers is not returned."""
    T, vis, K = _check_map_inputs(field, visible, T_world_cam, K)
    D = map_error_variances(position_std_m, rotation_std_rad)
    if not D.any():
        return np.zeros((6, 6))
    used = vis.any(axis=1)
    if not used.any():
        raise ValueError("no pose sees a marker; the map-error sensitivity is undefined")
    J = map_pose_jacobians(field, vis, T, K).sum(axis=0) / int(used.sum())
    S = np.einsum("mij,j,mkj->ik", J, D, J)
    return 0.5 * (S + S.T)


def intrinsics_pose_jacobians(points_world, T_world_cam, K, dist, sigmas) -> np.ndarray:
    """``(F, 6, 8)``: per frame, the first-order PnP pose error ``xi = (rotvec, t)`` of
    ``T_true^-1 T_est`` (right-multiplied, camera frame) per 1-sigma ``sigmas`` (8,) of each
    calibration parameter of :data:`INTRINSICS_PARAMETERS` (a calibration error is constant
    over a run; how it moves the pose depends on where the points fall in the image).
    ``points_world``: per frame the ``(P_f, 3)`` world points seen; ``T_world_cam``
    ``(F, 4, 4)``; ``K``, ``dist`` (5,): the calibration. The points are projected with
    ``(K, dist)``, undistorted with the calibration moved by ``+-sigma_j`` and taken to
    normalised coordinates (central difference); the pose follows through the normal
    equations of PnP in normalised coordinates. Frames with fewer than 4 points: zero.
    No PnP iteration (the linear counterpart of :func:`intrinsics_pose_sensitivity`)."""
    import cv2  # noqa: PLC0415
    T, K, dist, sig = _check_intrinsics_inputs(points_world, T_world_cam, K, dist, sigmas)
    K_norm = np.eye(3)
    J = np.zeros((T.shape[0], 6, 8))
    for f in range(T.shape[0]):
        seen = _frame_projection(cv2, points_world[f], T[f], K, dist)
        if seen is None:
            continue
        Pw, T_cw, _, img = seen
        pc = Pw @ T_cw[:3, :3].T + T_cw[:3, 3]
        duv_dpc, dpc_dxi = _pose_from_point_jacobian(pc, K_norm)
        A = (duv_dpc @ dpc_dxi).reshape(-1, 6)                  # normalised coordinates
        Apinv = np.linalg.pinv(A)
        for j in np.flatnonzero(sig > 0):
            n = [(uv - K2[:2, 2]) / np.diag(K2)[:2]
                 for K2, uv in _undistorted_at_plus_minus_sigma(img, K, dist, sig, j)]
            J[f, :, j] = Apinv @ (0.5 * (n[0] - n[1])).ravel()
    return J
