"""Visual pose streams: render each camera frame, degrade it, detect markers, solve PnP.

``visual_streams(world, cfg, rng, workers=...)`` renders every frame of both cameras of a
simulated run (:mod:`simcalib.world.render`), applies the image realism knobs of
:class:`VisionConfig` (Gaussian defocus blur, Gaussian pixel noise — drawn from a generator
derived per frame from ``rng`` and the (camera, frame) pair, so the worker count never
changes a result), detects ArUco markers and estimates each camera pose from all visible
map markers jointly (:mod:`simcalib.targets.markers`). A frame without a usable pose is dropped
and counted with its reason (``PoseStream.drop_reasons``; frames the world did not deliver
are not rendered and count as ``frame_dropped``) — never filled in.

Returns ``({camera: PoseStream}, VisualLog)``; the log is plain data for reviewers:
JPEG images of a subsample of frames (what the detector saw), detected ids/corners,
reprojection errors and status of every frame, and timings.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from simcalib.targets.markers import DROP_REASONS, MarkerField
from simcalib.streams import CameraIntrinsics, PoseStream

__all__ = ["VisionConfig", "VisualFrame", "VisualLog", "VisualStreamsInterrupted", "visual_streams",
           "FrameProcessor", "CalibrationBias", "calibration_sigmas", "calibration_pose_bias"]


from simcalib.sources.vision.config import VisionConfig  # noqa: E402



@dataclass(frozen=True)
class VisualFrame:
    """What happened to one camera frame (plain data).

    ``status``: ``"ok"`` or a drop reason (:data:`simcalib.targets.markers.DROP_REASONS`);
    ``ids`` ``(N,)`` / ``corners_px`` ``(N, 4, 2)``: all detected markers; ``ids_used``: the
    markers of the final pose; ``reproj_rmse_px`` (``inf`` when no pose was fitted);
    ``T_world_cam``: the estimated pose (``None`` when dropped); ``markers_in_view``: map
    markers geometrically in view (inside the image, facing the camera), of which
    ``markers_occluded`` have their line of sight blocked by the robot/cart (-1: not
    counted).
    """
    camera: str
    frame_index: int
    time_s: float
    status: str
    ids: np.ndarray
    corners_px: np.ndarray
    ids_used: np.ndarray
    reproj_rmse_px: float
    ambiguity: float
    T_world_cam: np.ndarray | None
    markers_in_view: int = -1
    markers_occluded: int = -1


@dataclass(frozen=True)
class VisualLog:
    """Reviewer's record of the visual stage (plain data, no rerun).

    ``frames[camera]``: one :class:`VisualFrame` per simulated frame, in order;
    ``images_jpeg[camera][frame_index]``: JPEG bytes of the grey image the detector saw
    (every ``config.log_every``-th frame); ``intrinsics[camera]``: the camera model used;
    ``timing``: wall-clock seconds and per-stage means (not deterministic).
    """
    config: VisionConfig
    intrinsics: dict
    frames: dict
    images_jpeg: dict
    timing: dict

    def image(self, camera: str, frame_index: int) -> np.ndarray:
        """Decode a logged image to a ``(H, W)`` uint8 array."""
        try:
            blob = self.images_jpeg[camera][int(frame_index)]
        except KeyError:
            have = {c: sorted(v)[:10] for c, v in self.images_jpeg.items()}
            raise KeyError(f"no logged image for camera {camera!r} frame {frame_index}; "
                           f"logged (first ten per camera): {have}") from None
        import cv2  # noqa: PLC0415
        return cv2.imdecode(np.frombuffer(blob, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)

    def reproj_rmse_px(self, camera: str) -> np.ndarray:
        """Reprojection RMSE of the frames with a pose (``(n_used,)``)."""
        return np.array([f.reproj_rmse_px for f in self.frames[camera] if f.status == "ok"])

    def summary(self) -> dict:
        """Per-camera counts and error statistics as plain Python numbers."""
        out: dict[str, Any] = {}
        for cam, frames in self.frames.items():
            rm = self.reproj_rmse_px(cam)
            reasons: dict[str, int] = {}
            for f in frames:
                if f.status != "ok":
                    reasons[f.status] = reasons.get(f.status, 0) + 1
            out[cam] = {
                "n_frames": len(frames),
                "n_used": int(rm.size),
                "drop_reasons": reasons,
                "median_markers_used": float(np.median([f.ids_used.size for f in frames
                                                        if f.status == "ok"])) if rm.size else 0.0,
                "median_reproj_rmse_px": float(np.median(rm)) if rm.size else None,
                "n_images": len(self.images_jpeg.get(cam, {})),
                "markers_in_view": int(sum(max(f.markers_in_view, 0) for f in frames)),
                "markers_occluded": int(sum(max(f.markers_occluded, 0) for f in frames)),
                "frames_with_occlusion": int(sum(f.markers_occluded > 0 for f in frames)),
            }
        return out


@dataclass(frozen=True)
class _FrameOut:
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

    def _board_frame(self, rendered: np.ndarray, job) -> _FrameOut:
        """A board target: detect the board, PnP on all its corners, and
        ``T_world_cam = T_world_board @ inv(T_cam_board)``."""
        from simcalib.targets.boards import board_pose_estimator  # noqa: PLC0415
        from simcalib.targets.markers import undistort_points  # noqa: PLC0415
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
        return _FrameOut(pose.status, T, pose.marker_ids, pose.marker_corners_px,
                         pose.corner_ids, float(pose.reproj_rmse_px), float(pose.ambiguity),
                         self._jpeg(gray, job.frame_index), t1 - t0, 0.0)

    def __call__(self, rendered: np.ndarray, job) -> _FrameOut:
        import cv2  # noqa: PLC0415
        from simcalib.targets.markers import undistort_points  # noqa: PLC0415
        from simcalib.targets.markers import Detections, detect_markers, estimate_camera_pose, make_detector  # noqa: PLC0415,E501
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
        return _FrameOut(est.reason, est.T_world_cam if est.ok else None, det.ids,
                         det.corners_px, est.ids_used, float(est.reproj_rmse_px),
                         float(est.ambiguity), jpeg, t1 - t0, t2 - t1)


def _camera_intrinsics(world, camera: str, cfg: VisionConfig) -> tuple[CameraIntrinsics, float]:
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


def _check_model_fovy(model, camera: str, fovy_deg: float, base: CameraIntrinsics) -> None:
    """The world's intrinsics must be the pinhole MuJoCo renders (else poses are biased)."""
    from simcalib.world.render import import_mujoco  # noqa: PLC0415
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


