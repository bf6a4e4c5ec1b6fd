"""Plain data types passed between stages: world -> sensor streams -> motion pairs.

Every pose is ``T_world_cam`` (pose of the camera's OpenCV frame — x right, y down,
z forward — in the stream's world frame). Ground truth lives in the MuJoCo world frame;
a visual stream lives in the marker map's frame (which is the MuJoCo world frame here).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["CAMERAS", "CameraFrames", "CameraIntrinsics", "PoseStream", "Trajectory"]

#: The cameras (streams) of a rig, in the order a run's generators are split between them.
CAMERAS = ("cam_a", "cam_b")


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics (no distortion) of a rendered camera, OpenCV convention."""
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @classmethod
    def from_fovy(cls, width: int, height: int, fovy_deg: float) -> "CameraIntrinsics":
        """MuJoCo's pinhole from a vertical field of view (docs/platform.md):
        ``fx = fy = H / (2 tan(fovy / 2))``, ``cx = (W - 1) / 2``, ``cy = (H - 1) / 2``."""
        if not (width > 0 and height > 0):
            raise ValueError(f"camera size must be positive; received {width}x{height}")
        if not (0.0 < fovy_deg < 180.0):
            raise ValueError(f"fovy must be in (0, 180) degrees; received {fovy_deg}")
        f = height / (2.0 * np.tan(np.deg2rad(fovy_deg) / 2.0))
        return cls(int(width), int(height), f, f, (width - 1) / 2.0, (height - 1) / 2.0)


@dataclass(frozen=True)
class CameraFrames:
    """Ground truth of one camera at its own capture times (a simulated run).

    ``time_s``: ``(F,)`` true capture times; ``T_world_cam``: ``(F, 4, 4)`` true poses of the
    camera's OpenCV frame in the MuJoCo world. ``qpos`` ``(F, nq)``, ``mocap_pos``
    ``(F, nmocap, 3)`` and ``mocap_quat_wxyz`` ``(F, nmocap, 4)`` are the raw MuJoCo state at
    those times (MuJoCo's own quaternion order — for rendering only, never for geometry).
    """
    camera: str
    time_s: np.ndarray
    T_world_cam: np.ndarray
    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat_wxyz: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.time_s.shape[0])


@dataclass(frozen=True)
class Trajectory:
    """Ground truth of a simulated run: both cameras' frames and the true extrinsic.

    ``T_a_b`` is the true ``X`` (pose of camera b in camera a), ``(4, 4)``. The cameras may
    capture at different times (time offset / jitter), so each has its own ``CameraFrames``.
    """
    cam_a: CameraFrames
    cam_b: CameraFrames
    T_a_b: np.ndarray
    meta: dict = field(default_factory=dict)


@dataclass(frozen=True)
class PoseStream:
    """Timestamped poses of one camera from one source, with dropped frames counted.

    ``frame_index[k]`` is the simulated frame pose ``k`` belongs to; frames without a usable
    pose are absent (never filled in) and counted in ``n_frames - len(frame_index)``.
    ``timestamp_s`` is the camera's own clock (may carry an offset and jitter).
    ``info`` holds per-pose source diagnostics (e.g. ``n_markers``, ``reproj_error_px``)
    as arrays aligned with ``frame_index``, and ``drop_reasons`` counts why frames dropped.
    """
    camera: str
    source: str
    frame_index: np.ndarray
    timestamp_s: np.ndarray
    T_world_cam: np.ndarray
    n_frames: int
    info: dict = field(default_factory=dict)
    drop_reasons: dict = field(default_factory=dict)

    @property
    def n_used(self) -> int:
        return int(self.frame_index.shape[0])

    @property
    def n_dropped(self) -> int:
        return int(self.n_frames - self.n_used)
