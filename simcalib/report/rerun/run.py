"""A run's recording (``recording.rrd`` of ``simcalib run``): :class:`RunRecorder`.

Headless: a recording stream saved straight to a file (no viewer), wall-clock log time
disabled; application id ``simcalib``, a fresh recording id per run (two runs opened
together stay apart). Written by a worker process (``recording.background``, default on;
:mod:`simcalib.report.rerun.worker`): the run never imports rerun.

The pipeline's stages never call rerun: after each stage the run loop hands the state to
:meth:`RunRecorder.record_stage`, the ONE place that decides what a stage's results look
like in the recording (``world``: room, markers, the platform's geoms posed per frame;
``streams``: trajectories, cameras, images with the detections of the same frames;
``solvers``: the extrinsic close-up and the per-solver errors; ``evaluation``: pose-source
errors; ``reports``: the summary). The blueprint is chosen from what was recorded
(scenario kind, images or not, views with data) and written when the recording is closed.

Entity layout (timeline ``frame`` = simulated frame index, plus ``sim_time``):

* ``world`` (z up): ``world/room/<geom>``, ``world/markers/<id>``,
  ``world/platform/<body>`` (posed per frame, geoms under ``.../geoms``), ``world/<cam>``
  with ``world/<cam>/image`` (pinhole, images, ``corners``/``markers`` of that frame),
  ``world/trajectories/<cam>/ground_truth|<source>`` (:mod:`.run_scene`)
* ``closeup`` (camera a's OpenCV frame): ``closeup/cam_a``, ``closeup/true_cam_b``,
  ``closeup/estimates/<solver>``, ``closeup/offscale/<k>``, ``closeup/uncertainty/<solver>``,
  ``closeup/labels/*`` (:mod:`.run_closeup`)
* ``errors/<solver>/rotation_deg|translation_cm`` — per-solver errors as scalars
* ``pose_error/rotation_deg/<cam>``, ``pose_error/translation_mm/<cam>``;
  ``convergence/<rotation_deg|translation_cm>/<solver>/<error|sigma>`` (:mod:`.run_plots`)
* ``summary`` — :func:`simcalib.report.rerun.run_summary.summary_markdown`
"""

from __future__ import annotations

import json
import time
import uuid
from pathlib import Path

from simcalib.report.rerun.run_closeup import CloseupLogging
from simcalib.report.rerun.run_layout import default_blueprint
from simcalib.report.rerun.run_plots import PlotLogging, log_convergence
from simcalib.report.rerun.run_scene import SceneLogging
from simcalib.report.rerun.run_summary import summary_markdown
from simcalib.report.rerun.worker import finish_stream, open_stream

__all__ = ["RunRecorder", "SCENE_ROOTS", "summary_of"]

#: top-level entity roots of a run recording
SCENE_ROOTS = ("world", "closeup", "errors", "pose_error", "summary")