#: Largest allowed difference between the rendered camera pose and the world's ground truth.
RENDER_POSE_TOL_M = 1e-6
RENDER_POSE_TOL_RAD = 1e-6


def _check_rendered_poses(jobs, timings, frames) -> None:
    """The state a frame is rendered from must put the camera at its ground-truth pose
    (else the visual stream would be compared against the wrong truth)."""
    from simcalib.geometry import rotation_error_rad, translation_error_m  # noqa: PLC0415
    if not jobs:
        return
    T_r = np.stack([t.T_world_cam for t in timings])
    T_gt = np.stack([frames[j.camera].T_world_cam[j.frame_index] for j in jobs])
    e_t = translation_error_m(T_r, T_gt)
    e_r = rotation_error_rad(T_r, T_gt)
    bad = np.flatnonzero((e_t > RENDER_POSE_TOL_M) | (e_r > RENDER_POSE_TOL_RAD))
    if bad.size:
        i = int(bad[0])
        raise ValueError(
            f"the MuJoCo state of {jobs[i].camera} frame {jobs[i].frame_index} puts the camera "
            f"{e_t[i]:.3g} m / {e_r[i]:.3g} rad away from the trajectory's T_world_cam "
            f"({bad.size} of {len(jobs)} frames differ; allowed {RENDER_POSE_TOL_M} m / "
            f"{RENDER_POSE_TOL_RAD} rad): qpos/mocap state and ground truth disagree")


def _check_world(world) -> None:
    for name in ("model", "camera_names", "intrinsics", "marker_field", "trajectory"):
        if not hasattr(world, name):
            raise TypeError(f"world must provide .{name} (a simcalib.world.World); received "
                            f"{type(world).__name__} without it")
    if not isinstance(world.marker_field, MarkerField):
        raise TypeError("world.marker_field must be a simcalib.targets.markers.MarkerField; received "
                        f"{type(world.marker_field).__name__}")


def _camera_frames(world, camera: str):
    traj = world.trajectory
    for attr in ("cam_a", "cam_b"):
        fr = getattr(traj, attr, None)
        if fr is not None and fr.camera == camera:
            return fr
    names = [getattr(getattr(traj, a, None), "camera", None) for a in ("cam_a", "cam_b")]
    raise ValueError(f"camera {camera!r} has no frames in world.trajectory; it has {names}")


