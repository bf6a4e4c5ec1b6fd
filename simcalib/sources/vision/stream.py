"""Visual pose streams: render each camera frame, degrade it, detect markers, solve PnP.

``visual_streams(world, cfg, rng, workers=...)`` renders every frame of both cameras of a
simulated run (:func:`simcalib.world.render_map.render_map`), and in the render workers
(:class:`~simcalib.sources.vision.frame.FrameProcessor`) applies the image realism knobs of
:class:`VisionConfig` (Gaussian defocus blur, Gaussian pixel noise — drawn from a generator
derived per frame from ``rng`` and the (camera, frame) pair, so the worker count never
changes a result), detects ArUco markers and estimates each camera pose from all visible
map markers jointly (:mod:`simcalib.targets.marker_pnp`). A frame without a usable pose is dropped
and counted with its reason (``PoseStream.drop_reasons``; frames the world did not deliver
are not rendered and count as ``frame_dropped``) — never filled in.

Returns ``({camera: PoseStream}, VisualLog)``; the log is plain data for reviewers:
JPEG images of a subsample of frames (what the detector saw), detected ids/corners,
reprojection errors and status of every frame, and timings.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from simcalib.sources.vision import world_cameras
from simcalib.sources.vision.config import VisionConfig
from simcalib.sources.vision.frame import (NOT_DELIVERED, NOT_RENDERED, FrameProcessor,
                                           camera_optics, estimator_map)
from simcalib.streams import PoseStream
from simcalib.targets.markers import MarkerField

__all__ = ["VisualFrame", "VisualLog", "VisualStreamsInterrupted", "rig_entropy_of",
           "visual_streams"]


@dataclass(frozen=True)
class VisualFrame:
    """What happened to one camera frame (plain data).

    ``status``: ``"ok"`` or a drop reason (:data:`simcalib.targets.marker_pnp.DROP_REASONS`);
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
    error (:func:`camera_optics`) and the lighting's phase — are drawn from that number
    too, unless ``rig_entropy`` (the number an earlier call drew, see
    :func:`rig_entropy_of`) is given: then more frames of the *same* rig are measured,
    with fresh per-frame noise.

    ``progress(n_done, n_total)`` (optional) is called as camera frames finish (e.g. a
    progress bar's update; :class:`simcalib.world.render_map.LineProgress` prints a line every N
    frames for non-terminal stderr). On Ctrl-C the render workers stop quietly and
    :class:`VisualStreamsInterrupted` is raised carrying the streams of the frames done.
    """
    cfg = VisionConfig() if cfg is None else cfg
    _check_inputs(world, cfg, rng, progress)
    cameras = tuple(world.camera_names)
    entropy = int(rng.integers(0, 2**63 - 1))
    rig = entropy if rig_entropy is None else int(rig_entropy)
    intr = world_cameras.checked_intrinsics(world, cameras, cfg)
    frames = {cam: world_cameras.camera_frames(world, cam) for cam in cameras}
    eff = cfg.effects()
    optics = camera_optics(cameras, intr, eff, rig)
    proc = FrameProcessor(estimator_map(world.marker_field, eff, rig),
                          {c: intr[c].K for c in cameras},
                          {c: i for i, c in enumerate(cameras)}, cfg, entropy, optics,
                          *world_cameras.board_of(world))
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


def _check_inputs(world, cfg, rng, progress) -> None:
    """Raise TypeError unless ``cfg`` is a VisionConfig, ``rng`` a Generator, ``world`` a World
    and ``progress`` a callable or None (checked before any frame renders)."""
    if not isinstance(cfg, VisionConfig):
        raise TypeError(f"cfg must be a VisionConfig; received {type(cfg).__name__}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    from simcalib.world.render_map import check_progress  # noqa: PLC0415
    check_progress(progress)
    world_cameras.check_world(world)


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
    n_jobs_total = int(sum(world_cameras.delivered(frames[c]).sum() for c in cameras))
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
    from simcalib.world.render_map import FrameJob  # noqa: PLC0415
    in_view = _markers_in_view(world.marker_field, fr.T_world_cam, intr) \
        if cfg.count_occlusion else None
    jobs = []
    for k in np.flatnonzero(world_cameras.delivered(fr)):
        k = int(k)
        t_k = float(fr.time_s[k])
        subs = () if offsets is None else tuple(
            world_cameras.state_at(fr, t_k + o) for o in offsets)
        light = _light_at(t_k, eff, light_phase)
        pts = None
        if in_view is not None:
            pts = _shrunk_corners(world.marker_field, in_view[k])
            occl_cam[k] = int(in_view[k].sum())
        jobs.append(FrameJob(cam, k, world_cameras.row(fr.qpos, k),
                             world_cameras.row(fr.mocap_pos, k),
                             world_cameras.row(fr.mocap_quat_wxyz, k), key=t_k, substates=subs,
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
    from simcalib.world.render_map import RenderInterrupted, render_map  # noqa: PLC0415
    def report(n, _t, _base=n_before):
        progress(_base + n, n_jobs_total)
    sub_progress = report if progress is not None else None
    try:
        results, rtimes = render_map(model, settings, jobs, proc, workers=workers,
                                     progress=sub_progress)
    except RenderInterrupted as exc:
        return [r if r is not None else NOT_RENDERED for r in exc.results], exc.timings, exc
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
    delivered = world_cameras.delivered(fr)
    res: list = [NOT_DELIVERED] * fr.n_frames
    for i, job_k in enumerate(np.flatnonzero(delivered)):
        # a delivered frame without a result: its pass never ran (interrupted before)
        res[int(job_k)] = outs_cam[i] if i < len(outs_cam) else NOT_RENDERED
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
    stamps = world_cameras.stamps(fr)
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


def rig_entropy_of(rng: np.random.Generator) -> int:
    """The number :func:`visual_streams` draws first from ``rng`` (a copy is drawn from:
    ``rng`` is not advanced): pass it as ``rig_entropy`` to measure more frames of the rig
    a call with ``rng`` measured."""
    import copy  # noqa: PLC0415
    return int(copy.deepcopy(rng).integers(0, 2**63 - 1))


def _subframe_offsets(eff):
    from simcalib.sources.vision.camera_effects import subframe_offsets_s  # noqa: PLC0415
    return subframe_offsets_s(eff) if eff.timed else None


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


def _default_workers() -> int:
    from simcalib.world.render_map import default_workers  # noqa: PLC0415
    return default_workers()


