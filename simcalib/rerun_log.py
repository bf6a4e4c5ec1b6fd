"""ALL rerun code of simcalib: the run recording (``recording.rrd``) and its blueprint.

Headless: a :class:`rerun.RecordingStream` saved straight to a file (no viewer), wall-clock
log time disabled; application id ``simcalib``, a fresh recording id per run (two runs
opened together stay apart). Open it with ``rerun recording.rrd``.

The pipeline's stages never call rerun: after each stage the run loop hands the state to
:meth:`RunRecorder.record_stage`, the ONE place that decides what a stage's results look
like in the recording (``world``: markers; ``streams``: trajectories, cameras, images with
the detections of the same frames; ``solvers``: the successful estimates — a failed
solver is never drawn; ``evaluation``: pose-source errors; ``reports``: the summary).

Entity layout (timeline ``frame`` = simulated frame index, plus ``sim_time``):

* ``world/markers`` — the marker field (thin boxes labelled with their ids), static.
* ``world/trajectories/<cam>/ground_truth`` and ``.../<source>`` — paths, static.
* ``world/<cam>`` — the camera's true pose per frame; ``world/<cam>/image`` its pinhole,
  the rendered (JPEG) image and ``world/<cam>/image/corners`` the detected marker corners.
* ``world/cam_a/estimates/<solver>`` — each solver's estimate of camera b, placed with
  ``X_est`` relative to the true camera a, so it sits beside the true ``world/cam_b``
  (``world/cam_a/true_cam_b`` is the same with the true X).
* ``errors/rotation_deg``, ``errors/translation_cm`` — per-solver bar charts (order in
  ``errors/legend``); ``errors/<solver>/...`` the same as scalars.
* ``pose_error/<cam>/rotation_deg|translation_mm`` — per-frame pose-source error series.
* ``convergence/<rotation_deg|translation_cm>/<solver>/<error|sigma>`` — error and
  predicted 1-sigma against the number of motions used (timeline ``motions``; issue 9).
* ``summary`` — the console table as text.
"""

from __future__ import annotations

import re
import uuid
from pathlib import Path

import numpy as np

from simcalib.geometry import quat_from_matrix

__all__ = ["RunRecorder", "default_blueprint", "entity_name"]


def entity_name(label: str) -> str:
    """Entity-path-safe name of a solver label (``dqopt+prior`` -> ``dqopt_prior``)."""
    return re.sub(r"[^A-Za-z0-9_]", "_", label)

_COLORS = {"cam_a": (230, 120, 30), "cam_b": (40, 140, 230)}
_SOLVER_COLORS = [(220, 50, 50), (50, 170, 80), (150, 80, 200), (240, 180, 0),
                  (0, 170, 190), (200, 100, 150), (120, 120, 120), (90, 60, 20)]


def default_blueprint(cameras=("cam_a", "cam_b")):
    """The layout the recording opens on: 3D world left; camera images, pose-error series,
    per-solver error bars and the summary right; ``frame`` timeline."""
    import rerun.blueprint as rrb
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name="world (true: cam_b; estimates beside it)"),
            rrb.Vertical(
                rrb.Horizontal(*[rrb.Spatial2DView(origin=f"world/{c}/image", name=c)
                                 for c in cameras]),
                rrb.TimeSeriesView(origin="pose_error", name="pose-source error per frame"),
                rrb.Horizontal(
                    rrb.BarChartView(origin="errors/rotation_deg", name="rotation error [deg]"),
                    rrb.BarChartView(origin="errors/translation_cm",
                                     name="translation error [cm]"),
                    rrb.TextDocumentView(origin="errors/legend", name="solvers"),
                ),
                rrb.TextDocumentView(origin="summary", name="summary"),
                row_shares=[3, 2, 2, 2],
            ),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline="frame"),
        collapse_panels=True,
    )