class VisualStreamsInterrupted(KeyboardInterrupt):
    """Interrupt (Ctrl-C) during :func:`visual_streams`, carrying what was rendered:
    ``streams`` / ``log`` as :func:`visual_streams` returns them, built from the frames
    finished before the interrupt (the others count as drop reason ``not_rendered``);
    ``n_done`` / ``n_total`` camera frames."""

    def __init__(self, streams: dict, log: "VisualLog", n_done: int, n_total: int):
        super().__init__(f"visual streams interrupted after {n_done} of {n_total} frames")
        self.streams, self.log, self.n_done, self.n_total = streams, log, n_done, n_total


def visual_streams(world, cfg: VisionConfig | None = None, rng: np.random.Generator | None = None,
                   workers: int | None = None, progress=None,
                   rig_entropy: int | None = None) -> tuple[dict, VisualLog]:
    """Visual ``PoseStream`` of every camera of ``world`` and the :class:`VisualLog`.

    ``rng`` (required ``numpy.random.Generator``) seeds the image noise: one number is
    drawn from it and every frame derives its own generator from that number and its
    (camera, frame) pair, so results do not depend on ``workers`` (``None``: all usable
    cores; ``1``: render in this process). Poses are ``T_world_cam`` in the marker map's
    frame (the MuJoCo world); ``info`` holds ``n_markers``, ``reproj_rmse_px`` and
    ``ambiguity`` per pose; ``drop_reasons`` counts dropped frames by reason.

    The rig's fixed errors — the marker map's survey error, each camera's calibration
    error (:func:`_camera_optics`) and the lighting's phase — are drawn from that number
    too, unless ``rig_entropy`` (the number an earlier call drew, see
    :func:`rig_entropy_of`) is given: then more frames of the *same* rig are measured,
    with fresh per-frame noise.

    ``progress(n_done, n_total)`` (optional) is called as camera frames finish (e.g. a
    progress bar's update; :class:`simcalib.world.render.LineProgress` prints a line every N
    frames for non-terminal stderr). On Ctrl-C the render workers stop quietly and
    :class:`VisualStreamsInterrupted` is raised carrying the streams of the frames done.
    """
    cfg = VisionConfig() if cfg is None else cfg
    _check_inputs(world, cfg, rng, progress)
    cameras = tuple(world.camera_names)
    entropy = int(rng.integers(0, 2**63 - 1))
    rig = entropy if rig_entropy is None else int(rig_entropy)
    intr = _checked_intrinsics(world, cameras, cfg)
    frames = {cam: _camera_frames(world, cam) for cam in cameras}
    eff = cfg.effects()
    optics = _camera_optics(cameras, intr, eff, rig)
    proc = FrameProcessor(_estimator_map(world.marker_field, eff, rig),
                          {c: intr[c].K for c in cameras},
                          {c: i for i, c in enumerate(cameras)}, cfg, entropy, optics,
                          *_board_of(world))
    t_start = time.perf_counter()
    outs, occl, timings, n_jobs_total, interrupted = _render_all(
        world, cameras, cfg, eff, frames, intr, optics, proc, rig, workers, progress)
    wall_s = time.perf_counter() - t_start
    streams, log_frames, log_images = {}, {}, {}
    for cam in cameras:
        streams[cam], log_frames[cam], log_images[cam] = _camera_outputs(
            cam, frames[cam], outs.get(cam, []), occl[cam])
    timing = _timing_report(outs, timings, wall_s, workers)
    log = VisualLog(cfg, intr, log_frames, log_images, timing)
    if interrupted is not None:
        raise VisualStreamsInterrupted(streams, log, len(timings), n_jobs_total) from None
    return streams, log


def _board_of(world) -> tuple:
    """``(BoardConfig, T_world_board)`` of a world whose target is a board, else (None, None)."""
    scene = getattr(world, "scene", None)
    return getattr(scene, "board", None), getattr(scene, "T_world_board", None)


