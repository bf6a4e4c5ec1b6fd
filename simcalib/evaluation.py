"""Errors against the known truth: each estimate of X, and each pose source per camera.

* Estimate errors: geodesic rotation error (degrees) and Euclidean translation error
  (metres) of ``X_est`` against ``X_true``; when a solver flags undetermined translation
  directions, also the translation error with those directions projected out (what the
  motion could determine at all).
* Pose-source errors: for every pose of a source that has a ground-truth pose at the same
  simulated frame, the rotation and translation error; median and 95th percentile.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcalib.geometry import check_transforms, rotation_error_rad, translation_error_m

__all__ = ["PoseErrors", "pose_source_errors", "estimate_errors", "summary_stats"]


@dataclass(frozen=True)
class PoseErrors:
    """Per-pose errors of one camera's pose source against ground truth.

    ``frame_index``, ``rotation_deg`` and ``translation_m`` are aligned ``(K,)`` arrays.
    """
    camera: str
    source: str
    frame_index: np.ndarray
    rotation_deg: np.ndarray
    translation_m: np.ndarray

    @property
    def n(self) -> int:
        return int(self.frame_index.shape[0])

    def summary(self) -> dict:
        return {"n": self.n,
                "rotation_deg": summary_stats(self.rotation_deg),
                "translation_m": summary_stats(self.translation_m)}


def summary_stats(values: np.ndarray) -> dict:
    """``{"median", "p95", "mean", "max"}`` of ``values`` (``None`` entries when empty)."""
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0:
        return {"median": None, "p95": None, "mean": None, "max": None}
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)),
            "mean": float(v.mean()), "max": float(v.max())}


def pose_source_errors(source, truth) -> PoseErrors:
    """Errors of ``source`` against ``truth`` (two :class:`~simcalib.streams.PoseStream` of
    the same camera, matched by simulated ``frame_index``; both in the same world frame)."""
    if source.camera != truth.camera:
        raise ValueError(f"pose streams of different cameras: {source.camera!r} vs "
                         f"{truth.camera!r}")
    fs = np.asarray(source.frame_index)
    ft = np.asarray(truth.frame_index)
    common, i_s, i_t = np.intersect1d(fs, ft, assume_unique=True, return_indices=True)
    Ts = check_transforms(source.T_world_cam, f"{source.source} poses")[i_s]
    Tt = check_transforms(truth.T_world_cam, "ground-truth poses")[i_t]
    return PoseErrors(camera=source.camera, source=source.source, frame_index=common,
                      rotation_deg=np.rad2deg(rotation_error_rad(Ts, Tt)),
                      translation_m=translation_error_m(Ts, Tt))


def estimate_errors(X_est: np.ndarray, X_true: np.ndarray,
                    undetermined_translation_axes: np.ndarray | None = None) -> dict:
    """``rotation_error_deg``, ``translation_error_m`` and, if undetermined translation
    directions (unit vectors in camera a's frame, ``(k, 3)``) are given,
    ``translation_error_determined_m`` — the error with those directions projected out."""
    X_est = check_transforms(X_est, "X estimate")
    X_true = check_transforms(X_true, "X_true")
    out = {"rotation_error_deg": float(np.rad2deg(rotation_error_rad(X_est, X_true))),
           "translation_error_m": float(translation_error_m(X_est, X_true))}
    axes = None if undetermined_translation_axes is None else np.atleast_2d(
        np.asarray(undetermined_translation_axes, dtype=np.float64))
    if axes is not None and axes.size:
        Q, _ = np.linalg.qr(axes.T)  # orthonormal basis of the undetermined subspace
        d = X_est[:3, 3] - X_true[:3, 3]
        d_det = d - Q @ (Q.T @ d)
        out["translation_error_determined_m"] = float(np.linalg.norm(d_det))
    else:
        out["translation_error_determined_m"] = out["translation_error_m"]
    return out