class RunRecorder:
    """Writes one run's recording; every ``log_*`` method is safe to call once per stage.

    ``close()`` flushes and finalises the file (also after an interrupt, so the partial
    recording stays readable).
    """

    def __init__(self, path: Path, cfg):
        import rerun as rr
        self.path = Path(path)
        self.cfg = cfg
        self.recording_id = str(uuid.uuid4())   # unique per run; the application id is shared
        self.rec = rr.RecordingStream("simcalib", recording_id=self.recording_id,
                                      send_properties=False)
        self.rec.set_log_time_enabled(False) if hasattr(self.rec, "set_log_time_enabled") \
            else None
        self.rec.save(str(self.path), default_blueprint=default_blueprint())
        self._closed = False
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    # ------------------------------------------------------------- dispatch
    def record_stage(self, stage: str, st) -> None:
        """Log what ``stage`` produced (``st``: :class:`simcalib.pipeline.RunState`)."""
        truth = st.truth
        if stage == "world":
            self.log_world(truth.marker_field)
        elif stage == "streams":
            from simcalib.sources import get_source
            measured = {cam: s for cam, s in st.measured.items()
                        if not get_source(st.camera_sources[cam]).info.exact}
            self.log_trajectories(dict(truth.streams), measured, truth.X_true)
            if truth.intrinsics:
                logs = [log for name, log in st.source_logs.items()   # a rendering source's
                        if log is not None and get_source(name).info.renders]
                self.log_cameras(dict(truth.intrinsics), dict(truth.streams),
                                 logs[0] if logs else None)
        elif stage == "solvers":
            self.log_estimates(st.solvers, truth.X_true, dict(truth.streams))
            log_convergence(self.rec, st.solvers)
        elif stage == "evaluation":
            self.log_pose_errors(st.pose_errors)
        elif stage == "reports":
            self.log_summary(st.summary)

    # ------------------------------------------------------------------ world
    def log_world(self, marker_field) -> None:
        import rerun as rr
        if marker_field is None or len(getattr(marker_field, "ids", ())) == 0:
            return
        T = np.asarray(marker_field.T_world_marker)
        h = 0.5 * float(marker_field.side_m)
        self.rec.log("world/markers", rr.Boxes3D(
            centers=T[:, :3, 3], half_sizes=np.tile([h, h, 0.002], (T.shape[0], 1)),
            quaternions=quat_from_matrix(T[:, :3, :3]),
            colors=(40, 40, 40), fill_mode=rr.components.FillMode.Solid,
            labels=[str(int(i)) for i in marker_field.ids]), static=True)

    # ----------------------------------------------------------- trajectories
    def log_trajectories(self, gt: dict, source: dict, X_true) -> None:
        import rerun as rr
        for cam, s in gt.items():
            color = _COLORS.get(cam, (200, 200, 200))
            T = np.asarray(s.T_world_cam)
            self.rec.log(f"world/trajectories/{cam}/ground_truth",
                         rr.LineStrips3D([T[:, :3, 3]], colors=color, radii=0.004),
                         static=True)
            frames = np.asarray(s.frame_index, dtype=np.int64)
            self.rec.send_columns(
                f"world/{cam}",
                indexes=[rr.TimeColumn("frame", sequence=frames),
                         rr.TimeColumn("sim_time", duration=np.asarray(s.timestamp_s,
                                                                        dtype=np.float64))],
                columns=rr.Transform3D.columns(translation=T[:, :3, 3],
                                               mat3x3=T[:, :3, :3]))
            self.rec.log(f"world/{cam}/axes", rr.TransformAxes3D(0.08), static=True)
        for cam, s in source.items():
            color = tuple(int(0.55 * c) for c in _COLORS.get(cam, (200, 200, 200)))
            T = np.asarray(s.T_world_cam)
            if T.shape[0] == 0:
                continue
            self.rec.log(f"world/trajectories/{cam}/{s.source}",
                         rr.Points3D(T[:, :3, 3], colors=color, radii=0.006), static=True)
        if X_true is not None:
            self._log_pose("world/cam_a/true_cam_b", np.asarray(X_true), static=True)
            self.rec.log("world/cam_a/true_cam_b", rr.TransformAxes3D(0.1), static=True)

    def _log_pose(self, entity: str, T: np.ndarray, static: bool = False) -> None:
        import rerun as rr
        self.rec.log(entity, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                     static=static)

    # ---------------------------------------------------------------- cameras
    def log_cameras(self, intrinsics: dict, gt: dict, visual_log) -> None:
        """Pinholes of both cameras, and (aruco source) the logged images and corners."""
        import rerun as rr
        intrinsics = dict(getattr(visual_log, "intrinsics", None) or intrinsics or {})
        for cam, K in intrinsics.items():
            self.rec.log(f"world/{cam}/image",
                         rr.Pinhole(image_from_camera=np.asarray(K.K),
                                    resolution=[K.width, K.height],
                                    image_plane_distance=0.15), static=True)
        if visual_log is None:
            return
        for cam, frame, image, corners, ids in _iter_visual_log(visual_log,
                                                                self.cfg.recording):
            self.rec.set_time("frame", sequence=int(frame))
            ent = f"world/{cam}/image"
            if image is not None:
                if isinstance(image, (bytes, bytearray, memoryview)):
                    self.rec.log(ent, rr.EncodedImage(contents=bytes(image),
                                                      media_type="image/jpeg"))
                else:
                    self.rec.log(ent, rr.Image(np.asarray(image)).compress(
                        jpeg_quality=self.cfg.recording.jpeg_quality))
            if corners is not None and len(corners):
                c = np.asarray(corners, dtype=np.float32).reshape(-1, 4, 2)
                labels = None if ids is None else [str(int(i)) for i in np.ravel(ids)]
                self.rec.log(f"{ent}/corners", rr.Points2D(c.reshape(-1, 2),
                                                           colors=(0, 255, 0), radii=2.0))
                self.rec.log(f"{ent}/markers", rr.LineStrips2D(
                    np.concatenate([c, c[:, :1]], axis=1), colors=(0, 255, 0),
                    labels=labels))
            else:  # no detections in this frame: no overlay from an older one
                self.rec.log(f"{ent}/corners", rr.Clear(recursive=False))
                self.rec.log(f"{ent}/markers", rr.Clear(recursive=False))
        self.rec.reset_time()

    # ------------------------------------------------------------- estimates
    def log_estimates(self, solvers, X_true, gt: dict) -> None:
        import rerun as rr
        ok = [s for s in solvers if s.X is not None and np.isfinite(s.X).all()]
        for k, s in enumerate(ok):
            ent = f"world/cam_a/estimates/{entity_name(s.label)}"
            self._log_pose(ent, np.asarray(s.X), static=True)
            self.rec.log(ent, rr.TransformAxes3D(0.06), static=True)
            self.rec.log(f"{ent}/origin", rr.Points3D(
                [[0.0, 0.0, 0.0]], radii=0.012, colors=_SOLVER_COLORS[k % len(_SOLVER_COLORS)],
                labels=[s.label]), static=True)
        if not ok:
            return
        rot = np.array([s.rotation_error_deg for s in ok], dtype=np.float64)
        trans = np.array([s.translation_error_m for s in ok], dtype=np.float64) * 100.0
        self.rec.log("errors/rotation_deg", rr.BarChart(rot), static=True)
        self.rec.log("errors/translation_cm", rr.BarChart(trans), static=True)
        legend = "\n".join(f"{i}. **{s.label}** (alpha {s.alpha:g}): {r:.3f} deg, {t:.2f} cm"
                           + (" — degenerate" if s.degenerate else "")
                           for i, (s, r, t) in enumerate(zip(ok, rot, trans)))
        self.rec.log("errors/legend", rr.TextDocument(legend, media_type="text/markdown"),
                     static=True)
        for s, r, t in zip(ok, rot, trans):
            self.rec.log(f"errors/{entity_name(s.label)}/rotation_deg", rr.Scalars([r]),
                         static=True)
            self.rec.log(f"errors/{entity_name(s.label)}/translation_cm", rr.Scalars([t]),
                         static=True)

    # ------------------------------------------------------------ pose error
    def log_pose_errors(self, pose_errors: dict) -> None:
        import rerun as rr
        for cam, e in pose_errors.items():
            if e.n == 0:
                continue
            frames = np.asarray(e.frame_index, dtype=np.int64)
            for name, values, unit in (("rotation_deg", e.rotation_deg, 1.0),
                                       ("translation_mm", e.translation_m, 1000.0)):
                ent = f"pose_error/{cam}/{name}"
                self.rec.log(ent, rr.SeriesLines(names=f"{cam} {name}",
                                                 colors=_COLORS.get(cam, (200, 200, 200))),
                             static=True)
                self.rec.send_columns(ent, indexes=[rr.TimeColumn("frame", sequence=frames)],
                                      columns=rr.Scalars.columns(
                                          scalars=np.asarray(values, dtype=np.float64) * unit))

    def log_summary(self, text: str) -> None:
        import rerun as rr
        self.rec.log("summary", rr.TextDocument(f"```\n{text}\n```",
                                                media_type="text/markdown"), static=True)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.rec.flush()
        finally:
            self.rec.disconnect()


