"""Pose streams from simulated ground truth: exact, and noise-corrupted (paper eq. 38).

Both keep the camera's delivery record: frames the camera dropped (``delivered`` False in
:class:`~simcalib.world.simulate.SimCameraFrames`) are absent from the stream and counted
in ``drop_reasons["frame_dropped"]`` — never filled in. Timestamps are the camera's
reported ``stamp_s`` (its own clock), not the true capture times.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import perturb_transforms, rotation_error_rad, translation_error_m
from simcalib.streams import CameraFrames, PoseStream

__all__ = ["ground_truth_stream", "noisy_stream", "delivered_mask"]


def _check_frames(frames) -> None:
    if not isinstance(frames, CameraFrames):
        raise TypeError(f"frames must be a CameraFrames (e.g. world.trajectory.cam_a); "
                        f"received {type(frames).__name__}")


def delivered_mask(frames: CameraFrames) -> np.ndarray:
    """``(F,)`` bool: frames the camera delivered (all True for plain ``CameraFrames``)."""
    _check_frames(frames)
    mask = getattr(frames, "delivered", None)
    if mask is None:
        return np.ones(frames.n_frames, dtype=bool)
    return np.asarray(mask, dtype=bool)


def _stamps(frames: CameraFrames) -> np.ndarray:
    s = getattr(frames, "stamp_s", None)
    return np.asarray(frames.time_s if s is None else s, dtype=np.float64)


def _drop_reasons(mask: np.ndarray) -> dict:
    n = int((~mask).sum())
    return {"frame_dropped": n} if n else {}


def ground_truth_stream(frames: CameraFrames) -> PoseStream:
    """The exact poses of one camera (``source="ground_truth"``), delivered frames only."""
    mask = delivered_mask(frames)
    idx = np.flatnonzero(mask)
    return PoseStream(camera=frames.camera, source="ground_truth", frame_index=idx,
                      timestamp_s=_stamps(frames)[idx],
                      T_world_cam=np.array(frames.T_world_cam[idx], dtype=np.float64),
                      n_frames=frames.n_frames, info={}, drop_reasons=_drop_reasons(mask))


def noisy_stream(frames: CameraFrames, sigma_r_rad: float, sigma_t_m: float,
                 rng: np.random.Generator) -> PoseStream:
    """Ground truth corrupted by the paper's eq. 38 noise (``T ∘ [δR | δt]``, δR about a
    uniform axis by an angle ~ N(0, σ_r²), δt ~ N(0, σ_t² I)), seeded by ``rng``.
    ``source="noisy_ground_truth"``; ``info`` holds the applied per-pose
    ``noise_rotation_rad`` and ``noise_translation_m``."""
    _check_frames(frames)
    for name, v in (("sigma_r_rad", sigma_r_rad), ("sigma_t_m", sigma_t_m)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise TypeError(f"{name} must be a number; received {v!r}")
    gt = ground_truth_stream(frames)
    noisy = perturb_transforms(gt.T_world_cam, float(sigma_r_rad), float(sigma_t_m), rng)
    info = {"noise_rotation_rad": rotation_error_rad(noisy, gt.T_world_cam),
            "noise_translation_m": translation_error_m(noisy, gt.T_world_cam)}
    return PoseStream(camera=gt.camera, source="noisy_ground_truth",
                      frame_index=gt.frame_index, timestamp_s=gt.timestamp_s,
                      T_world_cam=noisy, n_frames=gt.n_frames, info=info,
                      drop_reasons=dict(gt.drop_reasons))
