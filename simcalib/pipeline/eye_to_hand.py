"""results.json ``eye_to_hand`` of a run on the arm with a fixed camera (``world.arm.mount =
eye_to_hand``, :mod:`simcalib.world.eyetohand`): the fixed camera's pose in the robot base,
``T_base_cam ≈ T_base_flange_i · X · inv(T_cam_board_i)`` over the common frames ``i``, a
by-product of every estimate of ``X = T_flange_board``, with its error; and how the camera
saw the board over the run.
"""

from __future__ import annotations

import numpy as np

from simcalib.world.eyetohand import FIXED_CAMERA, T_world_fixed_camera, is_eye_to_hand

__all__ = ["eye_to_hand_report", "base_camera_estimate", "board_visibility"]


def _mean_transform(T: np.ndarray) -> np.ndarray:
    """Chordal mean rotation (SVD projection of the mean matrix) and mean translation."""
    U, _, Vt = np.linalg.svd(T[:, :3, :3].mean(axis=0))
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = R, T[:, :3, 3].mean(axis=0)
    return out


def base_camera_estimate(stream_a, stream_b, X: np.ndarray, T_world_base: np.ndarray):
    """``T_base_cam`` from the flange stream (world = room), the board stream (world =
    fixed camera) and ``X = T_flange_board``, averaged over their common frames."""
    from simcalib.errors import DataError
    from simcalib.geometry import invert_transform
    common, ia, ib = np.intersect1d(np.asarray(stream_a.frame_index),
                                    np.asarray(stream_b.frame_index), return_indices=True)
    if common.size == 0:
        raise DataError("eye-to-hand: the flange and board streams share no frame; "
                        "T_base_cam cannot be computed")
    A = np.asarray(stream_a.T_world_cam)[ia]
    B = np.asarray(stream_b.T_world_cam)[ib]
    per_frame = invert_transform(T_world_base) @ A @ X @ invert_transform(B)
    return _mean_transform(per_frame)


def eye_to_hand_report(st) -> dict | None:
    """results.json ``eye_to_hand``: the true ``T_base_cam`` and, per successful solver,
    the by-product estimate with its rotation (deg) / translation (m) error."""
    cfg = st.cfg.world
    world = st.truth.world if st.truth is not None else None
    if world is None or not is_eye_to_hand(cfg):
        return None
    from simcalib.geometry import invert_transform, rotation_error_rad, translation_error_m
    from simcalib.world.robot_error import arm_state
    _, T_world_base = arm_state(world)
    T_true = invert_transform(T_world_base) @ T_world_fixed_camera(cfg)
    out = {"camera": FIXED_CAMERA, "X": "T_flange_board", "T_base_cam_true": T_true.tolist(),
           "board_visibility": board_visibility(st.truth.streams["cam_b"]), "solvers": {}}
    for sol in st.solvers:
        if not sol.success or sol.X is None:
            continue
        T = base_camera_estimate(st.measured["cam_a"], st.measured["cam_b"], sol.X,
                                 T_world_base)
        out["solvers"][sol.label] = {
            "T_base_cam": T.tolist(),
            "rotation_error_deg": float(np.rad2deg(rotation_error_rad(T, T_true))),
            "translation_error_m": float(translation_error_m(T, T_true))}
    return out


def board_visibility(board_stream, fovy_deg: float = 60.0, aspect: float = 4 / 3) -> dict:
    """How the fixed camera sees the board over the run (truth stream, world = camera):
    the board origin's distance, its angle off the optical axis, the board's tilt
    (angle between its normal and the line of sight) and the fraction of frames with the
    origin inside the field of view and a tilt below 60 deg."""
    T = np.asarray(board_stream.T_world_cam)
    p = T[:, :3, 3]
    dist = np.linalg.norm(p, axis=-1)
    ray = p / dist[:, None]
    tilt = np.rad2deg(np.arccos(np.clip(np.abs(np.einsum("ni,ni->n", T[:, :3, 2], ray)),
                                        -1.0, 1.0)))
    half_y = np.tan(np.deg2rad(fovy_deg) / 2)
    inside = (np.abs(p[:, 0] / p[:, 2]) < half_y * aspect) & (np.abs(p[:, 1] / p[:, 2]) < half_y)
    ok = inside & (p[:, 2] > 0) & (tilt < 60.0)
    return {"distance_m_min": float(dist.min()), "distance_m_max": float(dist.max()),
            "tilt_deg_max": float(tilt.max()), "fraction_in_view": float(ok.mean())}
