"""One camera frame after rendering: the image the camera delivers (sub-frames mixed,
lens distortion, sensor, JPEG, blur and noise), the markers or the board detected in it,
and the camera pose by PnP with the calibration and the marker map the estimator believes.

:class:`FrameProcessor` is the per-frame function the render workers apply
(:func:`simcalib.world.render_map.render_map`; picklable, deterministic given the frame);
:func:`camera_optics` and :func:`estimator_map` draw, once per run, the calibration and the
map the estimator uses (``vision.intrinsics_error``, ``vision.map_*``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial

import numpy as np

from simcalib.sources.vision.config import VisionConfig
from simcalib.targets.marker_pnp import estimate_camera_pose, undistort_points
from simcalib.targets.markers import Detections, MarkerField, detect_markers, make_detector

__all__ = ["CameraOptics", "FrameOut", "FrameProcessor", "NOT_DELIVERED", "NOT_RENDERED",
           "camera_optics", "estimator_map"]


@dataclass(frozen=True)
class FrameOut:
    status: str
    T_world_cam: np.ndarray | None
    ids: np.ndarray
    corners_px: np.ndarray
    ids_used: np.ndarray
    reproj_rmse_px: float
    ambiguity: float
    jpeg: bytes | None
    detect_s: float
    pnp_s: float


@dataclass(frozen=True)
class CameraOptics:
    """One camera's lens and calibration in a run: ``dist`` the true distortion, ``K_est`` /
    ``dist_est`` the calibration the estimator uses (``vision.intrinsics_error``),
    ``margin_px`` ``(mx, my)`` the render margin of a distorted camera, ``gain_phase``
    the phase of its auto-exposure drift."""
    dist: tuple
    K_est: np.ndarray
    dist_est: np.ndarray
    margin_px: tuple
    gain_phase: float = 0.0


class FrameProcessor:
    """Per-frame work after rendering (runs in render workers; picklable).

    Mixes the sub-frame renders (motion blur, rolling shutter), converts to grey, applies
    lens distortion, the sensor (gain, shot/read noise) and the camera's JPEG, then the
    legacy blur/noise knobs (generator seeded by ``(entropy, camera index, frame index)``),
    detects markers, undistorts their corners with the estimator's calibration, estimates
    the camera pose, and JPEG-encodes the image when the frame is in the log subsample.
    """

    def __init__(self, field: MarkerField, K_by_camera: dict, cam_index: dict, cfg: VisionConfig,
                 entropy: int, optics: dict | None = None, board=None, T_world_board=None):
        self.field = field
        self.board = board                 # a simcalib.targets.boards.BoardConfig, or None
        self.T_world_board = None if board is None else np.asarray(T_world_board, dtype=float)
        self._board_est = None
        self.K_by_camera = {c: np.asarray(K, dtype=np.float64) for c, K in K_by_camera.items()}
        self.cam_index = dict(cam_index)
        self.cfg = cfg
        self.effects = cfg.effects()
        self.entropy = int(entropy)
        self.optics = dict(optics or {})
        self._detector = None
        self._maps: dict = {}

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_detector"] = None  # OpenCV objects do not pickle; rebuilt per process
        state["_board_est"] = None
        state["_maps"] = {}        # remap tables are rebuilt per process (cheap, large)
        return state

    def frame_rng(self, camera: str, frame_index: int) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence(
            self.entropy, spawn_key=(self.cam_index[camera], int(frame_index))))

    def degrade(self, rgb: np.ndarray, camera: str, frame_index: int) -> np.ndarray:
        """Legacy knobs on the grey image: Gaussian blur then Gaussian noise."""
        import cv2  # noqa: PLC0415
        gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY) if rgb.ndim == 3 else rgb
        cfg = self.cfg
        if cfg.blur_sigma_px > 0:
            gray = cv2.GaussianBlur(gray, (0, 0), sigmaX=float(cfg.blur_sigma_px),
                                    sigmaY=float(cfg.blur_sigma_px),
                                    borderType=cv2.BORDER_REPLICATE)
        if cfg.noise_std > 0:
            rng = self.frame_rng(camera, frame_index)
            noise = rng.standard_normal(gray.shape, dtype=np.float32) * np.float32(cfg.noise_std)
            gray = np.clip(gray.astype(np.float32) + noise, 0, 255).round().astype(np.uint8)
        return gray

    def _remap(self, camera: str, gray: np.ndarray) -> np.ndarray:
        import cv2  # noqa: PLC0415
        from simcalib.sources.vision.camera_effects import distortion_maps  # noqa: PLC0415
        opt = self.optics[camera]
        if camera not in self._maps:
            K = self.K_by_camera[camera]
            h = int(round(2 * K[1, 2] + 1))
            w = int(round(2 * K[0, 2] + 1))
            self._maps[camera] = distortion_maps(K, opt.dist, w, h, opt.margin_px)
        mx, my = self._maps[camera]
        return cv2.remap(gray, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def camera_image(self, rendered: np.ndarray, job) -> np.ndarray:
        """The ``(H, W)`` uint8 grey image the camera delivers for one rendered frame
        (``(H', W', 3)`` render or ``(S, H', W', 3)`` sub-frame stack)."""
        import cv2  # noqa: PLC0415
        from simcalib.sources.vision.camera_effects import apply_sensor, combine_subframes, jpeg_roundtrip, row_weights  # noqa: PLC0415,E501
        eff = self.effects
        opt = self.optics.get(job.camera)
        rng = self.frame_rng(job.camera, job.frame_index)
        stack = rendered if rendered.ndim == 4 else rendered[None]
        grays = np.stack([cv2.cvtColor(im, cv2.COLOR_RGB2GRAY) for im in stack])
        distorted = opt is not None and eff.has_distortion
        sensor = eff.read_noise_dn > 0 or eff.shot_noise_dn > 0 or eff.gain_log_std > 0
        if grays.shape[0] == 1 and not distorted and not sensor:
            gray = grays[0]
        else:
            my = opt.margin_px[1] if distorted else 0
            h_out = grays.shape[1] - 2 * my
            w = row_weights(eff, grays.shape[1], first_row=-my, height=h_out) \
                if grays.shape[0] > 1 else np.ones((grays.shape[1], 1))
            img = combine_subframes(grays, w)
            if distorted:
                img = self._remap(job.camera, img)
            t = float(job.key) if job.key is not None else 0.0
            gray = apply_sensor(img, eff, rng, t, opt.gain_phase if opt is not None else 0.0)
        gray = jpeg_roundtrip(gray, eff.jpeg_quality)
        return self.degrade(gray, job.camera, job.frame_index)

    def _jpeg(self, gray: np.ndarray, frame_index: int) -> bytes | None:
        import cv2  # noqa: PLC0415
        cfg = self.cfg
        if cfg.log_every and frame_index % cfg.log_every == 0:
            ok, buf = cv2.imencode(".jpg", gray, [cv2.IMWRITE_JPEG_QUALITY, int(cfg.jpeg_quality)])
            return buf.tobytes() if ok else None
        return None

    def _board_frame(self, rendered: np.ndarray, job) -> FrameOut:
        """A board target: detect the board, PnP on all its corners, and
        ``T_world_cam = T_world_board @ inv(T_cam_board)``."""
        from simcalib.targets.boards import board_pose_estimator  # noqa: PLC0415
        cfg = self.cfg
        if self._board_est is None:
            self._board_est = board_pose_estimator(
                self.board, corner_refinement=cfg.corner_refinement,
                edge_refinement=cfg.edge_refinement, max_reproj_rmse_px=cfg.max_reproj_rmse_px,
                max_point_reproj_px=cfg.max_marker_reproj_px,
                ambiguity_ratio=cfg.ambiguity_ratio)
        gray = self.camera_image(rendered, job)
        K = self.K_by_camera[job.camera]
        opt = self.optics.get(job.camera)
        undistort = None
        if opt is not None:
            K = opt.K_est
            if np.any(opt.dist_est != 0):
                undistort = partial(undistort_points, K=K, dist=opt.dist_est)
        t0 = time.perf_counter()
        pose = self._board_est(gray, K, undistort)
        t1 = time.perf_counter()
        T = None
        if pose.ok:
            from simcalib.geometry import invert_transform  # noqa: PLC0415
            T = self.T_world_board @ invert_transform(pose.T_cam_board)
        return FrameOut(pose.status, T, pose.marker_ids, pose.marker_corners_px,
                         pose.corner_ids, float(pose.reproj_rmse_px), float(pose.ambiguity),
                         self._jpeg(gray, job.frame_index), t1 - t0, 0.0)

    def __call__(self, rendered: np.ndarray, job) -> FrameOut:
        import cv2  # noqa: PLC0415
        if self.board is not None:
            return self._board_frame(rendered, job)
        cfg = self.cfg
        dsettings = cfg.detector_settings(self.field.dictionary)
        if self._detector is None:
            self._detector = make_detector(dsettings)
        gray = self.camera_image(rendered, job)
        t0 = time.perf_counter()
        det = detect_markers(gray, self._detector, dsettings)
        t1 = time.perf_counter()
        K = self.K_by_camera[job.camera]
        opt = self.optics.get(job.camera)
        det_pnp = det
        if opt is not None:
            K = opt.K_est
            if det.n and np.any(opt.dist_est != 0):
                det_pnp = Detections(det.ids, undistort_points(det.corners_px, K, opt.dist_est),
                                     det.n_rejected)
        est = estimate_camera_pose(det_pnp, self.field, K, cfg.pnp_settings())
        t2 = time.perf_counter()
        jpeg = None
        if cfg.log_every and job.frame_index % cfg.log_every == 0:
            ok, buf = cv2.imencode(".jpg", gray, [cv2.IMWRITE_JPEG_QUALITY, int(cfg.jpeg_quality)])
            jpeg = buf.tobytes() if ok else None
        return FrameOut(est.reason, est.T_world_cam if est.ok else None, det.ids,
                         det.corners_px, est.ids_used, float(est.reproj_rmse_px),
                         float(est.ambiguity), jpeg, t1 - t0, t2 - t1)


NOT_RENDERED = FrameOut("not_rendered", None, np.zeros(0, dtype=np.int64), np.zeros((0, 4, 2)),
                          np.zeros(0, dtype=np.int64), float("inf"), float("inf"), None, 0.0, 0.0)


NOT_DELIVERED = FrameOut("frame_dropped", None, np.zeros(0, dtype=np.int64), np.zeros((0, 4, 2)),
                           np.zeros(0, dtype=np.int64), float("inf"), float("inf"), None, 0.0, 0.0)


def camera_optics(cameras, intr: dict, eff, entropy: int) -> dict:
    """Per camera: true distortion, the estimator's (perturbed) calibration, render margin;
    ``{}`` when no effect needs them (the ideal pinhole path)."""
    from simcalib.sources.vision.camera_effects import perturbed_calibration, render_margin_px  # noqa: PLC0415
    if not eff.has_distortion and not any(eff.intrinsics_error) and eff.gain_log_std == 0:
        return {}
    out = {}
    for i, cam in enumerate(cameras):
        K = intr[cam].K
        rng = np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(10**6 + 1 + i,)))
        K_est, d_est = perturbed_calibration(K, eff.distortion, eff, rng)
        out[cam] = CameraOptics(eff.distortion, K_est, d_est,
                                render_margin_px(K, eff.distortion, intr[cam].width,
                                                 intr[cam].height),
                                float(rng.uniform(0, 2 * np.pi)))
    return out


def estimator_map(field: MarkerField, eff, entropy: int) -> MarkerField:
    """The marker map the estimator uses: the true ``field`` or, with a map error, one
    draw of :func:`simcalib.sources.vision.camera_effects.perturbed_map` for the run (both
    cameras)."""
    if not eff.has_map_error:
        return field
    from dataclasses import replace  # noqa: PLC0415

    from simcalib.sources.vision.camera_effects import perturbed_map  # noqa: PLC0415
    rng = np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(10**6 + 500,)))
    return replace(field, T_world_marker=perturbed_map(field.T_world_marker, eff, rng))
