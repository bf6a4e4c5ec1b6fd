"""A world's cameras as the vision stack sees them: each camera's pinhole (the
:class:`~simcalib.streams.CameraIntrinsics` under the ``vision`` config, checked against
the camera MuJoCo renders), its frames (which were delivered, their timestamps, the MuJoCo
state between frames) and the world's board target. Plain numpy on the world's records.
"""

from __future__ import annotations

import numpy as np

from simcalib.streams import CameraIntrinsics
from simcalib.sources.vision.config import VisionConfig
from simcalib.targets.markers import MarkerField

__all__ = ["board_of", "camera_frames", "camera_intrinsics", "check_model_fovy", "check_world",
           "checked_intrinsics", "delivered", "row", "stamps", "state_at"]


def camera_intrinsics(world, camera: str, cfg: VisionConfig) -> tuple[CameraIntrinsics, float]:
    base = world.intrinsics[camera]
    if not isinstance(base, CameraIntrinsics):
        raise TypeError(f"world.intrinsics[{camera!r}] must be a CameraIntrinsics; received "
                        f"{type(base).__name__}")
    width = cfg.width if cfg.width is not None else base.width
    height = cfg.height if cfg.height is not None else base.height
    if cfg.fovy_deg is not None:
        fovy = float(cfg.fovy_deg)
    else:
        fovy = float(np.rad2deg(2.0 * np.arctan(base.height / (2.0 * base.fy))))
    return CameraIntrinsics.from_fovy(width, height, fovy), fovy


def checked_intrinsics(world, cameras, cfg: VisionConfig) -> dict:
    """Each camera's intrinsics under ``cfg``, checked against the model if fovy is not set."""
    intr = {}
    for cam in cameras:
        intr[cam], fovy = camera_intrinsics(world, cam, cfg)
        if cfg.fovy_deg is None:
            check_model_fovy(world.model, cam, fovy, world.intrinsics[cam])
    return intr


def check_model_fovy(model, camera: str, fovy_deg: float, base: CameraIntrinsics) -> None:
    """The world's intrinsics must be the pinhole MuJoCo renders (else poses are biased)."""
    from simcalib.world.render_backend import import_mujoco  # noqa: PLC0415
    mujoco = import_mujoco()
    cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
    if cid < 0:
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)]
        raise ValueError(f"camera {camera!r} is not in world.model; cameras: {names}")
    if np.any(np.asarray(model.cam_sensorsize[cid]) > 0):
        raise ValueError(f"camera {camera!r} uses sensorsize/focal length; simcalib derives "
                         "intrinsics from fovy only (docs/platform.md)")
    model_fovy = float(model.cam_fovy[cid])
    expect = CameraIntrinsics.from_fovy(base.width, base.height, model_fovy)
    if abs(model_fovy - fovy_deg) > 1e-6 or abs(base.cx - expect.cx) > 1e-9 \
            or abs(base.cy - expect.cy) > 1e-9 or abs(base.fx - base.fy) > 1e-9 * base.fy:
        raise ValueError(
            f"world.intrinsics[{camera!r}] (fx={base.fx:.6g}, fy={base.fy:.6g}, cx={base.cx}, "
            f"cy={base.cy}, {base.width}x{base.height}) is not the pinhole MuJoCo renders for "
            f"fovy {model_fovy} deg (fx=fy={expect.fy:.6g}, cx={expect.cx}, cy={expect.cy})")


def check_world(world) -> None:
    for name in ("model", "camera_names", "intrinsics", "marker_field", "trajectory"):
        if not hasattr(world, name):
            raise TypeError(f"world must provide .{name} (a simcalib.world.World); received "
                            f"{type(world).__name__} without it")
    if not isinstance(world.marker_field, MarkerField):
        raise TypeError("world.marker_field must be a simcalib.targets.markers.MarkerField; received "
                        f"{type(world.marker_field).__name__}")


def camera_frames(world, camera: str):
    traj = world.trajectory
    for attr in ("cam_a", "cam_b"):
        fr = getattr(traj, attr, None)
        if fr is not None and fr.camera == camera:
            return fr
    names = [getattr(getattr(traj, a, None), "camera", None) for a in ("cam_a", "cam_b")]
    raise ValueError(f"camera {camera!r} has no frames in world.trajectory; it has {names}")


def board_of(world) -> tuple:
    """``(BoardConfig, T_world_board)`` of a world whose target is a board, else (None, None)."""
    scene = getattr(world, "scene", None)
    return getattr(scene, "board", None), getattr(scene, "T_world_board", None)


def delivered(frames) -> np.ndarray:
    """Frames the camera delivered (world's ``delivered`` record; all when absent)."""
    mask = getattr(frames, "delivered", None)
    if mask is None:
        return np.ones(frames.n_frames, dtype=bool)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (frames.n_frames,):
        raise ValueError(f"frames.delivered must have shape ({frames.n_frames},); received "
                         f"{mask.shape}")
    return mask


def stamps(frames) -> np.ndarray:
    """The camera's reported timestamps (``stamp_s`` when the world provides them)."""
    s = getattr(frames, "stamp_s", None)
    return np.asarray(frames.time_s if s is None else s, dtype=np.float64)


def state_at(fr, t: float) -> tuple:
    """Raw MuJoCo state ``(qpos, mocap_pos, mocap_quat_wxyz)`` at time ``t``, linearly
    interpolated between the camera's frames (quaternions: normalised lerp in one
    hemisphere); outside the frames, extrapolated from the nearest pair."""
    ts = np.asarray(fr.time_s, dtype=np.float64)
    n = ts.size
    if n == 1:
        return (row(fr.qpos, 0), row(fr.mocap_pos, 0), row(fr.mocap_quat_wxyz, 0))
    i = int(np.clip(np.searchsorted(ts, t) - 1, 0, n - 2))
    dt = ts[i + 1] - ts[i]
    a = (t - ts[i]) / dt if dt > 0 else 0.0

    def lerp(arr):
        r0, r1 = row(arr, i), row(arr, i + 1)
        return None if r0 is None else (1 - a) * r0 + a * r1

    q0, q1 = row(fr.mocap_quat_wxyz, i), row(fr.mocap_quat_wxyz, i + 1)
    q = None
    if q0 is not None:
        sign = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -1.0, 1.0)
        q = (1 - a) * q0 + a * sign * q1
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return (lerp(fr.qpos), lerp(fr.mocap_pos), q)


def row(arr, k):
    if arr is None:
        return None
    a = np.asarray(arr)
    if a.size == 0:
        return None
    return a[k]
