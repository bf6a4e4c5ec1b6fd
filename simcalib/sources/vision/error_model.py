"""The known systematic errors of visual poses: how the camera's calibration error
(``vision.intrinsics_error``, read as the 1-sigma of the calibration the estimator has) and
the marker map's survey error (``vision.map_position_std_m`` / ``map_rotation_std_deg``)
move the ArUco poses of a world's cameras — :func:`calibration_pose_bias` (the run-constant
covariance, :class:`CalibrationBias`) and :func:`pose_error_basis` (per pose, per shared
parameter). First order through PnP (:mod:`simcalib.targets.pnp_sensitivity`); nothing is
rendered.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcalib.sources.vision.config import VisionConfig
from simcalib.sources.vision.world_cameras import (board_of, camera_frames, camera_intrinsics,
                                                   delivered)
from simcalib.targets.pnp_sensitivity import (INTRINSICS_PARAMETERS, check_camera_poses,
                                              intrinsics_pose_jacobians,
                                              intrinsics_pose_sensitivity, map_error_variances,
                                              map_pose_covariance, map_pose_jacobians)

__all__ = ["CalibrationBias", "calibration_pose_bias", "calibration_sigmas", "pose_error_basis"]


@dataclass(frozen=True, eq=False)
class CalibrationBias:
    """The run-constant pose error of one camera that its calibration error causes
    (:func:`calibration_pose_bias`): ``covariance`` (6x6, of ``(rotvec rad, translation
    m)`` right-multiplied in the camera frame: ``T_world_cam measured = T_world_cam N``),
    ``jacobian`` (6, 8) the pose error per 1-sigma of each parameter of
    :data:`simcalib.targets.pnp_sensitivity.INTRINSICS_PARAMETERS`, ``sigmas`` (8,) those 1-sigmas,
    ``n_frames`` the poses averaged over; ``map_covariance`` the part of ``covariance``
    from the marker map's error (zeros without one)."""
    camera: str
    covariance: np.ndarray
    jacobian: np.ndarray
    sigmas: np.ndarray
    n_frames: int
    map_covariance: np.ndarray | None = None

    def report(self) -> dict:
        """Plain numbers for results.json: 1-sigma per axis (deg, m) and the inputs."""
        s = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        Sm = np.zeros((6, 6)) if self.map_covariance is None else self.map_covariance
        sm = np.sqrt(np.clip(np.diag(Sm), 0.0, None))
        return {"std_deg": [float(x) for x in np.degrees(s[:3])],
                "std_m": [float(x) for x in s[3:]],
                "covariance": np.asarray(self.covariance).tolist(),
                "parameter_sigmas": {n: float(v) for n, v in zip(INTRINSICS_PARAMETERS,
                                                                  self.sigmas)},
                "n_frames": int(self.n_frames),
                "map_std_deg": [float(x) for x in np.degrees(sm[:3])],
                "map_std_m": [float(x) for x in sm[3:]]}


def calibration_sigmas(eff) -> np.ndarray:
    """1-sigma (8,) of the calibration parameters (:data:`simcalib.targets.pnp_sensitivity.
    INTRINSICS_PARAMETERS`) a configuration's ``intrinsics_error`` ``(e_f, e_c, e_k)``
    stands for: focal ``e_f`` (relative, fx and fy together), principal point moved ``e_c``
    px in an unknown direction (RMS displacement ``e_c``: ``e_c / sqrt(2)`` per axis),
    each distortion coefficient ``e_k |k_j|``."""
    ef, ec, ek = eff.intrinsics_error
    d = np.abs(np.asarray(eff.distortion, dtype=np.float64))
    return np.concatenate([[ef, ec / np.sqrt(2.0), ec / np.sqrt(2.0)], ek * d])


def calibration_pose_bias(world, cfg: "VisionConfig | None" = None, cameras=None,
                          max_frames: int = 30) -> dict:
    """Per camera of ``world`` (or of ``cameras``): the :class:`CalibrationBias` the
    calibration error ``cfg.effects().intrinsics_error`` (read as the 1-sigma of the
    calibration the estimator has, :func:`calibration_sigmas`) causes in the ArUco poses.
    Nothing is rendered: the marker corners the layout makes fully visible in the camera's
    distorted image (:func:`simcalib.world.layout.visible_markers` with the lens
    distortion, as :func:`pose_error_basis`) from up to ``max_frames`` of the
    camera's true poses (evenly spaced over the delivered frames) go through
    :func:`simcalib.targets.pnp_sensitivity.intrinsics_pose_sensitivity`; ``covariance = J J^T``
    plus the marker-map term (``vision.map_position_std_m`` / ``map_rotation_std_deg``, the
    map's survey accuracy: :func:`simcalib.targets.pnp_sensitivity.map_pose_covariance`). The
    two cameras' map terms are correlated where they see the same markers; that cross term is
    not kept.
    Empty when the configuration has neither a calibration nor a map error."""
    cfg = VisionConfig() if cfg is None else cfg
    if not isinstance(cfg, VisionConfig):
        raise TypeError(f"cfg must be a VisionConfig; received {type(cfg).__name__}")
    if isinstance(max_frames, bool) or not isinstance(max_frames, (int, np.integer)) \
            or max_frames < 1:
        raise ValueError(f"max_frames must be an integer >= 1; received {max_frames!r}")
    eff = cfg.effects()
    sig = calibration_sigmas(eff)
    if not np.any(sig > 0) and not eff.has_map_error:
        return {}
    cameras = tuple(world.camera_names) if cameras is None else tuple(cameras)
    out = {}
    for cam in cameras:
        intr, _ = camera_intrinsics(world, cam, cfg)
        fr = camera_frames(world, cam)
        idx = np.flatnonzero(delivered(fr))
        if idx.size > max_frames:
            idx = idx[np.round(np.linspace(0, idx.size - 1, max_frames)).astype(int)]
        T = np.asarray(fr.T_world_cam, dtype=np.float64)[idx]
        vis, pts = _visible_target_points(world, T, intr, eff)
        if np.any(sig > 0):
            J = intrinsics_pose_sensitivity(pts, T, intr.K, eff.distortion, sig)
        else:
            J = np.zeros((6, sig.size))
        S_map = map_pose_covariance(world.marker_field, vis, T, intr.K,
                                    eff.map_position_std_m,
                                    float(np.radians(eff.map_rotation_std_deg))) \
            if vis.shape[1] else np.zeros((6, 6))    # a board: rigid, no map error
        n = int(sum(p.shape[0] >= 4 for p in pts))
        out[cam] = CalibrationBias(cam, J @ J.T + S_map, J, sig, n, S_map)
    return out