def log_convergence(rec, solvers) -> None:
    """Issue 9: error and predicted 1-sigma against the number of motions used (k), one
    named series per solver, on the ``motions`` timeline: ``convergence/rotation_deg/
    <solver>/{error,sigma}`` and ``convergence/translation_cm/<solver>/{error,sigma}``
    (from ``SolverResult.convergence``; failed or undetermined points are left out)."""
    import rerun as rr
    for n, s in enumerate(solvers):
        pts = [p for p in getattr(s, "convergence", ()) if p.get("success")]
        if not pts:
            continue
        color = _SOLVER_COLORS[n % len(_SOLVER_COLORS)]
        k = np.array([p["k"] for p in pts], dtype=np.int64)
        for quantity, key, unit in (("rotation_deg", "rotation", 1.0),
                                    ("translation_cm", "translation", 100.0)):
            err = np.array([p[f"{key}_error_{'deg' if unit == 1.0 else 'm'}"] for p in pts],
                           dtype=np.float64) * unit
            sig = np.array([np.nan if p[f"sigma_{key}_{'deg' if unit == 1.0 else 'm'}"] is None
                            else p[f"sigma_{key}_{'deg' if unit == 1.0 else 'm'}"]
                            for p in pts], dtype=np.float64) * unit
            for part, vals, width in (("error", err, 2.0), ("sigma", sig, 1.0)):
                keep = np.isfinite(vals)
                if not keep.any():
                    continue
                ent = f"convergence/{quantity}/{entity_name(s.label)}/{part}"
                rec.log(ent, rr.SeriesLines(names=f"{s.label} {part}", colors=color,
                                            widths=width), static=True)
                rec.send_columns(ent, indexes=[rr.TimeColumn("motions", sequence=k[keep])],
                                 columns=rr.Scalars.columns(scalars=vals[keep]))