class RunRecorder(SceneLogging, CloseupLogging, PlotLogging):
    """Writes one run's recording; every ``log_*`` method is safe to call once per stage.

    ``close()`` writes the blueprint for what was recorded, flushes and finalises the file
    (also after an interrupt, so the partial recording stays readable).
    """

    def __init__(self, path: Path, cfg, background: bool = True):
        """``background``: rerun runs in a worker process
        (:class:`~simcalib.report.rerun.worker.WorkerStream`), so the run neither imports
        rerun nor waits for the file until :meth:`close`; ``False`` logs in this process."""
        t_init = time.perf_counter()
        self.path = Path(path)
        self.cfg = cfg
        self.recording_id = str(uuid.uuid4())   # unique per run; the application id is shared
        self.rec, self.rr, self.background = open_stream(
            self.path, background, application_id="simcalib",
            recording_id=self.recording_id, send_properties=False)
        self._closed = False
        self.kind = getattr(cfg, "kind", "sim")
        self.images = False
        self.image_cameras: set = set()   # the cameras that logged images (their panes)
        self.eye = None
        self.closeup_eye = None
        self.room = None                 # (min, max) corners of the room, sim runs
        self._workspace = []             # points the scene view frames
        self.stage_s: dict[str, float] = {}   # wall time per stage ("init", "close" too)
        self.present: set[str] = set()   # views with data (the blueprint shows only those)
        self.rec.log("world", self.rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.rec.log("closeup", self.rr.ViewCoordinates.RDF, static=True)
        # wall time spent recording (recording_view.json)
        self.elapsed_s = self.stage_s["init"] = time.perf_counter() - t_init

    # ------------------------------------------------------------- dispatch
    def record_stage(self, stage: str, st) -> None:
        """Log what ``stage`` produced (``st``: :class:`simcalib.pipeline.state.RunState`)."""
        t0 = time.perf_counter()
        try:
            self._record_stage(stage, st)
        finally:
            if self.background:
                self.rec.handoff()
            dt = time.perf_counter() - t0
            self.elapsed_s += dt
            self.stage_s[stage] = self.stage_s.get(stage, 0.0) + dt

    def _record_stage(self, stage: str, st) -> None:
        truth = st.truth
        if stage == "world":
            self.kind = truth.kind
            world = getattr(truth, "world", None)
            if world is not None:
                self.log_room_and_platform(world)
            self.log_world(truth.marker_field)
        elif stage == "streams":
            self._record_streams(st)
        elif stage == "solvers":
            self.log_estimates(st.solvers, truth.X_true, dict(truth.streams))
            log_convergence(self.rec, st.solvers, rr=self.rr)
        elif stage == "evaluation":
            self.log_pose_errors(st.pose_errors)
        elif stage == "reports":
            self.log_summary(summary_markdown(st.result()))

    def _record_streams(self, st) -> None:
        from simcalib.sources import get_source
        truth = st.truth
        measured = {cam: s for cam, s in st.measured.items()
                    if not get_source(st.camera_sources[cam]).info.exact}
        self.log_trajectories(dict(truth.streams), measured, truth.X_true)
        if truth.intrinsics:
            logs = [log for name, log in st.source_logs.items()   # a rendering source's
                    if log is not None and get_source(name).info.renders]
            self.log_cameras(dict(truth.intrinsics), dict(truth.streams),
                             logs[0] if logs else None)

    def log_summary(self, markdown: str) -> None:
        self.present.add("summary")
        self.rec.log("summary", self.rr.TextDocument(markdown, media_type="text/markdown"),
                     static=True)

    def blueprint(self):
        cameras = tuple(c for c in ("cam_a", "cam_b") if c in self.image_cameras)
        return default_blueprint(kind=self.kind, images=self.images, cameras=cameras,
                                 eye=self.eye, closeup_eye=self.closeup_eye, present=self.present,
                                 rrb=self.rr.blueprint if self.background else None)

    def close(self) -> None:
        """Write the blueprint, finish the file (waiting for the recording worker) and
        ``recording_view.json`` beside it."""
        if self._closed:
            return
        self._closed = True
        t0 = time.perf_counter()
        try:
            self.rec.send_blueprint(self.blueprint(), make_active=True, make_default=True)
        finally:
            try:
                finish_stream(self.rec, self.background)   # raises on a worker's error
            finally:
                self.stage_s["close"] = time.perf_counter() - t0
                self.elapsed_s += self.stage_s["close"]
        self._write_view()

    def _write_view(self) -> None:
        """``recording_view.json``: the views' framing, for tools that open one view alone
        (tools/screenshots.py), and the cost: ``recording_s`` = wall time the run spent
        recording (with the worker: handing it the data, and waiting at the end);
        ``worker`` = the worker's own times."""
        worker = getattr(self.rec, "status", None) if self.background else None
        self.path.with_name("recording_view.json").write_text(json.dumps(
            {"kind": self.kind, "images": self.images, "recording_s": self.elapsed_s,
             "recording_stage_s": self.stage_s,
             "worker": None if worker is None else {k: worker.get(k) for k in (
                 "import_s", "log_s", "calls")},
             "eye": self.eye,
             "closeup_eye": self.closeup_eye,
             "room": None if self.room is None else [v.tolist() for v in self.room]},
            indent=1))


def summary_of(rrd) -> str:
    """The summary pane's markdown of a run recording, read back from the file."""
    from rerun.chunk import RrdReader
    for ch in RrdReader(str(rrd)).store().stream():
        if str(ch.entity_path) == "/summary":
            rb = ch.to_record_batch()
            for name in rb.schema.names:
                if name.startswith("TextDocument:text"):
                    v = rb.column(name).to_pylist()[0]
                    return str(v[0] if isinstance(v, list) else v)
    return ""
