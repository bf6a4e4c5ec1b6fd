"""Source ``mocap``: an optical motion-capture system (Vicon / OptiTrack style) tracking a
rigid body of retro-reflective markers fixed to the camera (``mocap.*``).

What the tracker does, frame by frame (at the camera stream's frames: its rate is
``world.cam_X.fps``, its latency the stream's clock ``world.cam_X.clock_offset_s``, its
random losses ``world.cam_X.drop_prob``):

* **The body.** ``mocap.markers`` markers on a plate ``mocap.body_size_m`` across (a fixed
  asymmetric layout, :data:`MARKER_LAYOUT`), the plate at ``mocap.body_offset_m`` /
  ``mocap.body_rotvec_deg`` in the camera frame (default: 7 cm above the lens, facing up).
* **Who sees a marker.** :data:`TRACKING_CAMERAS` mocap cameras high on the room's walls
  (four corners, four wall centres), aimed at the middle of the room, each seeing a cone
  of :data:`TRACKING_FOV_DEG`; a marker counts when at least ``mocap.min_views`` of them
  see it — inside their cone and in front of the plate (within ``mocap.marker_view_deg``
  of its normal: the plate hides what is behind it). With fewer than 3 markers counted
  the body is lost and the frame dropped (``drop_reasons["occluded"]``), so dropouts come
  in runs where the motion turns the plate away, as on a real system.
* **Noise.** Each counted marker is triangulated with Gaussian error
  ``mocap.marker_sigma_m`` per axis; the body pose is the least-squares rigid fit
  (Kabsch) of the layout to them: its rotation noise grows as the body shrinks or loses
  markers, and reaches the camera through the lever arm of the body offset.
* **Body-to-camera offset.** The reported camera pose is the tracked body composed with
  the body-to-camera transform the user *believes*: the true one times an error drawn once
  per run and camera (1-sigma ``mocap.offset_sigma_deg`` per rotation axis,
  ``mocap.offset_sigma_m`` per translation axis, in the camera frame). That error is a
  constant pose bias of the stream: it goes into X unchanged, and the run's covariance
  includes it (:meth:`MocapSource.calibration_bias`). Default 0: the body defines the frame.

The truth of the frame is the camera's: with no noise and no offset error the stream is the
camera's exact pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simcalib.config.checks import check_int, check_range, check_vector, set_fields
from simcalib.config.engine import key_help
from simcalib.sources.base import CAMERAS, GroundTruth, SourceHooks, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["MocapConfig", "MocapSource", "MocapOffsetBias", "MARKER_LAYOUT",
           "TRACKING_CAMERAS", "rigid_fit", "tracking_cameras"]

#: Marker positions on the plate, in units of ``body_size_m``, body frame (z = the plate's
#: normal); asymmetric, so the body is identifiable; the first ``markers`` are used.
MARKER_LAYOUT = ((0.50, 0.00, 0.0), (-0.35, 0.30, 0.0), (-0.20, -0.45, 0.0),
                 (0.10, 0.50, 0.15), (0.40, -0.40, 0.0), (-0.50, 0.05, 0.10))
#: Mocap cameras of the room: four upper corners and four wall centres.
TRACKING_CAMERAS = 8
#: Full opening angle of a mocap camera's view cone, degrees.
TRACKING_FOV_DEG = 80.0
#: Where the mocap cameras are aimed: the room's centre at this height, metres.
TRACKING_AIM_HEIGHT_M = 1.0



@dataclass(frozen=True)
class MocapConfig:
    """The motion-capture tracker of source ``mocap`` (module docstring)."""
    markers: int = field(default=4, metadata=key_help(
        "markers on the tracked body (3 to 6; at least 3 must be seen to track it)"))
    body_size_m: float = field(default=0.10, metadata=key_help(
        "span of the marker plate, metres"))
    body_offset_m: tuple[float, float, float] = field(default=(0.0, -0.07, -0.02),
                                                      metadata=key_help(
        "the body's origin in the camera frame (x right, y down, z forward), metres"))
    body_rotvec_deg: tuple[float, float, float] = field(default=(90.0, 0.0, 0.0),
                                                        metadata=key_help(
        "the body's orientation in the camera frame, axis-angle degrees (default: plate "
        "normal = camera up)"))
    marker_sigma_m: float = field(default=0.0002, metadata=key_help(
        "triangulation noise of a marker per axis, metres"))
    min_views: int = field(default=2, metadata=key_help(
        "mocap cameras that must see a marker for it to count"))
    marker_view_deg: float = field(default=80.0, metadata=key_help(
        "a marker is seen from within this angle of the plate's normal, degrees"))
    offset_sigma_m: float = field(default=0.0, metadata=key_help(
        "1-sigma error per axis of the body-to-camera translation the user applies, m"))
    offset_sigma_deg: float = field(default=0.0, metadata=key_help(
        "1-sigma error per axis of the body-to-camera rotation the user applies, deg"))

    def __post_init__(self):
        set_fields(self,
                   markers=check_int("markers", self.markers, lo=3, hi=len(MARKER_LAYOUT)),
                   body_size_m=check_range("body_size_m", self.body_size_m, lo=0.01, hi=1.0),
                   body_offset_m=check_vector("body_offset_m", self.body_offset_m,
                                              max_norm=1.0, what="metres from the camera"),
                   body_rotvec_deg=check_vector("body_rotvec_deg", self.body_rotvec_deg),
                   marker_sigma_m=check_range("marker_sigma_m", self.marker_sigma_m,
                                              lo=0.0, hi=0.05),
                   min_views=check_int("min_views", self.min_views, lo=1,
                                       hi=TRACKING_CAMERAS),
                   marker_view_deg=check_range("marker_view_deg", self.marker_view_deg,
                                               lo=0.0, hi=180.0, lo_open=True),
                   offset_sigma_m=check_range("offset_sigma_m", self.offset_sigma_m,
                                              lo=0.0, hi=0.1),
                   offset_sigma_deg=check_range("offset_sigma_deg", self.offset_sigma_deg,
                                                lo=0.0, hi=20.0))

    def marker_points(self) -> np.ndarray:
        """``(K, 3)`` the markers in the body frame, metres."""
        return self.body_size_m * np.asarray(MARKER_LAYOUT[:self.markers], dtype=np.float64)

    def T_cam_body(self) -> np.ndarray:
        """``(4, 4)`` the true pose of the body in the camera frame."""
        from simcalib.geometry import matrix_from_rotvec, transform_from_rotation_translation
        R = matrix_from_rotvec(np.deg2rad(np.asarray(self.body_rotvec_deg)))
        return transform_from_rotation_translation(R, np.asarray(self.body_offset_m))


@dataclass(frozen=True)
class MocapOffsetBias:
    """The run-constant pose error of one camera's stream that the body-to-camera offset
    error causes: ``covariance`` (6, 6) of ``(rotvec rad, translation m)`` right-multiplied
    in the camera frame (``T_world_cam reported = T_world_cam N``), diagonal."""
    camera: str
    covariance: np.ndarray

    def report(self) -> dict:
        s = np.sqrt(np.diag(self.covariance))
        return {"std_deg": [float(x) for x in np.degrees(s[:3])],
                "std_m": [float(x) for x in s[3:]],
                "covariance": np.asarray(self.covariance).tolist(),
                "input": "mocap.offset_sigma_deg / offset_sigma_m (the body-to-camera "
                         "transform's error)"}


def tracking_cameras(room_size_m) -> tuple[np.ndarray, np.ndarray]:
    """``(positions (M, 3), viewing directions (M, 3))`` of the mocap cameras in a room of
    ``room_size_m`` (centred on the origin, floor at 0)."""
    sx, sy, sz = (float(v) for v in room_size_m)
    hx, hy, z = 0.5 * sx - 0.1, 0.5 * sy - 0.1, sz - 0.15
    pos = np.array([(hx, hy, z), (-hx, hy, z), (-hx, -hy, z), (hx, -hy, z),
                    (hx, 0.0, z), (0.0, hy, z), (-hx, 0.0, z), (0.0, -hy, z)])
    aim = np.array([0.0, 0.0, TRACKING_AIM_HEIGHT_M]) - pos
    return pos, aim / np.linalg.norm(aim, axis=1, keepdims=True)


def _seen(markers_w: np.ndarray, normal_w: np.ndarray, cfg: MocapConfig,
          room_size_m) -> np.ndarray:
    """``(F, K)`` bool: markers counted (seen by at least ``min_views`` mocap cameras)."""
    cam_pos, cam_dir = tracking_cameras(room_size_m)
    to_cam = cam_pos[None, None, :, :] - markers_w[:, :, None, :]          # (F, K, M, 3)
    to_cam /= np.linalg.norm(to_cam, axis=-1, keepdims=True)
    in_cone = -np.einsum("fkmi,mi->fkm", to_cam, cam_dir) >= math.cos(
        math.radians(0.5 * TRACKING_FOV_DEG))
    facing = np.einsum("fkmi,fi->fkm", to_cam, normal_w) >= math.cos(
        math.radians(cfg.marker_view_deg))
    return (in_cone & facing).sum(axis=-1) >= cfg.min_views


def rigid_fit(P: np.ndarray, Q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``(F, 4, 4)`` the rigid transforms ``T`` minimising ``sum_k w[f, k] |T P[k] -
    Q[f, k]|^2`` (weighted Kabsch, batched): ``P`` ``(K, 3)`` the body's points, ``Q``
    ``(F, K, 3)`` the measured ones, ``w`` ``(F, K)`` weights (0: not seen; each frame
    needs 3 non-collinear points of weight > 0)."""
    w = np.asarray(w, dtype=np.float64)
    ws = w.sum(axis=1, keepdims=True)
    p0 = (w @ P) / ws                                                     # (F, 3)
    q0 = np.einsum("fk,fki->fi", w, Q) / ws
    H = np.einsum("fk,fki,fkj->fij", w, P[None] - p0[:, None], Q - q0[:, None])
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, 1, 2) @ np.swapaxes(U, 1, 2)))
    D = np.zeros_like(H)
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = d
    R = np.swapaxes(Vt, 1, 2) @ D @ np.swapaxes(U, 1, 2)
    T = np.zeros(R.shape[:1] + (4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = q0 - np.einsum("fij,fj->fi", R, p0)
    T[:, 3, 3] = 1.0
    return T


class MocapSource(SourceHooks):
    info = SourceInfo(name="mocap", kinds=("sim",), rng_stream="mocap", config=MocapConfig,
                      example=("planar", "streams.a.source=mocap"),
                      description="motion capture: a marker body on the camera tracked by "
                                  "mocap cameras on the walls (triangulation noise, "
                                  "occlusion dropouts, body-to-camera offset error; mocap.*)")

    def _sigmas(self, cfg) -> tuple[float, float]:
        """Predicted 1-sigma of the camera pose from the body fit: rotation (rad, per
        axis) and translation (m, per axis) with all markers seen."""
        m = cfg.mocap
        P = m.marker_points()
        r = np.sqrt(np.mean(np.sum((P - P.mean(axis=0)) ** 2, axis=1)))
        s_rot = m.marker_sigma_m / (r * math.sqrt(P.shape[0]))
        lever = float(np.linalg.norm(m.body_offset_m)) + r
        return s_rot, m.marker_sigma_m / math.sqrt(P.shape[0]) + lever * s_rot

    def pose_margins(self, cfg) -> tuple[float, float]:
        """4 sigma of the difference of two tracked poses (as ``noisy``: translation m,
        rotation deg), the bias of the offset error on a motion included."""
        s_rot, s_t = self._sigmas(cfg)
        k = 4.0 * math.sqrt(2.0)
        m = cfg.mocap
        return (k * math.sqrt(3.0) * s_t + 2.0 * m.offset_sigma_m,
                k * math.sqrt(3.0) * math.degrees(s_rot))

    def check_config(self, cfg) -> None:
        from simcalib.errors import ConfigError
        from simcalib.world.platforms import get_platform
        if get_platform(cfg.world.platform).info.outdoor:
            raise ConfigError(f"source mocap tracks inside the room's capture volume; "
                              f"platform {cfg.world.platform!r} drives outdoors",
                              key="source", value="mocap")

    def calibration_bias(self, world, cfg, cameras) -> dict:
        """The body-to-camera offset error's covariance (constant per camera)."""
        m = cfg.mocap
        if m.offset_sigma_m == 0.0 and m.offset_sigma_deg == 0.0:
            return {}
        var = [math.radians(m.offset_sigma_deg) ** 2] * 3 + [m.offset_sigma_m ** 2] * 3
        return {cam: MocapOffsetBias(cam, np.diag(var)) for cam in cameras}

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        world = truth.world
        rngs = dict(zip(CAMERAS, rng.spawn(len(CAMERAS))))
        streams, log = {}, {}
        for cam in cameras:
            streams[cam], log[cam] = self._track(world, cfg.mocap, cam, rngs[cam])
        return SourceOutput(streams=streams, log=log)

    def _track(self, world, m: MocapConfig, cam: str, rng) -> tuple:
        """One camera's tracked stream and its log entry."""
        from simcalib.geometry import (invert_transform, matrix_from_rotvec,
                                       rotation_error_rad, transform_from_rotation_translation,
                                       translation_error_m)
        from simcalib.streams import PoseStream
        from simcalib.world.sensors import delivered_mask
        fr = world.frames(cam)
        T_cam_body = m.T_cam_body()
        offset_error = transform_from_rotation_translation(     # drawn once per run/camera
            matrix_from_rotvec(rng.normal(0.0, math.radians(m.offset_sigma_deg), 3)),
            rng.normal(0.0, m.offset_sigma_m, 3))
        T_body_cam_believed = invert_transform(T_cam_body) @ offset_error
        T_world_cam = np.asarray(fr.T_world_cam, dtype=np.float64)
        T_world_body = T_world_cam @ T_cam_body
        P = m.marker_points()
        Q = np.einsum("fij,kj->fki", T_world_body[:, :3, :3], P) + T_world_body[:, None, :3, 3]
        noise = rng.normal(0.0, m.marker_sigma_m, Q.shape)     # drawn for every marker
        seen = _seen(Q, T_world_body[:, :3, 2], m, world.config.room.size_m)
        delivered = delivered_mask(fr)
        tracked = seen.sum(axis=1) >= 3
        idx = np.flatnonzero(delivered & tracked)
        T_fit = rigid_fit(P, (Q + noise)[idx], seen[idx].astype(np.float64))
        T = T_fit @ T_body_cam_believed
        gt = T_world_cam[idx]
        drops = {k: int(v) for k, v in (("frame_dropped", (~delivered).sum()),
                                        ("occluded", (delivered & ~tracked).sum())) if v}
        stream = PoseStream(camera=cam, source="mocap", frame_index=idx,
                            timestamp_s=np.asarray(fr.stamp_s, dtype=np.float64)[idx],
                            T_world_cam=T, n_frames=fr.n_frames,
                            info={"markers_seen": seen[idx].sum(axis=1)},
                            drop_reasons=drops)
        err_t = translation_error_m(T, gt)
        return stream, {
            "markers_seen_median": float(np.median(seen.sum(axis=1))),
            "occluded_frames": drops.get("occluded", 0),
            "translation_error_m_median": float(np.median(err_t)) if idx.size else None,
            "rotation_error_deg_median": float(np.degrees(np.median(
                rotation_error_rad(T, gt)))) if idx.size else None,
            "offset_error_m": float(np.linalg.norm(offset_error[:3, 3])),
            "offset_error_deg": float(np.degrees(rotation_error_rad(
                offset_error[None], np.eye(4)[None])[0]))}



register(MocapSource())