def _iter_visual_log(log, rec_cfg):
    """Yield ``(camera, frame, image, corners (K,4,2) | None, ids | None)`` from the vision
    stage's :class:`~simcalib.vision.VisualLog` (``frames[camera]``: per-frame records with
    ``frame_index``, ``ids``, ``corners_px``; ``images_jpeg[camera][frame_index]``: JPEG
    bytes). At most ``rec_cfg.max_images`` images per camera are yielded (evenly
    subsampled), each with the corners detected in THAT frame; frames without a logged
    image are not yielded, so an overlay never sits on another frame's image."""
    frames_by_cam = getattr(log, "frames", None) or {}
    images = getattr(log, "images_jpeg", None) or {}
    for cam, entries in dict(frames_by_cam).items():
        cam_images = dict(images.get(cam, {}))
        logged = sorted(cam_images)
        keep = set(logged)
        if rec_cfg.max_images < len(logged):
            sel = np.linspace(0, len(logged) - 1, rec_cfg.max_images).round().astype(int) \
                if rec_cfg.max_images else []
            keep = {logged[i] for i in sel}
        for e in entries:
            frame = int(_get(e, "frame_index", "frame"))
            if frame not in keep:
                continue
            yield cam, frame, cam_images[frame], _get(e, "corners_px", "corners"), \
                _get(e, "ids")


def _get(entry, *names):
    for n in names:
        if isinstance(entry, dict) and n in entry:
            return entry[n]
        if hasattr(entry, n):
            return getattr(entry, n)
    return None