def _check_inputs(world, cfg, rng, progress) -> None:
    """Raise TypeError unless ``cfg`` is a VisionConfig, ``rng`` a Generator, ``world`` a World
    and ``progress`` a callable or None (checked before any frame renders)."""
    if not isinstance(cfg, VisionConfig):
        raise TypeError(f"cfg must be a VisionConfig; received {type(cfg).__name__}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    from simcalib.world.render import check_progress  # noqa: PLC0415
    check_progress(progress)
    _check_world(world)


def _checked_intrinsics(world, cameras, cfg: VisionConfig) -> dict:
    """Each camera's intrinsics under ``cfg``, checked against the model if fovy is not set."""
    intr = {}
    for cam in cameras:
        intr[cam], fovy = _camera_intrinsics(world, cam, cfg)
        if cfg.fovy_deg is None:
            _check_model_fovy(world.model, cam, fovy, world.intrinsics[cam])
    return intr


def _render_all(world, cameras, cfg: VisionConfig, eff, frames: dict, intr: dict, optics: dict,
                proc: FrameProcessor, rig: int, workers, progress) -> tuple:
    """Render and process every delivered frame, one pass per image size, until an interrupt."""
    light_phase = float(np.random.default_rng(np.random.SeedSequence(
        rig, spawn_key=(10**6,))).uniform(0, 2 * np.pi))
    offsets = _subframe_offsets(eff)
    sizes = _render_sizes(cameras, intr, optics)
    outs: dict[str, list] = {}
    occl: dict[str, dict] = {c: {} for c in cameras}
    timings: list = []
    n_jobs_total = int(sum(_delivered(frames[c]).sum() for c in cameras))
    n_before = 0
    interrupted = None
    for (w, h), cams in sizes.items():
        settings = _render_settings(w, h, cams, intr, cfg)
        jobs = []
        for cam in cams:
            jobs += _camera_jobs(world, cam, frames[cam], intr[cam], cfg, eff, offsets,
                                 light_phase, occl[cam])
        results, rtimes, interrupted = _render_pass(world.model, settings, jobs, proc, workers,
                                                    progress, n_before, n_jobs_total)
        done = [i for i, t in enumerate(rtimes) if t is not None]
        timings += [rtimes[i] for i in done]
        _record_occlusion(occl, jobs, rtimes, done)
        _check_rendered_poses([jobs[i] for i in done], [rtimes[i] for i in done], frames)
        for job, res in zip(jobs, results):
            outs.setdefault(job.camera, []).append(res)
        n_before += len(jobs)
        if interrupted is not None:
            break
    return outs, occl, timings, n_jobs_total, interrupted


def _render_sizes(cameras, intr: dict, optics: dict) -> dict:
    """Cameras grouped by rendered image size (image plus distortion margin), in camera order."""
    sizes: dict[tuple[int, int], list[str]] = {}
    for cam in cameras:
        mx, my = optics[cam].margin_px if optics else (0, 0)
        sizes.setdefault((intr[cam].width + 2 * mx, intr[cam].height + 2 * my), []).append(cam)
    return sizes


def _render_settings(w: int, h: int, cams, intr: dict, cfg: VisionConfig):
    """RenderSettings of one image size, with fovy overridden where the model's does not fit."""
    from simcalib.world.render import RenderSettings  # noqa: PLC0415
    fov_over = {}
    for c in cams:
        if cfg.fovy_deg is not None or (w, h) != (intr[c].width, intr[c].height):
            fov_over[c] = float(np.rad2deg(2 * np.arctan(h / (2 * intr[c].fy))))
    return RenderSettings(width=w, height=h, msaa_samples=cfg.msaa_samples,
                          fovy_deg=fov_over)


def _camera_jobs(world, cam: str, fr, intr, cfg: VisionConfig, eff, offsets, light_phase: float,
                 occl_cam: dict) -> list:
    """FrameJobs of one camera's delivered frames; stores markers-in-view counts in ``occl_cam``."""
    from simcalib.world.render import FrameJob  # noqa: PLC0415
    in_view = _markers_in_view(world.marker_field, fr.T_world_cam, intr) \
        if cfg.count_occlusion else None
    jobs = []
    for k in np.flatnonzero(_delivered(fr)):
        k = int(k)
        t_k = float(fr.time_s[k])
        subs = () if offsets is None else tuple(
            _state_at(fr, t_k + o) for o in offsets)
        light = _light_at(t_k, eff, light_phase)
        pts = None
        if in_view is not None:
            pts = _shrunk_corners(world.marker_field, in_view[k])
            occl_cam[k] = int(in_view[k].sum())
        jobs.append(FrameJob(cam, k, _row(fr.qpos, k), _row(fr.mocap_pos, k),
                             _row(fr.mocap_quat_wxyz, k), key=t_k, substates=subs,
                             light=light, check_points=pts))
    return jobs


def _light_at(t_k: float, eff, light_phase: float):
    """Scene light state at time ``t_k`` (``None`` when the effects keep the lights constant)."""
    if eff.light_variation > 0 or eff.light_motion_deg > 0:
        from simcalib.sources.vision.camera_effects import light_state  # noqa: PLC0415
        return light_state(t_k, eff, light_phase,
                           float(np.sin(2 * np.pi * 3.7 * t_k + light_phase)))
    return None


def _render_pass(model, settings, jobs: list, proc: FrameProcessor, workers, progress,
                 n_before: int, n_jobs_total: int) -> tuple:
    """Render one pass: ``(results, timings, RenderInterrupted or None)``."""
    from simcalib.world.render import RenderInterrupted, render_map  # noqa: PLC0415
    def report(n, _t, _base=n_before):
        progress(_base + n, n_jobs_total)
    sub_progress = report if progress is not None else None
    try:
        results, rtimes = render_map(model, settings, jobs, proc, workers=workers,
                                     progress=sub_progress)
    except RenderInterrupted as exc:
        return [r if r is not None else _NOT_RENDERED for r in exc.results], exc.timings, exc
    return results, rtimes, None


def _record_occlusion(occl: dict, jobs: list, rtimes: list, done: list) -> None:
    """Pair each rendered frame's markers-in-view count with its count of occluded markers."""
    for i in done:
        if rtimes[i].occluded is not None:
            n_occ = int(rtimes[i].occluded.reshape(-1, 4).any(axis=1).sum())
            occl[jobs[i].camera][jobs[i].frame_index] = (
                occl[jobs[i].camera][jobs[i].frame_index], n_occ)


def _camera_outputs(cam: str, fr, outs_cam: list, occl_cam: dict) -> tuple:
    """One camera's ``(PoseStream, VisualFrame records, logged JPEGs)`` from its frame results."""
    delivered = _delivered(fr)
    res: list = [_NOT_DELIVERED] * fr.n_frames
    for i, job_k in enumerate(np.flatnonzero(delivered)):
        # a delivered frame without a result: its pass never ran (interrupted before)
        res[int(job_k)] = outs_cam[i] if i < len(outs_cam) else _NOT_RENDERED
    stream = _pose_stream(cam, fr, res)
    vis = {k: v for k, v in occl_cam.items() if isinstance(v, tuple)}
    log_frames = tuple(
        VisualFrame(cam, k, float(fr.time_s[k]), r.status, r.ids, r.corners_px, r.ids_used,
                    r.reproj_rmse_px, r.ambiguity, r.T_world_cam,
                    *vis.get(k, (-1, -1)))
        for k, r in enumerate(res))
    log_images = {k: r.jpeg for k, r in enumerate(res) if r.jpeg is not None}
    return stream, log_frames, log_images


def _pose_stream(cam: str, fr, res: list) -> PoseStream:
    """The visual PoseStream of one camera's per-frame results (drops counted by reason)."""
    stamps = _stamps(fr)
    ok = np.array([r.status == "ok" for r in res], dtype=bool)
    idx = np.flatnonzero(ok)
    reasons: dict[str, int] = {}
    for r in res:
        if r.status != "ok":
            reasons[r.status] = reasons.get(r.status, 0) + 1
    T = np.stack([res[i].T_world_cam for i in idx]) if idx.size else np.zeros((0, 4, 4))
    return PoseStream(
        camera=cam, source="visual", frame_index=idx.astype(np.int64),
        timestamp_s=stamps[idx] if stamps.size else np.zeros(0), T_world_cam=T,
        n_frames=fr.n_frames,
        info={"n_markers": np.array([res[i].ids_used.size for i in idx], dtype=np.int64),
              "reproj_rmse_px": np.array([res[i].reproj_rmse_px for i in idx]),
              "ambiguity": np.array([res[i].ambiguity for i in idx])},
        drop_reasons=reasons)


def _timing_report(outs: dict, timings: list, wall_s: float, workers) -> dict:
    """The log's timing: wall-clock seconds, frame counts and per-stage means."""
    n_total = sum(len(v) for v in outs.values())
    all_res = [r for v in outs.values() for r in v]
    return {
        "wall_s": wall_s,
        "camera_frames": n_total,
        "frames_per_s": n_total / wall_s if wall_s > 0 else float("inf"),
        "workers": workers if workers is not None else _default_workers(),
        "processes": len({t.pid for t in timings}),
        "render_ms_mean": 1e3 * float(np.mean([t.render_s for t in timings])) if timings else 0.0,
        "frame_ms_mean": 1e3 * float(np.mean([t.total_s for t in timings])) if timings else 0.0,
        "cpu_ms_per_frame": 1e3 * float(np.mean([t.cpu_s for t in timings])) if timings else 0.0,
        "detect_ms_mean": 1e3 * float(np.mean([r.detect_s for r in all_res])) if all_res else 0.0,
        "pnp_ms_mean": 1e3 * float(np.mean([r.pnp_s for r in all_res])) if all_res else 0.0,
    }


def _camera_optics(cameras, intr: dict, eff, entropy: int) -> dict:
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


@dataclass(frozen=True, eq=False)
class CalibrationBias:
    """The run-constant pose error of one camera that its calibration error causes
    (:func:`calibration_pose_bias`): ``covariance`` (6x6, of ``(rotvec rad, translation
    m)`` right-multiplied in the camera frame: ``T_world_cam measured = T_world_cam N``),
    ``jacobian`` (6, 8) the pose error per 1-sigma of each parameter of
    :data:`simcalib.targets.markers.INTRINSICS_PARAMETERS`, ``sigmas`` (8,) those 1-sigmas,
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
        from simcalib.targets.markers import INTRINSICS_PARAMETERS  # noqa: PLC0415
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
    """1-sigma (8,) of the calibration parameters (:data:`simcalib.targets.markers.
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
    :func:`simcalib.targets.markers.intrinsics_pose_sensitivity`; ``covariance = J J^T`` plus the
    marker-map term (``vision.map_position_std_m`` / ``map_rotation_std_deg``, the map's
    survey accuracy: :func:`simcalib.targets.markers.map_pose_covariance`). The two cameras' map
    terms are correlated where they see the same markers; that cross term is not kept.
    Empty when the configuration has neither a calibration nor a map error."""
    from simcalib.targets.markers import intrinsics_pose_sensitivity, map_pose_covariance  # noqa: PLC0415
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
        intr, _ = _camera_intrinsics(world, cam, cfg)
        fr = _camera_frames(world, cam)
        idx = np.flatnonzero(_delivered(fr))
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
    ``map_rotation_std_deg``, the survey's accuracy; :func:`simcalib.targets.markers.
    map_pose_jacobians`), then the 8 calibration parameters (``vision.intrinsics_error`` as
    1-sigma, :func:`calibration_sigmas`; :func:`simcalib.targets.markers.intrinsics_pose_jacobians`).
    The map columns are the same parameters for every camera of the world (their errors
    are shared where the cameras see the same markers); each camera's calibration is its
    own. First order, linearised at the given poses with the markers each pose rests on:
    ``visible`` (F, M) bool (e.g. the ids the PnP used, :attr:`VisualFrame.ids_used`), by
    default those the layout makes fully visible there in the camera's distorted image
    (:func:`simcalib.world.layout.visible_markers` with the lens distortion). Nothing is
    rendered."""
    from simcalib.targets.markers import (check_camera_poses, intrinsics_pose_jacobians,  # noqa: PLC0415
                          map_error_variances, map_pose_jacobians)
    cfg = VisionConfig() if cfg is None else cfg
    if not isinstance(cfg, VisionConfig):
        raise TypeError(f"cfg must be a VisionConfig; received {type(cfg).__name__}")
    T = check_camera_poses(T_world_cam)
    eff = cfg.effects()
    intr, _ = _camera_intrinsics(world, camera, cfg)
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
    board, T_wb = _board_of(world)
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


def rig_entropy_of(rng: np.random.Generator) -> int:
    """The number :func:`visual_streams` draws first from ``rng`` (a copy is drawn from:
    ``rng`` is not advanced): pass it as ``rig_entropy`` to measure more frames of the rig
    a call with ``rng`` measured."""
    import copy  # noqa: PLC0415
    return int(copy.deepcopy(rng).integers(0, 2**63 - 1))


def _estimator_map(field: MarkerField, eff, entropy: int) -> MarkerField:
    """The marker map the estimator uses: the true ``field`` or, with a map error, one
    draw of :func:`simcalib.sources.vision.camera_effects.perturbed_map` for the run (both cameras)."""
    if not eff.has_map_error:
        return field
    from dataclasses import replace  # noqa: PLC0415

    from simcalib.sources.vision.camera_effects import perturbed_map  # noqa: PLC0415
    rng = np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(10**6 + 500,)))
    return replace(field, T_world_marker=perturbed_map(field.T_world_marker, eff, rng))


def _subframe_offsets(eff):
    from simcalib.sources.vision.camera_effects import subframe_offsets_s  # noqa: PLC0415
    return subframe_offsets_s(eff) if eff.timed else None


def _state_at(fr, t: float) -> tuple:
    """Raw MuJoCo state ``(qpos, mocap_pos, mocap_quat_wxyz)`` at time ``t``, linearly
    interpolated between the camera's frames (quaternions: normalised lerp in one
    hemisphere); outside the frames, extrapolated from the nearest pair."""
    ts = np.asarray(fr.time_s, dtype=np.float64)
    n = ts.size
    if n == 1:
        return (_row(fr.qpos, 0), _row(fr.mocap_pos, 0), _row(fr.mocap_quat_wxyz, 0))
    i = int(np.clip(np.searchsorted(ts, t) - 1, 0, n - 2))
    dt = ts[i + 1] - ts[i]
    a = (t - ts[i]) / dt if dt > 0 else 0.0

    def lerp(arr):
        r0, r1 = _row(arr, i), _row(arr, i + 1)
        return None if r0 is None else (1 - a) * r0 + a * r1

    q0, q1 = _row(fr.mocap_quat_wxyz, i), _row(fr.mocap_quat_wxyz, i + 1)
    q = None
    if q0 is not None:
        sign = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -1.0, 1.0)
        q = (1 - a) * q0 + a * sign * q1
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return (lerp(fr.qpos), lerp(fr.mocap_pos), q)


def _markers_in_view(field: MarkerField, T_world_cam: np.ndarray, intr) -> np.ndarray:
    """``(F, M)`` markers geometrically in view (simcalib.world.layout.visible_markers
    with no minimum size: inside the image, in front, facing within 80 deg)."""
    from simcalib.world.layout import visible_markers  # noqa: PLC0415
    return visible_markers(field, T_world_cam, intr, min_side_px=0.0, max_view_angle_deg=80.0)


def _shrunk_corners(field: MarkerField, mask: np.ndarray) -> np.ndarray:
    """Corners of the markers in ``mask`` pulled 5 % towards their centre, ``(4 n, 3)``
    (rays to the exact corners graze the marker's own edge)."""
    c = field.corners_world()[np.asarray(mask, dtype=bool)]
    centre = c.mean(axis=1, keepdims=True)
    return (centre + 0.95 * (c - centre)).reshape(-1, 3)


_NOT_RENDERED = _FrameOut("not_rendered", None, np.zeros(0, dtype=np.int64), np.zeros((0, 4, 2)),
                          np.zeros(0, dtype=np.int64), float("inf"), float("inf"), None, 0.0, 0.0)
_NOT_DELIVERED = _FrameOut("frame_dropped", None, np.zeros(0, dtype=np.int64), np.zeros((0, 4, 2)),
                           np.zeros(0, dtype=np.int64), float("inf"), float("inf"), None, 0.0, 0.0)


def _delivered(frames) -> np.ndarray:
    """Frames the camera delivered (world's ``delivered`` record; all when absent)."""
    mask = getattr(frames, "delivered", None)
    if mask is None:
        return np.ones(frames.n_frames, dtype=bool)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (frames.n_frames,):
        raise ValueError(f"frames.delivered must have shape ({frames.n_frames},); received "
                         f"{mask.shape}")
    return mask


def _stamps(frames) -> np.ndarray:
    """The camera's reported timestamps (``stamp_s`` when the world provides them)."""
    s = getattr(frames, "stamp_s", None)
    return np.asarray(frames.time_s if s is None else s, dtype=np.float64)


def _default_workers() -> int:
    from simcalib.world.render import default_workers  # noqa: PLC0415
    return default_workers()


def _row(arr, k):
    if arr is None:
        return None
    a = np.asarray(arr)
    if a.size == 0:
        return None
    return a[k]


# Re-exported for callers that want to explain a drop reason.
DROP_REASON_TEXT = dict(DROP_REASONS)