def pose_error_basis(world, camera: str, T_world_cam, cfg: "VisionConfig | None" = None,
                     visible: np.ndarray | None = None) -> np.ndarray:
    """How the calibration's and the marker map's errors move each of ``camera``'s ArUco
    poses ``T_world_cam`` (F, 4, 4): ``(F, 6, 6 M + 8)`` — the pose error ``xi = (rotvec,
    t)`` (right-multiplied, camera frame) per unit of standard-normal parameters: the ``6 M``
    map errors of the field's markers (``vision.map_position_std_m`` /
    ``map_rotation_std_deg``, the survey's accuracy; :func:`simcalib.targets.pnp_sensitivity.
    map_pose_jacobians`), then the 8 calibration parameters (``vision.intrinsics_error`` as
    1-sigma, :func:`calibration_sigmas`;
    :func:`simcalib.targets.pnp_sensitivity.intrinsics_pose_jacobians`). The map columns are the
    same parameters for every camera of the world (their errors
    are shared where the cameras see the same markers); each camera's calibration is its
    own. First order, linearised at the given poses with the markers each pose rests on:
    ``visible`` (F, M) bool (e.g. the ids the PnP used,
    :attr:`simcalib.sources.vision.stream.VisualFrame.ids_used`), by default those the layout
    makes fully visible there in the camera's distorted image
    (:func:`simcalib.world.layout.visible_markers` with the lens distortion). Nothing is
    rendered."""
    cfg = VisionConfig() if cfg is None else cfg
    if not isinstance(cfg, VisionConfig):
        raise TypeError(f"cfg must be a VisionConfig; received {type(cfg).__name__}")
    T = check_camera_poses(T_world_cam)
    eff = cfg.effects()
    intr, _ = camera_intrinsics(world, camera, cfg)
    field = world.marker_field
    if visible is None:
        vis, pts = _visible_target_points(world, T, intr, eff)
    else:
        vis = np.asarray(visible)
        if vis.shape != (T.shape[0], field.T_world_marker.shape[0]) or vis.dtype != bool:
            raise ValueError(f"visible must be ({T.shape[0]}, {field.T_world_marker.shape[0]}) "
                             f"booleans (pose x marker); received shape {vis.shape}, dtype "
                             f"{vis.dtype}")
    D = map_error_variances(eff.map_position_std_m, float(np.radians(eff.map_rotation_std_deg)))
    Jm = map_pose_jacobians(field, vis, T, intr.K) * np.sqrt(D)          # (F, M, 6, 6)
    if visible is not None:
        corners = field.corners_world()
        pts = [corners[v].reshape(-1, 3) for v in vis]
    sig = calibration_sigmas(eff)
    Ji = intrinsics_pose_jacobians(pts, T, intr.K, eff.distortion, sig)
    F, M = Jm.shape[:2]
    return np.concatenate([Jm.transpose(0, 2, 1, 3).reshape(F, 6, 6 * M), Ji], axis=2)


def _visible_target_points(world, T: np.ndarray, intr, eff) -> tuple[np.ndarray, list]:
    """``(visible (F, M) markers, [points (n_f, 3) per pose])``: the map markers fully in
    view (:func:`simcalib.world.layout.visible_markers` in the distorted image) and their
    corners; for a board target no map marker (M = 0) and the board corners in view."""
    from simcalib.world.layout import project_points, visible_markers  # noqa: PLC0415
    board, T_wb = board_of(world)
    if board is None:
        vis = visible_markers(world.marker_field, T, intr, distortion=eff.distortion)
        corners = world.marker_field.corners_world()
        return vis, [corners[v].reshape(-1, 3) for v in vis]
    from simcalib.targets.boards import board_corners  # noqa: PLC0415
    from simcalib.geometry import distort_pixels  # noqa: PLC0415
    p_world = board_corners(board)[1] @ T_wb[:3, :3].T + T_wb[:3, 3]
    uv, z = project_points(T, intr, p_world)                          # (F, N, 2), (F, N)
    ok = z > 0.05
    if np.any(np.asarray(eff.distortion, dtype=np.float64) != 0):
        uv, one_to_one = distort_pixels(uv, intr.K, eff.distortion)
        ok &= one_to_one
    ok &= ((uv[..., 0] >= 2) & (uv[..., 0] <= intr.width - 3) & (uv[..., 1] >= 2)
           & (uv[..., 1] <= intr.height - 3))
    return np.zeros((T.shape[0], 0), dtype=bool), [p_world[m] for m in ok]