# ------------------------------------------------------- calibrate command (issue 11)
def record_calibration(path, *, time_s, T_world_a, T_world_b, X, T_wa_wb, motion_time_s,
                       rotation_error_deg, translation_error_m, inlier, lags_s, correlation,
                       cost_offsets_s=None, cost=None, offset_s: float = 0.0,
                       summary: str = "") -> Path:
    """The recording of ``simcalib calibrate`` (self-contained; headless, no viewer).

    Entities (timeline ``time`` = synchronised instants in clock a, seconds):

    * ``world/a/trajectory`` — sensor a's path (its world frame); ``world/a`` its pose.
    * ``world/b_measured/trajectory`` — sensor b's measured path, brought into a's world
      frame through the estimate (``T_wa_wb T_wb_b``); ``world/b_predicted/trajectory`` —
      where the estimate puts b (``T_wa_a X``). They coincide when X is right.
    * ``residuals/rotation_deg``, ``residuals/translation_mm`` — per-motion errors of
      ``C X = X H`` at the motions' start; ``residuals/inlier`` 1/0.
    * ``time_offset/correlation`` — angular-speed cross-correlation over the lag (timeline
      ``lag``, seconds); ``time_offset/cost`` — the refinement cost over the offset
      (timeline ``offset``); ``time_offset/estimate`` — the chosen offset (text).
    * ``summary`` — the console report.
    """
    import rerun as rr
    import rerun.blueprint as rrb
    path = Path(path)
    rec = rr.RecordingStream("simcalib", recording_id=str(uuid.uuid4()), send_properties=False)
    if hasattr(rec, "set_log_time_enabled"):
        rec.set_log_time_enabled(False)
    blueprint = rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name="trajectories (frame of a's world)"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="residuals", name="motion residuals over time"),
                rrb.TimeSeriesView(origin="time_offset/correlation",
                                   name="angular-speed correlation over lag"),
                rrb.TextDocumentView(origin="summary", name="summary"),
                row_shares=[2, 2, 3]),
            column_shares=[3, 2]),
        rrb.TimePanel(timeline="time"), collapse_panels=True)
    rec.save(str(path), default_blueprint=blueprint)
    try:
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        Ta = np.asarray(T_world_a, dtype=np.float64)
        Tb_meas = np.asarray(T_wa_wb, dtype=np.float64) @ np.asarray(T_world_b, np.float64)
        Tb_pred = Ta @ np.asarray(X, dtype=np.float64)
        for name, T, color in (("a", Ta, (230, 120, 30)),
                               ("b_measured", Tb_meas, (40, 140, 230)),
                               ("b_predicted", Tb_pred, (40, 200, 120))):
            rec.log(f"world/{name}/trajectory", rr.LineStrips3D([T[:, :3, 3]], colors=color,
                                                                radii=0.002), static=True)
            rec.send_columns(f"world/{name}",
                             indexes=[rr.TimeColumn("time", duration=np.asarray(time_s))],
                             columns=rr.Transform3D.columns(translation=T[:, :3, 3],
                                                            mat3x3=T[:, :3, :3]))
            rec.log(f"world/{name}/axes", rr.TransformAxes3D(0.05), static=True)
        mt = np.asarray(motion_time_s, dtype=np.float64)
        for name, values, color in (
                ("rotation_deg", np.asarray(rotation_error_deg), (220, 50, 50)),
                ("translation_mm", 1e3 * np.asarray(translation_error_m), (50, 120, 220)),
                ("inlier", np.asarray(inlier, dtype=np.float64), (120, 120, 120))):
            if mt.size == 0:
                break
            rec.log(f"residuals/{name}", rr.SeriesLines(names=name, colors=color), static=True)
            rec.send_columns(f"residuals/{name}", indexes=[rr.TimeColumn("time", duration=mt)],
                             columns=rr.Scalars.columns(scalars=values.astype(np.float64)))
        for ent, x, y, timeline in (("time_offset/correlation", lags_s, correlation, "lag"),
                                    ("time_offset/cost", cost_offsets_s, cost, "offset")):
            x = np.zeros(0) if x is None else np.asarray(x, dtype=np.float64)
            y = np.zeros(0) if y is None else np.asarray(y, dtype=np.float64)
            ok = np.isfinite(x) & np.isfinite(y) if x.size == y.size else np.zeros(0, bool)
            if ok.any():
                rec.log(ent, rr.SeriesLines(names=ent.split("/")[-1]), static=True)
                rec.send_columns(ent, indexes=[rr.TimeColumn(timeline, duration=x[ok])],
                                 columns=rr.Scalars.columns(scalars=y[ok]))
        rec.log("time_offset/estimate", rr.TextDocument(
            f"offset t_b - t_a = {1e3 * float(offset_s):.3f} ms"), static=True)
        if summary:
            rec.log("summary", rr.TextDocument(f"```\n{summary}\n```",
                                               media_type="text/markdown"), static=True)
    finally:
        rec.flush()
        rec.disconnect()
    return path
