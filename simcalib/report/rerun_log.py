"""ALL rerun code of simcalib: the run recording (``recording.rrd``), the sweep and experiment
recordings, and their blueprints (docs/recording.md shows them).

Headless: a :class:`rerun.RecordingStream` saved straight to a file (no viewer), wall-clock
log time disabled; application id ``simcalib``, a fresh recording id per run (two runs
opened together stay apart). Open it with ``rerun recording.rrd``.

A run's recording is written by a worker process (``recording.background``, default on;
:mod:`simcalib.report._rerun_replay`): the run never imports rerun (0.4-1 s, more than a
synthetic run's solving); :class:`RunRecorder` logs through stand-ins (:class:`_RRProxy`)
whose calls are pickled into a spool file the worker replays with the real rerun, so
importing rerun and writing the file happen beside the run. ``simcalib run`` starts the
worker before it loads the configuration (:func:`prestart_worker`).

The pipeline's stages never call rerun: after each stage the run loop hands the state to
:meth:`RunRecorder.record_stage`, the ONE place that decides what a stage's results look
like in the recording (``world``: room, markers, the platform's geoms posed per frame;
``streams``: trajectories, cameras, images with the detections of the same frames;
``solvers``: the extrinsic close-up and the per-solver error table; ``evaluation``:
pose-source errors; ``reports``: the summary). The blueprint is chosen from what was
recorded (scenario kind, images or not) and written when the recording is closed.

Entity layout (timeline ``frame`` = simulated frame index, plus ``sim_time``):

* ``world`` (z up): ``world/room/<geom>`` floor (solid), walls and ceiling (outlines);
  ``world/markers/<id>`` textured marker quads; ``world/platform/<body>`` every moving body
  of the MuJoCo model (cart, wheels, arm links, rig) posed per frame, its geoms logged once
  under ``.../geoms``; ``world/<cam>`` the true camera pose per frame with
  ``world/<cam>/image`` (pinhole frustum, JPEG image, ``corners``/``markers`` overlays of
  that frame); ``world/trajectories/<cam>/ground_truth`` (line) and ``.../<source>``
  (points).
* ``closeup`` (camera a's OpenCV frame, x right, y down, z forward): ``closeup/cam_a``,
  ``closeup/true_cam_b`` and ``closeup/estimates/<solver>`` as axes; estimates farther than
  the close-up bound (:func:`closeup_bound_m`) are drawn at the bound as
  ``closeup/offscale/<k>`` (one marker per place) with the real errors in the label;
  ``closeup/uncertainty/<solver>`` the 3-sigma translation ellipsoid when the solver
  result carries a ``covariance`` (clipped inside the bound; ``.../offscale`` arrows
  mark clipped and undetermined axes); failed solvers are only named in camera a's label.
  ``closeup/labels/*``: one label per group of agreeing estimates, laid out on the
  close-up's screen so that none overlaps another (:func:`_place_labels`).
* ``errors/<solver>/rotation_deg|translation_cm`` — per-solver errors as scalars (the
  summary shows them as a table with log-scale bars).
* ``pose_error/rotation_deg/<cam>``, ``pose_error/translation_mm/<cam>`` — per-frame
  pose-source error, one unit per plot, a colour per camera.
* ``convergence/<rotation_deg|translation_cm>/<solver>/<error|sigma>`` — error and
  predicted 1-sigma against the number of motions used (timeline ``motions``).
* ``summary`` — the console summary as a markdown document: per-solver errors with
  log-scale bars, FAILED and degenerate rows, undetermined directions, frames, pairs.
"""

from __future__ import annotations

import math
import re
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.report._rerun_replay import _HEADER, _TAG   # the worker's wire format (stdlib only)
from simcalib.geometry import quat_from_matrix

__all__ = ["RunRecorder", "default_blueprint", "entity_name", "closeup_bound_m",
           "record_sweep", "log_experiment", "summary_markdown", "SCENE_ROOTS"]

#: top-level entity roots of a run recording
SCENE_ROOTS = ("world", "closeup", "errors", "pose_error", "summary")


def entity_name(label: str) -> str:
    """Entity-path-safe name of a solver label (``dqopt+prior`` -> ``dqopt_prior``)."""
    return re.sub(r"[^A-Za-z0-9_]", "_", label)


_COLORS = {"cam_a": (230, 120, 30), "cam_b": (40, 140, 230)}
_SOLVER_COLORS = [(220, 50, 50), (50, 170, 80), (150, 80, 200), (240, 180, 0),
                  (0, 170, 190), (200, 100, 150), (120, 120, 120), (90, 60, 20)]
_TRUE_COLOR = (40, 140, 230)
_OFFSCALE_COLOR = (255, 40, 40)
_LABEL_COLOR = (255, 255, 255)
#: backgrounds of the two 3D views (the screenshot checks rely on them)
SCENE_BACKGROUND = (245, 245, 245)
CLOSEUP_BACKGROUND = (28, 30, 34)    # label text (drawn on the viewer's grey label boxes)


def closeup_bound_m(t_true_norm_m: float) -> float:
    """Radius of the extrinsic close-up around camera a: ``min(1 m, 10 |t_X|)``, at least
    0.1 m. Estimates beyond it are drawn at the bound as off-scale markers."""
    return float(max(0.1, min(1.0, 10.0 * float(t_true_norm_m))))


def _fmt_len_cm(x_m: float | None) -> str:
    if x_m is None or not np.isfinite(x_m):
        return "–"
    cm = 100.0 * float(x_m)
    return f"{cm:.3g} cm" if abs(cm) < 1e4 else f"{cm:.3g} cm ({x_m:.3g} m)"


def _fmt(x, digits=3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    x = float(x)
    return f"{x:.{digits}g}" if abs(x) < 1e4 and (x == 0 or abs(x) >= 1e-3) else f"{x:.2e}"


def _log_bar(value: float | None, lo: float, hi: float, width: int = 12) -> str:
    """A log-scale bar (unicode blocks) of ``value`` between decades ``lo`` and ``hi``."""
    if value is None or not np.isfinite(value) or value <= 0:
        return ""
    f = (math.log10(value) - lo) / max(hi - lo, 1e-9)
    n = int(round(min(max(f, 0.0), 1.0) * width))
    return "█" * max(n, 1)


def _decades(values) -> tuple[float, float]:
    v = np.array([x for x in values if x is not None and np.isfinite(x) and x > 0])
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = math.floor(math.log10(v.min())), math.ceil(math.log10(v.max()))
    return float(lo), float(max(hi, lo + 1))


# -------------------------------------------------------------------------- blueprints
def default_blueprint(kind: str = "sim", images: bool = True, cameras=("cam_a", "cam_b"),
                      eye: dict | None = None, closeup_eye: dict | None = None,
                      present: set | None = None, rrb=None):
    """The layout a run recording opens on, per scenario kind.

    Left: the scene (room, platform, cameras, trajectories) and, when images were logged
    (ArUco runs), both camera images with that frame's detections. Right: the extrinsic
    close-up, the pose-source error (rotation and translation in separate plots), the
    per-solver error table and the summary. Synthetic runs (no room, no images) give the
    scene less room and the tables more. ``eye`` / ``closeup_eye``: ``{"position",
    "look_target", "eye_up"}`` of the two 3D views. ``present``: the views that have data
    (``"scene"``, ``"closeup"``, ``"pose_error"``, ``"summary"``); the others are left out
    (no pane says "No data available"); ``None`` keeps all. ``rrb``: ``rerun.blueprint``
    (default) or the recorder's stand-in for it."""
    if rrb is None:
        import rerun.blueprint as rrb

    def eye_controls(e):
        return None if e is None else rrb.EyeControls3D(
            kind=rrb.Eye3DKind.Orbital, position=e["position"], look_target=e["look_target"],
            eye_up=e["eye_up"])

    scene = rrb.Spatial3DView(
        origin="world", name="scene (true paths: lines, pose source: points)",
        eye_controls=eye_controls(eye), background=SCENE_BACKGROUND,
        line_grid=rrb.LineGrid3D(visible=False))
    closeup = rrb.Spatial3DView(
        origin="closeup", name="extrinsic close-up (camera a frame; true cam_b blue)",
        eye_controls=eye_controls(closeup_eye), background=CLOSEUP_BACKGROUND,
        line_grid=rrb.LineGrid3D(visible=False))
    pose = [rrb.TimeSeriesView(origin="pose_error/rotation_deg",
                               name="pose-source rotation error [deg]"),
            rrb.TimeSeriesView(origin="pose_error/translation_mm",
                               name="pose-source translation error [mm]")]
    summary = rrb.TextDocumentView(origin="summary",
                                   name="summary: errors per solver (log bars), verdict")
    images_row = [rrb.Spatial2DView(origin=f"world/{c}/image", name=f"{c} image + detections")
                  for c in cameras]
    if present is not None:   # only views with data (an interrupted run has fewer)
        scene, closeup, summary = (v if k in present else None for v, k in (
            (scene, "scene"), (closeup, "closeup"), (summary, "summary")))
        pose = pose if "pose_error" in present else []

    def box(cls, items, shares):
        kept = [(i, sh) for i, sh in zip(items, shares) if i is not None]
        if not kept:
            return None
        if len(kept) == 1:
            return kept[0][0]
        key = "row_shares" if cls is rrb.Vertical else "column_shares"
        return cls(*[i for i, _ in kept], **{key: [sh for _, sh in kept]})

    pose_box = box(rrb.Vertical, pose, [1] * len(pose))
    if kind == "synthetic":
        body = box(rrb.Horizontal, [box(rrb.Vertical, [scene, closeup], [1, 1]),
                                    box(rrb.Vertical, [pose_box, summary], [2, 3])], [2, 3])
    elif images:
        body = box(rrb.Horizontal, [
            box(rrb.Vertical, [scene, box(rrb.Horizontal, images_row, [1] * len(cameras))],
                [3, 2]),
            box(rrb.Vertical, [box(rrb.Horizontal, [closeup, pose_box], [3, 2]), summary],
                [1, 1])], [1, 1])
    else:
        body = box(rrb.Horizontal, [box(rrb.Vertical, [scene, closeup], [3, 2]),
                                    box(rrb.Vertical, [pose_box, summary], [2, 3])], [1, 1])
    if body is None:
        body = rrb.Spatial3DView(origin="world", name="scene")
    return rrb.Blueprint(body, rrb.TimePanel(timeline="frame", state="collapsed"),
                         rrb.BlueprintPanel(state="collapsed"),
                         rrb.SelectionPanel(state="collapsed"), auto_views=False)


def _eye(bbox_min, bbox_max, direction, up, inside=None, min_dist=0.0) -> dict:
    """An orbital eye looking at the centre of a box from ``direction`` (kept inside the
    box ``inside`` = (min, max) when given)."""
    lo, hi = np.asarray(bbox_min, float), np.asarray(bbox_max, float)
    c = 0.5 * (lo + hi)
    ext = max(float(np.linalg.norm(hi - lo)), 0.05)
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    pos = c + max(1.3 * ext, min_dist) * d
    if inside is not None:
        pos = np.clip(pos, np.asarray(inside[0]) + 0.05, np.asarray(inside[1]) - 0.05)
    return {"position": pos.tolist(), "look_target": c.tolist(), "eye_up": list(up)}


def _fmt_len_m(x_m: float) -> str:
    return f"{100 * x_m:.2g} cm" if x_m < 1.0 else f"{x_m:.2g} m"


def _axis_name(v) -> str:
    """``x``/``y``/``z`` for a direction (nearly) along a camera-a axis, else the vector."""
    v = np.asarray(v, dtype=np.float64)
    i = int(np.argmax(np.abs(v)))
    if abs(v[i]) > 0.95:
        return "xyz"[i]
    return "(" + ", ".join(f"{x:+.2f}" for x in v) + ")"


def _wrap(text: str, width: int = 34) -> list[str]:
    """``text`` (comma-separated names) wrapped after commas into lines of ~``width``."""
    lines, cur = [], ""
    for part in text.split(", "):
        if cur and len(cur) + 2 + len(part) > width:
            lines.append(cur + ",")
            cur = part
        else:
            cur = f"{cur}, {part}" if cur else part
    return lines + [cur]


#: the close-up's label layout, in tangent units of the viewer's 3D eye (vertical field of
#: view 55°: the view is 2 tan(27.5°) = 1.04 high), sized for the smallest close-up pane of
#: the default layouts (about 480 x 440 logical px: 15 px per text line, 6 px per char)
_FOV_TAN = math.tan(math.radians(55.0) / 2)
_LINE_H = 0.045
_CHAR_W = 0.0145
_PAD = 0.012
_PANE_ASPECT = 1.05


def _screen_basis(eye: dict):
    pos = np.asarray(eye["position"], dtype=np.float64)
    f = np.asarray(eye["look_target"], dtype=np.float64) - pos
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(eye["eye_up"], dtype=np.float64))
    r /= np.linalg.norm(r)
    return pos, f, r, np.cross(r, f)


def _place_labels(eye: dict, items, max_norm: float) -> list[np.ndarray]:
    """3D positions for labels so that none overlaps another on the screen of ``eye``.

    ``items``: ``(anchor (3,), lines)``. Each label is a box (its text's size in the
    viewer: lines x width in characters, ``_LINE_H``/``_CHAR_W``) that the viewer centres
    horizontally just below its point. Boxes are placed greedily, anchors top to bottom,
    inside the pane: just above the anchor, else below it, else beside it, else ever
    farther up, down or beside, the first place that overlaps neither a box placed before
    nor any anchor (the dots the labels name). The point is put on the anchor's viewing
    depth, or nearer the eye if that would leave the sphere of radius ``max_norm``."""
    pos, f, r, u = _screen_basis(eye)
    half_h = _FOV_TAN
    half_w = _FOV_TAN * _PANE_ASPECT

    def project(p):
        d = np.asarray(p, dtype=np.float64) - pos
        z = max(float(d @ f), 1e-6)
        return np.array([d @ r / z, -(d @ u) / z]), z

    anchors = [project(a) for a, _ in items]
    sizes = [(max(len(x) for x in lines) * _CHAR_W + 2 * _PAD, len(lines) * _LINE_H + _PAD)
             for _, lines in items]
    boxes: list[tuple[float, float, float, float]] = []   # x0, y0, x1, y1 (y down)
    dots = [(xy[0] - 0.012, xy[1] - 0.012, xy[0] + 0.012, xy[1] + 0.012) for xy, _ in anchors]

    def free(b, own):
        return not any(b[0] < o[2] and o[0] < b[2] and b[1] < o[3] and o[1] < b[3]
                       for o in boxes + [d for k, d in enumerate(dots) if k != own])

    order = sorted(range(len(items)), key=lambda i: anchors[i][0][1])
    screen = [None] * len(items)
    for i in order:
        (ax, ay), _ = anchors[i]
        w, h = sizes[i]

        def box(cx, top):
            cx = float(np.clip(cx, -half_w + 0.5 * w, half_w - 0.5 * w)) if w < 2 * half_w \
                else 0.0
            top = float(np.clip(top, -half_h + 0.02, half_h - h - 0.02))
            return (cx - 0.5 * w, top, cx + 0.5 * w, top + h)

        above, below, mid = ay - 0.012 - h, ay + 0.012, ay - 0.5 * h
        right, left = ax + 0.02 + 0.5 * w, ax - 0.02 - 0.5 * w
        best = None
        for k in range(90):   # above the anchor, below, beside it; then farther away
            d = k * _LINE_H / 3
            for b in (box(ax, above - d), box(ax, below + d), box(right, mid - d),
                      box(right, mid + d), box(left, mid - d), box(left, mid + d)):
                if free(b, i):
                    best = b
                    break
            if best is not None:
                break
        if best is None:   # a crowded pane: below everything placed
            top = max([o[3] for o in boxes], default=ay) + 0.005
            best = (ax - 0.5 * w, top, ax + 0.5 * w, top + h)
        boxes.append(best)
        # the viewer draws the text centred just below its point
        screen[i] = (0.5 * (best[0] + best[2]), best[1] - 0.005)
    out = []
    for (a, _), (xy, z), (sx, sy) in zip(items, anchors, screen):
        ray = f + sx * r - sy * u
        p = pos + z * ray
        if np.linalg.norm(p) > max_norm:   # nearer the eye, same place on the screen
            aa, bb, cc = float(ray @ ray), float(pos @ ray), float(pos @ pos) - max_norm ** 2
            disc = bb * bb - aa * cc
            roots = [] if disc < 0 else [(-bb - math.sqrt(disc)) / aa,
                                         (-bb + math.sqrt(disc)) / aa]
            roots = [x for x in roots if 0 < x <= z]
            p = pos + (max(roots) if roots else max(-bb / aa, 1e-3)) * ray
        out.append(p)
    return out


# ------------------------------------------------------------- recording worker
class _RRProxy:
    """Stands for ``rerun`` (or one of its attributes) in the run's process: attribute
    access and calls build the encoded objects :mod:`simcalib.report._rerun_replay` rebuilds in
    the recording worker. Children are cached, so ``rrb.Vertical is rrb.Vertical``."""

    def __init__(self, path=()):
        self._path = tuple(path)
        self._children: dict[str, _RRProxy] = {}

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        child = self._children.get(name)
        if child is None:
            child = self._children[name] = _RRProxy(self._path + (name,))
        return child

    def __call__(self, *args, **kwargs):
        return _RRObject((_TAG, "new", self._path, _encode(args), _encode(kwargs)))

    def _encoded(self):
        return (_TAG, "ref", self._path)


class _RRObject:
    """A rerun object built in the worker (``rr.Image(x)``); method calls chain
    (``.compress(jpeg_quality=70)``)."""

    def __init__(self, spec):
        self._spec = spec

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return lambda *args, **kwargs: _RRObject(
            (_TAG, "meth", self._spec, name, _encode(args), _encode(kwargs)))

    def _encoded(self):
        return self._spec


_NESTED = (_RRProxy, _RRObject, tuple, list, dict)


def _encode(x):
    """``x`` with the stand-ins replaced by their encodings (containers of plain values,
    e.g. colours or vertex lists, are passed through as they are)."""
    if isinstance(x, (_RRProxy, _RRObject)):
        return x._encoded()
    if isinstance(x, (tuple, list)):
        if not any(isinstance(v, _NESTED) for v in x):
            return x
        return type(x)(_encode(v) for v in x)
    if isinstance(x, dict):
        return {k: _encode(v) for k, v in x.items()}
    return x


class _WorkerStream:
    """A :class:`rerun.RecordingStream` living in the recording worker process
    (:mod:`simcalib.report._rerun_replay`): every method call is pickled and appended to a spool
    file the worker follows (appending never blocks the run, also while the worker still
    imports rerun; no thread). :meth:`finish` closes the stream and waits for the file;
    it raises when the worker reported an error."""

    def __init__(self, path: Path | None = None, **stream_kwargs):
        """Start the worker; with ``path``, open the recording there (else :meth:`open`
        does later: a worker started before the run is known, :func:`prestart_worker`)."""
        import os
        import subprocess
        import sys
        import tempfile
        script = Path(__file__).with_name("_rerun_replay.py")
        fd, spool = tempfile.mkstemp(prefix="simcalib-rec-", suffix=".spool")
        self._spool_path = Path(spool)
        self._spool = os.fdopen(fd, "wb", buffering=1 << 20)   # handed over per stage
        self._status = self._spool_path.with_suffix(".json")
        self._stderr = tempfile.TemporaryFile()
        self._proc = subprocess.Popen(
            [sys.executable, "-P", str(script), str(self._spool_path), str(self._status),
             str(os.getpid())], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=self._stderr)
        self.status: dict = {}
        if path is not None:
            self.open(path, **stream_kwargs)

    def open(self, path: Path, **stream_kwargs) -> None:
        self._send(("init", stream_kwargs, str(path)))
        self.handoff()

    def alive(self) -> bool:
        return self._proc.poll() is None and not self._spool.closed

    def cancel(self) -> None:
        """Stop an unused worker (no recording written)."""
        if not self._spool.closed:
            self._spool.close()
        if self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()
        self._stderr.close()
        for p in (self._spool_path, self._status):
            p.unlink(missing_ok=True)

    def _send(self, msg):
        import pickle
        data = pickle.dumps(msg, protocol=pickle.HIGHEST_PROTOCOL)
        self._spool.write(_HEADER.pack(len(data)))
        self._spool.write(data)

    def handoff(self) -> None:
        """Make what was logged so far visible to the worker (after each stage)."""
        self._spool.flush()

    def __getattr__(self, method):
        if method.startswith("_"):
            raise AttributeError(method)
        return lambda *args, **kwargs: self._send(("rec", method, _encode(args),
                                                   _encode(kwargs)))

    def finish(self) -> None:
        """Close the recording, wait for the worker to write it, report its errors."""
        import json
        try:
            self._send(("close",))
            self._spool.close()
            code = self._proc.wait()
        finally:
            if self._proc.poll() is None:   # interrupted while waiting
                self._proc.kill()
                self._proc.wait()
            self._spool_path.unlink(missing_ok=True)
        try:
            self.status = json.loads(self._status.read_text() or "{}")
        except (OSError, ValueError):
            self.status = {}
        finally:
            self._status.unlink(missing_ok=True)
        self._stderr.seek(0)
        err = self._stderr.read().decode(errors="replace").strip()
        self._stderr.close()
        if code != 0:
            raise RuntimeError(f"the recording worker failed (exit {code}): "
                               + "\n".join(err.splitlines()[-12:]))
        if err:   # rerun's warnings, as they would have appeared in-process
            import sys
            print(err, file=sys.stderr)


_PRESTARTED: list = []       # a worker started ahead of the run (prestart_worker)


def prestart_worker() -> None:
    """Start the recording worker now, before the run's configuration is even loaded, so
    that rerun's import overlaps that too; the next :class:`RunRecorder` adopts it (an
    unused one is stopped at exit). Used by ``simcalib run``."""
    import sys
    if _PRESTARTED or "rerun" in sys.modules:   # imported already: nothing to hide
        return
    try:
        w = _WorkerStream()
    except OSError:   # no worker: the recorder starts one, or logs in-process
        return
    _PRESTARTED.append(w)
    import atexit
    atexit.register(cancel_prestarted_worker)


def cancel_prestarted_worker() -> None:
    """Stop a worker :func:`prestart_worker` started when the run records nothing."""
    while _PRESTARTED:
        _PRESTARTED.pop().cancel()


def _worker_stream(path: Path, **stream_kwargs) -> _WorkerStream:
    while _PRESTARTED:
        w = _PRESTARTED.pop()
        if w.alive():
            w.open(path, **stream_kwargs)
            return w
        w.cancel()
    return _WorkerStream(path, **stream_kwargs)




# ------------------------------------------------------------------------------ run
class RunRecorder:
    """Writes one run's recording; every ``log_*`` method is safe to call once per stage.

    ``close()`` writes the blueprint for what was recorded, flushes and finalises the file
    (also after an interrupt, so the partial recording stays readable).
    """

    def __init__(self, path: Path, cfg, background: bool = True):
        """``background``: rerun runs in a worker process (:class:`_WorkerStream`), so the
        run neither imports rerun nor waits for the file until :meth:`close`; ``False``
        logs in this process."""
        t_init = time.perf_counter()
        self.path = Path(path)
        self.cfg = cfg
        self.recording_id = str(uuid.uuid4())   # unique per run; the application id is shared
        stream = dict(application_id="simcalib", recording_id=self.recording_id,
                      send_properties=False)
        self.background = bool(background)
        if self.background:
            try:
                self.rec = _worker_stream(self.path, **stream)
                self.rr = _RRProxy()
            except OSError:   # no process can be started here: log in-process
                self.background = False
        if not self.background:
            import rerun as rr
            self.rr = rr
            self.rec = rr.RecordingStream(**stream)
            self.rec.set_log_time_enabled(False)
            self.rec.save(str(self.path))
        rr = self.rr
        self._closed = False
        self.kind = getattr(cfg, "kind", "sim")
        self.images = False
        self.image_cameras: set = set()   # the cameras that logged images (their panes)
        self.eye = None
        self.closeup_eye = None
        self.room = None                 # (min, max) corners of the room, sim runs
        self._workspace = []             # points the scene view frames
        self.elapsed_s = 0.0             # wall time spent recording (recording_view.json)
        self.stage_s: dict[str, float] = {}   # ... per stage ("init", "close" included)
        self.present: set[str] = set()   # views with data (the blueprint shows only those)
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.rec.log("closeup", rr.ViewCoordinates.RDF, static=True)
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
            log_convergence(self.rec, st.solvers, rr=self.rr)
        elif stage == "evaluation":
            self.log_pose_errors(st.pose_errors)
        elif stage == "reports":
            self.log_summary(summary_markdown(st.result()))

    # ------------------------------------------------------------------ world
    def log_room_and_platform(self, world) -> None:
        """The room (floor solid, walls/ceiling as outlines) and the platform: every moving
        body's geoms logged once in the body frame, the body posed per simulated frame."""
        rr = self.rr
        from simcalib.world.visual import scene_geometry
        frames = world.frames(world.camera_names[0])
        geo = scene_geometry(world.model, frames.qpos, frames.mocap_pos, frames.mocap_quat_wxyz)
        size = np.asarray(world.config.room.size_m, dtype=np.float64)
        self.room = (np.array([-0.5 * size[0], -0.5 * size[1], 0.0]),
                     np.array([0.5 * size[0], 0.5 * size[1], size[2]]))
        for g in geo.static:
            if g.kind != "box":
                continue
            # clip the wall slabs to the room so nothing is drawn outside it
            lo = np.maximum(g.pos - g.size, self.room[0] - 0.02)
            hi = np.minimum(g.pos + g.size, self.room[1] + 0.02)
            floor = g.name == "floor"
            if floor:
                lo[2], hi[2] = -0.01, 0.0
            self.rec.log(f"world/room/{entity_name(g.name)}", rr.Boxes3D(
                centers=[0.5 * (lo + hi)], half_sizes=[0.5 * (hi - lo)],
                colors=[(200, 200, 205) if floor else (150, 150, 150)],
                fill_mode="solid" if floor else "majorwireframe", radii=0.004),
                static=True)
        frame_idx = np.arange(frames.qpos.shape[0], dtype=np.int64)
        for body in geo.bodies:
            ent = f"world/platform/{entity_name(body.name)}"
            T = body.T_world_body
            self.rec.send_columns(ent, indexes=[rr.TimeColumn("frame", sequence=frame_idx)],
                                  columns=rr.Transform3D.columns(   # quaternions: vectorised
                                      translation=T[:, :3, 3],
                                      quaternion=quat_from_matrix(T[:, :3, :3])))
            self._log_geoms(f"{ent}/geoms", body.geoms)
            self._workspace.append(T[:, :3, 3])
        self._update_eye()

    def _log_geoms(self, ent: str, geoms) -> None:
        rr = self.rr
        by_kind: dict[str, list] = {}
        for g in geoms:
            by_kind.setdefault(g.kind, []).append(g)
        for kind, gs in by_kind.items():
            pos = np.array([g.pos for g in gs])
            quat = np.array([g.quat_xyzw for g in gs])
            col = (np.clip(np.array([g.rgba for g in gs]), 0, 1) * 255).astype(np.uint8)
            size = np.array([g.size for g in gs])
            if kind == "box":
                arch = rr.Boxes3D(centers=pos, half_sizes=size, quaternions=quat, colors=col,
                                  fill_mode="solid")
            elif kind == "cylinder":
                arch = rr.Cylinders3D(centers=pos, lengths=2 * size[:, 1], radii=size[:, 0],
                                      quaternions=quat, colors=col, fill_mode="solid")
            elif kind == "capsule":
                from simcalib.geometry import matrix_from_quat
                z = matrix_from_quat(quat)[..., :, 2]
                arch = rr.Capsules3D(translations=pos - z * size[:, 1:2],
                                     lengths=2 * size[:, 1], radii=size[:, 0],
                                     quaternions=quat, colors=col, fill_mode="solid")
            elif kind in ("sphere", "ellipsoid"):
                half = np.repeat(size[:, :1], 3, axis=1) if kind == "sphere" else size
                arch = rr.Ellipsoids3D(centers=pos, half_sizes=half, quaternions=quat,
                                       colors=col, fill_mode="solid")
            elif kind == "mesh":
                for k, g in enumerate(gs):
                    self.rec.log(f"{ent}/{entity_name(g.name)}",
                                 rr.Transform3D(translation=g.pos, quaternion=g.quat_xyzw),
                                 rr.Mesh3D(vertex_positions=g.vertices,
                                           triangle_indices=g.faces,
                                           albedo_factor=tuple(col[k])), static=True)
                continue
            else:   # planes: the room's floor is a box; a plane is drawn as a thin box
                arch = rr.Boxes3D(centers=pos, half_sizes=np.c_[size[:, :2], 0.001 * np.ones(
                    len(gs))], quaternions=quat, colors=col, fill_mode="solid")
            self.rec.log(f"{ent}/{kind}", arch, static=True)

    def log_world(self, marker_field) -> None:
        """The marker field as textured quads (the ArUco pattern with its quiet zone)."""
        rr = self.rr
        if marker_field is None or len(getattr(marker_field, "ids", ())) == 0:
            return
        from simcalib.targets.markers import marker_image
        T = np.asarray(marker_field.T_world_marker)
        cell = 6
        for mid, Tm in zip(marker_field.ids, T):
            img = marker_image(int(mid), pixels=8 * cell, dictionary=marker_field.dictionary)
            img = np.pad(img, cell, constant_values=255)
            n_cells = img.shape[0] / cell
            h = 0.5 * float(marker_field.side_m) * n_cells / (n_cells - 2)
            local = np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])
            verts = local @ Tm[:3, :3].T + Tm[:3, 3] + 0.003 * Tm[:3, 2]
            self.rec.log(f"world/markers/{int(mid)}", rr.Mesh3D(
                vertex_positions=verts, triangle_indices=[[0, 2, 1], [0, 3, 2]],
                vertex_texcoords=[[0, 0], [1, 0], [1, 1], [0, 1]],
                albedo_texture=np.repeat(img[:, :, None], 3, axis=2)), static=True)

    # ----------------------------------------------------------- trajectories
    def log_trajectories(self, gt: dict, source: dict, X_true) -> None:
        rr = self.rr
        scale = 0.08
        pts = [np.asarray(s.T_world_cam)[:, :3, 3] for s in gt.values()]
        if pts:
            allp = np.concatenate(pts)
            ext = float(np.linalg.norm(allp.max(0) - allp.min(0))) if len(allp) else 1.0
            scale = float(np.clip(0.04 * ext, 0.02, 0.1))
        for cam, s in gt.items():
            color = _COLORS.get(cam, (200, 200, 200))
            T = np.asarray(s.T_world_cam)
            self._workspace.append(T[:, :3, 3])
            self.rec.log(f"world/trajectories/{cam}/ground_truth",
                         rr.LineStrips3D([T[:, :3, 3]], colors=color, radii=0.1 * scale,
                                         labels=[f"{cam} true path"], show_labels=False),
                         static=True)
            frames = np.asarray(s.frame_index, dtype=np.int64)
            self.rec.send_columns(
                f"world/{cam}",
                indexes=[rr.TimeColumn("frame", sequence=frames),
                         rr.TimeColumn("sim_time", duration=np.asarray(s.timestamp_s,
                                                                        dtype=np.float64))],
                columns=rr.Transform3D.columns(translation=T[:, :3, 3],
                                               quaternion=quat_from_matrix(T[:, :3, :3])))
            self.rec.log(f"world/{cam}/axes", rr.TransformAxes3D(1.5 * scale), static=True)
        for cam, s in source.items():
            color = tuple(int(0.55 * c) for c in _COLORS.get(cam, (200, 200, 200)))
            T = np.asarray(s.T_world_cam)
            if T.shape[0] == 0:
                continue
            p = T[:, :3, 3]
            if self.room is not None:   # a wild pose-source sample must not zoom the view out
                p = np.clip(p, self.room[0], self.room[1])
            self.rec.log(f"world/trajectories/{cam}/{s.source}",
                         rr.Points3D(p, colors=color, radii=0.12 * scale), static=True)
        self._update_eye()

    def _update_eye(self) -> None:
        if not self._workspace:
            return
        self.present.add("scene")
        p = np.concatenate(self._workspace)
        lo, hi = p.min(0), p.max(0)
        if self.room is not None:
            lo = np.minimum(lo, [lo[0], lo[1], 0.0])     # include the floor under the platform
            self.eye = _eye(lo, hi, (-1.0, -1.4, 1.0), (0, 0, 1), inside=self.room,
                            min_dist=2.5)
        else:
            self.eye = _eye(lo, hi, (-1.0, -1.4, 0.9), (0, 0, 1))

    # ---------------------------------------------------------------- cameras
    def log_cameras(self, intrinsics: dict, gt: dict, visual_log) -> None:
        """Pinholes of both cameras, and (aruco source) the logged images and corners."""
        rr = self.rr
        intrinsics = dict(getattr(visual_log, "intrinsics", None) or intrinsics or {})
        for cam, K in intrinsics.items():
            self.rec.log(f"world/{cam}/image",
                         rr.Pinhole(image_from_camera=np.asarray(K.K),
                                    resolution=[K.width, K.height],
                                    image_plane_distance=0.15,
                                    color=_COLORS.get(cam, (200, 200, 200))), static=True)
        if visual_log is None:
            return
        for cam, frame, image, corners, ids in _iter_visual_log(visual_log,
                                                                self.cfg.recording):
            self.rec.set_time("frame", sequence=int(frame))
            ent = f"world/{cam}/image"
            if image is not None:
                self.images = True
                self.image_cameras.add(cam)
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
    def log_estimates(self, solvers, X_true, gt: dict | None = None) -> None:
        """The extrinsic close-up (camera a frame) and the per-solver error table.

        Estimates that agree within ``0.3 L`` (L: the axis length) share one label listing
        their names; every label is placed on the screen of the close-up's eye
        (:func:`_place_labels`) so that no two labels overlap, each joined to what it
        names by a leader line. Estimates beyond :func:`closeup_bound_m` are drawn at the
        bound (off-scale); uncertainty ellipsoids are bounded the same way
        (:meth:`_log_ellipsoid`)."""
        rr = self.rr
        X_true = np.asarray(X_true, dtype=np.float64)
        t_true = X_true[:3, 3]
        self.present.add("closeup")
        bound = closeup_bound_m(np.linalg.norm(t_true))
        L = float(np.clip(0.3 * np.linalg.norm(t_true), 0.02, 0.15))   # axis length
        ok = [s for s in solvers if s.X is not None and np.isfinite(s.X).all()]
        failed = [s for s in solvers if s not in ok]
        self.rec.log("closeup/cam_a", rr.TransformAxes3D(L), rr.Points3D(
            [[0.0, 0.0, 0.0]], radii=0.1 * L, colors=_COLORS["cam_a"]), static=True)
        self._log_pose("closeup/true_cam_b", X_true, static=True)
        self.rec.log("closeup/true_cam_b", rr.TransformAxes3D(1.3 * L), rr.Points3D(
            [[0.0, 0.0, 0.0]], radii=0.12 * L, colors=_TRUE_COLOR), static=True)
        extent = [np.zeros(3), t_true]
        groups: list[list] = []          # estimates on top of each other share one label
        offscale: list[list] = []        # so do off-scale markers at the same place
        notes: dict[str, list[str]] = {}  # off-scale uncertainty, per solver
        for k, s in enumerate(ok):
            t = np.asarray(s.X)[:3, 3]
            color = _SOLVER_COLORS[k % len(_SOLVER_COLORS)]
            name = entity_name(s.label)
            if np.linalg.norm(t) > bound:
                p = t / np.linalg.norm(t) * bound
                for grp in offscale:
                    if np.linalg.norm(grp[0][1] - p) < 0.3 * L:
                        grp.append((s, p))
                        break
                else:
                    offscale.append([(s, p)])
                continue
            ent = f"closeup/estimates/{name}"
            self._log_pose(ent, np.asarray(s.X), static=True)
            self.rec.log(ent, rr.TransformAxes3D(L), rr.Points3D(
                [[0.0, 0.0, 0.0]], radii=0.08 * L, colors=color), static=True)
            extent.append(t)
            for grp in groups:
                if np.linalg.norm(grp[0][1] - t) < 0.3 * L:
                    grp.append((s, t, color))
                    break
            else:
                groups.append([(s, t, color)])
            cov = getattr(s, "covariance", None)
            if cov is not None:
                notes[s.label] = self._log_ellipsoid(
                    f"closeup/uncertainty/{name}", np.asarray(cov), t, bound, L, color,
                    s.label)
        for j, grp in enumerate(offscale):
            p = grp[0][1]
            self.rec.log(f"closeup/offscale/{j}", rr.Points3D(
                [p], radii=0.2 * L, colors=_OFFSCALE_COLOR), rr.Arrows3D(
                origins=[0.85 * p], vectors=[0.15 * p], colors=_OFFSCALE_COLOR), static=True)
            extent.append(p)
        self.closeup_extent = np.array(extent)
        lo, hi = self.closeup_extent.min(0) - L, self.closeup_extent.max(0) + L
        self.closeup_eye = _eye(lo, hi, (-0.35, -0.5, -1.0), (0, -1, 0))

        # the labels: (entity, anchor, text lines, leader colour)
        cam_lines = ["cam a (origin)"]
        if failed:
            cam_lines.append("FAILED, not drawn: " + ", ".join(s.label for s in failed))
        labels = [("cam_a", np.zeros(3), cam_lines, _COLORS["cam_a"]),
                  ("true_cam_b", t_true, ["true cam b"], _TRUE_COLOR)]
        for j, grp in enumerate(groups):
            names = [s.label for s, _, _ in grp]
            lines = _wrap(", ".join(names))
            same = len({tuple(notes.get(n, [])) for n in names}) == 1
            for n in names[:1] if same else names:   # the same notes once for the group
                lines += [x if same else f"{n}: {x}" for x in notes.get(n, [])]
            labels.append((f"{j}", grp[0][1], lines, grp[0][2]))
        for j, grp in enumerate(offscale):   # the real errors of what is drawn at the bound
            labels.append((f"offscale_{j}", grp[0][1],
                           [f"OFF-SCALE (drawn at {bound:g} m), real error:"]
                           + [f"{s.label}: {_fmt(s.rotation_error_deg)}° / "
                              f"{_fmt_len_cm(s.translation_error_m)}" for s, _ in grp],
                           _OFFSCALE_COLOR))
        placed = _place_labels(self.closeup_eye, [(a, lines) for _, a, lines, _ in labels],
                               max_norm=1.4 * bound)
        for (key, anchor, lines, color), p in zip(labels, placed):
            leader = None
            if np.linalg.norm(p - anchor) > 0.2 * L:
                leader = rr.LineStrips3D([[anchor, p]], colors=color, radii=0.006 * L)
            self.rec.log(f"closeup/labels/{key}", *[a for a in (rr.Points3D(
                [p], radii=0.02 * L, colors=_LABEL_COLOR, labels=["\n".join(lines)]), leader)
                if a is not None], static=True)
        for s in ok:
            self.rec.log(f"errors/{entity_name(s.label)}/rotation_deg",
                         rr.Scalars([s.rotation_error_deg]), static=True)
            self.rec.log(f"errors/{entity_name(s.label)}/translation_cm",
                         rr.Scalars([100.0 * s.translation_error_m]), static=True)

    def _log_ellipsoid(self, ent, cov, center, bound, L, color, label) -> list[str]:
        """The 3-sigma ellipsoid of the translation block (rows/cols 3..5 of the 6x6
        covariance of (omega, v) in frame a), bounded like the estimates: a half-axis is
        clipped so the ellipsoid stays inside the close-up's bound (a red arrow at each
        clipped end marks it off-scale); an undetermined (infinite) axis is no part of the
        ellipsoid but a red double arrow through the estimate. Returns the label notes
        (e.g. ``3σ 1.4 m along y: off-scale``, ``σ = ∞ along x, y, z``)."""
        rr = self.rr
        C = np.asarray(cov, dtype=np.float64)
        if C.shape != (6, 6):
            return []
        Ct = 0.5 * (C[3:, 3:] + C[3:, 3:].T)
        inf_axes = ~np.isfinite(np.diag(Ct)) | (np.diag(Ct) > 1e12)
        # principal axes of the determined coordinates; the undetermined ones as they are
        fin = np.flatnonzero(~inf_axes)
        sub = np.where(np.isfinite(Ct), Ct, 0.0)[np.ix_(fin, fin)]
        w_f, V_f = np.linalg.eigh(sub) if fin.size else (np.zeros(0), np.zeros((0, 0)))
        w, V = np.zeros(3), np.zeros((3, 3))
        w[:fin.size] = w_f
        V[np.ix_(fin, np.arange(fin.size))] = V_f
        V[np.flatnonzero(inf_axes), np.arange(fin.size, 3)] = 1.0
        undetermined = np.arange(3) >= fin.size
        if np.linalg.det(V) < 0:
            V[:, 0] = -V[:, 0]
        half_real = 3.0 * np.sqrt(np.clip(w, 0.0, None))
        cap = max(bound - float(np.linalg.norm(center)), 0.25 * bound)
        clipped = ~undetermined & (half_real > cap)
        half = np.where(undetermined, 0.0, np.minimum(half_real, cap))
        notes, arrows_o, arrows_v = [], [], []
        for i in np.flatnonzero(clipped):
            notes.append(f"3σ {_fmt_len_m(half_real[i])} along {_axis_name(V[:, i])}: "
                         f"off-scale (drawn at {_fmt_len_m(cap)})")
            for sgn in (1.0, -1.0):
                arrows_o.append(center + sgn * cap * V[:, i])
                arrows_v.append(sgn * 0.6 * L * V[:, i])
        if undetermined.any():
            notes.append("σ = ∞ along " + ", ".join(_axis_name(V[:, i])
                                                     for i in np.flatnonzero(undetermined)))
            for i in np.flatnonzero(undetermined):
                for sgn in (1.0, -1.0):
                    arrows_o.append(center + sgn * 0.3 * L * V[:, i])
                    arrows_v.append(sgn * 1.2 * L * V[:, i])
        sigma = np.sqrt(np.clip(np.diag(Ct), 0, None))
        text = (f"{label} 3σ: σ = " + ", ".join("∞" if u else f"{100 * v:.2g}"
                                                 for u, v in zip(inf_axes, sigma)) + " cm")
        if not undetermined.all():
            self.rec.log(ent, rr.Ellipsoids3D(
                centers=[center], half_sizes=[np.maximum(half, 1e-4)],
                quaternions=[quat_from_matrix(V)], colors=[(*color, 90)],
                fill_mode="transparentfillmajorwireframe", labels=[text], show_labels=False),
                static=True)
        if arrows_o:
            self.rec.log(f"{ent}/offscale", rr.Arrows3D(
                origins=arrows_o, vectors=arrows_v, colors=_OFFSCALE_COLOR,
                radii=0.02 * L, labels=[text] * len(arrows_o), show_labels=False),
                static=True)
        return notes

    def _log_pose(self, entity: str, T: np.ndarray, static: bool = False) -> None:
        rr = self.rr
        self.rec.log(entity, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                     static=static)

    # ------------------------------------------------------------ pose error
    def log_pose_errors(self, pose_errors: dict) -> None:
        """One plot per unit (``pose_error/rotation_deg``, ``pose_error/translation_mm``),
        one named series per camera in the camera's colour."""
        rr = self.rr
        for cam, e in pose_errors.items():
            if e.n == 0:
                continue
            frames = np.asarray(e.frame_index, dtype=np.int64)
            for name, values, unit, what in (("rotation_deg", e.rotation_deg, 1.0, "deg"),
                                             ("translation_mm", e.translation_m, 1000.0,
                                              "mm")):
                ent = f"pose_error/{name}/{cam}"
                self.present.add("pose_error")
                self.rec.log(ent, rr.SeriesLines(names=f"{cam} ({e.source}) [{what}]",
                                                 colors=_COLORS.get(cam, (200, 200, 200))),
                             static=True)
                self.rec.send_columns(ent, indexes=[rr.TimeColumn("frame", sequence=frames)],
                                      columns=rr.Scalars.columns(
                                          scalars=np.asarray(values, dtype=np.float64) * unit))

    def log_summary(self, markdown: str) -> None:
        rr = self.rr
        self.present.add("summary")
        self.rec.log("summary", rr.TextDocument(markdown, media_type="text/markdown"),
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
                if self.background:
                    self.rec.finish()    # raises when the worker reported an error
                else:
                    self.rec.flush()
                    self.rec.disconnect()
            finally:
                self.stage_s["close"] = time.perf_counter() - t0
                self.elapsed_s += self.stage_s["close"]
        # the views' framing, for tools that open one view alone (tools/screenshots.py),
        # and the cost: recording_s = wall time the run spent recording (with the worker:
        # handing it the data, and waiting at the end); worker = the worker's own times
        import json
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


def summary_markdown(result) -> str:
    """The console summary (:func:`simcalib.report.console.summary_table`) as markdown: one table
    row per solver with its errors and log-scale bars (FAILED rows in bold, their reason
    below; degenerate ones flagged), then the undetermined directions, frames, motion pairs
    and pose-source errors."""
    cfg = result.config
    solvers = list(result.solvers)
    ok = [s for s in solvers if s.X is not None]
    alphas = sorted({s.alpha for s in ok if s.alpha is not None})
    rlo, rhi = _decades([s.rotation_error_deg for s in ok])
    tlo, thi = _decades([100 * s.translation_error_m for s in ok])
    out = [f"**{cfg.scenario}** — kind {cfg.kind}, source {cfg.source}, seed {cfg.seed}, "
           f"{(result.pairing or {}).get('used', '?')} motions, alpha "
           f"{', '.join(_fmt(a) for a in alphas) or '–'}", "",
           "| method | rot err [deg] | log | trans err [cm] | log | determined [cm] "
           "| degenerate |", "|---|---:|:---|---:|:---|---:|:---:|"]
    notes = []
    for s in solvers:
        if s.X is None:
            reason = (s.error or "no estimate").replace("|", "/")
            if len(reason) > 160:
                reason = reason[:157] + "..."
            out.append(f"| **{s.label}** | **FAILED** | | | | | |")
            notes.append(f"**{s.label} FAILED**: {reason}")
            continue
        det = s.translation_error_determined_m
        t_cm = 100 * s.translation_error_m
        out.append(f"| {s.label} | {_fmt(s.rotation_error_deg)} | "
                   f"{_log_bar(s.rotation_error_deg, rlo, rhi)} | {_fmt(t_cm)} | "
                   f"{_log_bar(t_cm, tlo, thi)} | {_fmt(None if det is None else 100 * det)} | "
                   f"{ {True: '**YES**', False: 'no'}.get(s.degenerate, 'unknown')} |")
    if ok:
        notes.append(f"log bars: rotation 1e{int(rlo)}–1e{int(rhi)} deg, translation "
                     f"1e{int(tlo)}–1e{int(thi)} cm")
    undet = {}
    for s in result.solvers:
        if s.degenerate:
            key = tuple(d["description"] for d in s.undetermined_directions) \
                or tuple(s.undetermined)
            undet.setdefault(key, []).append(s.label)
    for dirs, labels in undet.items():
        notes.append(f"undetermined by this motion ({', '.join(labels)}): " + "; ".join(dirs)
                     + " — not a measurement; *determined* = error with it projected out")
    fr = result.frames or {}
    if fr.get("rendered"):
        cams = [f"{c} used {(fr.get(c) or {}).get('used')}, dropped "
                f"{(fr.get(c) or {}).get('dropped')}" for c in result.camera_names]
        notes.append(f"frames: {fr['rendered']} per camera; " + "; ".join(cams))
    p = result.pairing or {}
    if p.get("candidate_pairs") is not None:
        notes.append(f"motion pairs: {p.get('used')} used of {p.get('candidate_pairs')} "
                     f"candidates")
    for cam, e in (result.pose_errors or {}).items():
        if getattr(e, "n", 0):
            sm = e.summary()
            notes.append(f"pose error {cam} ({e.source}): median "
                         f"{_fmt(sm['rotation_deg']['median'])} deg / "
                         f"{_fmt(1000 * sm['translation_m']['median'])} mm")
    return "\n".join(out + [""] + [f"- {n}" for n in notes])


# ---------------------------------------------------------------------------- sweeps
def _sweep_per_axis(summary: dict) -> dict:
    per_axis = summary.get("per_axis", summary) if isinstance(summary, dict) else None
    if not isinstance(per_axis, dict):
        raise TypeError(f"summary must be a dict (simcalib.studies.sweep.report.summarise output or "
                        f"its 'per_axis'); received {type(summary).__name__}")
    return per_axis



def _open_recording(rr, application_id: str, path, **save_kwargs):
    """A new recording stream (unique recording id, no log-time timeline) saving to
    ``path``: how every self-contained recording of this module is opened."""
    rec = rr.RecordingStream(application_id, recording_id=str(uuid.uuid4()),
                             send_properties=False)
    if hasattr(rec, "set_log_time_enabled"):
        rec.set_log_time_enabled(False)
    rec.save(str(path), **save_kwargs)
    return rec

def record_sweep(path, summary: dict) -> Path:
    """Write ``path`` (.rrd): a sweep's per-axis, per-solver median and IQR series.

    ``summary``: ``{"per_axis": {axis: {value: {solver: stats}}}}`` (the output of
    ``simcalib.studies.sweep.report.summarise``) or that ``per_axis`` dict itself; ``stats`` holds
    ``rot_med``, ``rot_q1``, ``rot_q3`` (deg), ``tr_med``, ``tr_q1``, ``tr_q3`` (m) and
    optionally ``failed`` (fraction). Timeline ``sweep_index`` = position of the value in
    the axis (sorted); ``sweep/<axis>/values`` maps indices to values. Errors are plotted
    as log10 (one plot per axis and quantity: ``sweep/<axis>/log10_rotation_deg/<solver>/
    median|q1|q3``, ``.../log10_translation_cm/...``), failure rates linearly."""
    import rerun as rr
    import rerun.blueprint as rrb
    per_axis = _sweep_per_axis(summary)
    path = Path(path)
    rec = _open_recording(rr, "simcalib_sweep", path)
    views = []
    try:
        for axis, by_value in per_axis.items():
            values = list(by_value)
            numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool)
                          for v in values)
            values = sorted(values) if numeric else sorted(values, key=str)
            solvers = sorted({s for v in values for s in by_value[v]})
            a = entity_name(str(axis))
            rec.log(f"sweep/{a}/values", rr.TextDocument(
                f"**{axis}** (x axis = index)\n\n| index | value |\n|---:|---|\n" + "\n".join(
                    f"| {i} | {v} |" for i, v in enumerate(values)),
                media_type="text/markdown"), static=True)
            for k, solver in enumerate(solvers):
                color = _SOLVER_COLORS[k % len(_SOLVER_COLORS)]
                sname = entity_name(solver)
                for key, qty, scale in (("rot", "log10_rotation_deg", 1.0),
                                        ("tr", "log10_translation_cm", 100.0)):
                    for q, width in (("med", 2.5), ("q1", 0.8), ("q3", 0.8)):
                        ent = f"sweep/{a}/{qty}/{sname}/{'median' if q == 'med' else q}"
                        label = f"{solver} {'median' if q == 'med' else q}"
                        rec.log(ent, rr.SeriesLines(names=label, colors=color, widths=width),
                                static=True)
                        for i, v in enumerate(values):
                            st = by_value[v].get(solver)
                            x = None if st is None else st.get(f"{key}_{q}")
                            if x is None or not np.isfinite(x) or x * scale <= 0:
                                continue
                            rec.set_time("sweep_index", sequence=i)
                            rec.log(ent, rr.Scalars([math.log10(x * scale)]))
                ent = f"sweep/{a}/failed/{sname}"
                rec.log(ent, rr.SeriesLines(names=f"{solver} failed", colors=color),
                        static=True)
                for i, v in enumerate(values):
                    st = by_value[v].get(solver) or {}
                    if st.get("failed") is not None and np.isfinite(st["failed"]):
                        rec.set_time("sweep_index", sequence=i)
                        rec.log(ent, rr.Scalars([float(st["failed"])]))
            rec.reset_time()
            views.append(rrb.Horizontal(
                rrb.TimeSeriesView(origin=f"sweep/{a}/log10_rotation_deg",
                                   name=f"{axis}: log10 rotation error [deg] (median, IQR)"),
                rrb.TimeSeriesView(origin=f"sweep/{a}/log10_translation_cm",
                                   name=f"{axis}: log10 translation error [cm] (median, IQR)"),
                rrb.TimeSeriesView(origin=f"sweep/{a}/failed", name=f"{axis}: failure rate"),
                rrb.TextDocumentView(origin=f"sweep/{a}/values", name=f"{axis} values"),
                column_shares=[3, 3, 2, 1]))
        if views:
            rec.send_blueprint(rrb.Blueprint(rrb.Vertical(*views), rrb.TimePanel(
                timeline="sweep_index", state="collapsed"), rrb.BlueprintPanel(
                state="collapsed"), rrb.SelectionPanel(state="collapsed"), auto_views=False))
        rec.flush()
    finally:
        rec.disconnect()
    return path


# ----------------------------------------------------------------------- experiments
def log_experiment(path, name: str, pngs: dict, documents: dict) -> Path:
    """Write ``path`` (.rrd): an experiment's figures (PNG, ``figures/<key>``) and markdown
    tables (``tables/<key>``), laid out as a grid of figures above tabs of tables."""
    import rerun as rr
    import rerun.blueprint as rrb
    path = Path(path)
    rec = _open_recording(rr, f"simcalib_experiment_{name}", path)
    try:
        for key, png in pngs.items():
            rec.log(f"figures/{entity_name(key)}", rr.EncodedImage(path=str(png)), static=True)
        for key, text in documents.items():
            rec.log(f"tables/{entity_name(key)}",
                    rr.TextDocument(text, media_type="text/markdown"), static=True)
        figs = [rrb.Spatial2DView(origin=f"figures/{entity_name(k)}", name=k) for k in pngs]
        docs = [rrb.TextDocumentView(origin=f"tables/{entity_name(k)}", name=k)
                for k in documents]
        parts = ([rrb.Grid(*figs)] if figs else []) + ([rrb.Tabs(*docs)] if docs else [])
        if parts:
            rec.send_blueprint(rrb.Blueprint(
                rrb.Vertical(*parts, row_shares=[3, 2][:len(parts)]),
                rrb.TimePanel(state="hidden"), rrb.BlueprintPanel(state="collapsed"),
                rrb.SelectionPanel(state="collapsed"), auto_views=False))
        rec.flush()
    finally:
        rec.disconnect()
    return path


def log_convergence(rec, solvers, rr=None) -> None:
    """Issue 9: error and predicted 1-sigma against the number of motions used (k), one
    named series per solver, on the ``motions`` timeline: ``convergence/rotation_deg/
    <solver>/{error,sigma}`` and ``convergence/translation_cm/<solver>/{error,sigma}``
    (from ``SolverResult.convergence``; failed or undetermined points are left out).
    ``rr``: the rerun module (or the recorder's stand-in for it)."""
    if rr is None:
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
    stage's :class:`~simcalib.sources.vision.stream.VisualLog` (``frames[camera]``: per-frame records with
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


# ------------------------------------------------ calibrate command
#: colours of the calibration recording, one per pane (the screenshot check counts them)
CALIBRATION_COLORS = {
    "b_from_a": (240, 150, 40),        # a's poses through X: where b should be
    "b_measured": (40, 140, 230),      # b's measured poses mapped into a's world
    "rejected": (235, 40, 40),         # rejected poses (3D) and motions (plots)
    "rotation": (60, 190, 110),        # inlier rotation residuals
    "translation": (190, 110, 240),    # inlier translation residuals
    "correlation": (40, 190, 200),     # correlation inside the plausibility window
    "outside": (110, 110, 120),        # correlation outside it
    "peak": (235, 40, 40),             # the correlation's own peak
    "chosen": (250, 205, 40),          # the offset used
}
CALIBRATION_BACKGROUND = (24, 26, 30)
#: the one pane each colour identifies (views that must show their data)
CALIBRATION_PANE_COLORS = {"trajectories": ("b_from_a", "b_measured"),
                           "rotation residuals": ("rotation",),
                           "translation residuals": ("translation",),
                           "correlation over lag": ("correlation",)}


def rejected_instants(n: int, i, j, inlier) -> np.ndarray:
    """(n,) bool: synchronised instants that some motion uses and no inlier motion does
    (the poses the rejection threw out; instants no motion uses are not rejected)."""
    i, j = np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64)
    inlier = np.asarray(inlier, dtype=bool)
    used, good = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    used[i] = used[j] = True
    good[i[inlier]] = good[j[inlier]] = True
    return used & ~good


def trajectory_strips(points, keep, time_s, max_skip: int = 3) -> list[np.ndarray]:
    """The kept ``points`` as polylines: a rejected instant is left out and its neighbours
    joined; a strip breaks where more than ``max_skip`` instants in a row are left out or
    where the time between kept instants exceeds 10 median steps (a gap in the data)."""
    idx = np.flatnonzero(np.asarray(keep, dtype=bool))
    if idx.size == 0:
        return []
    t = np.asarray(time_s, dtype=np.float64)
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    brk = np.diff(idx) > max_skip + 1
    if step > 0:
        brk |= np.diff(t[idx]) > 10.0 * step
    return [np.asarray(points)[seg] for seg in np.split(idx, np.flatnonzero(brk) + 1)
            if seg.size >= 2]


@dataclass
class CalibrationScene:
    """What the calibration recording's 3D view draws, in a's world: ``b_from_a``
    (``T_wa_a X``, N x 4 x 4), ``b_measured`` (``T_wa_wb T_wb_b``), ``rejected`` (N,) bool,
    ``eye`` (orbital eye on the kept poses) and ``axis_m`` (axes length)."""
    time_s: np.ndarray
    T_a: np.ndarray
    b_from_a: np.ndarray
    b_measured: np.ndarray
    rejected: np.ndarray
    eye: dict
    axis_m: float


def calibration_scene(r) -> CalibrationScene:
    """:class:`CalibrationScene` of a :class:`simcalib.estimation.path.StreamCalibration`:
    the synchronised poses (at the estimated offset) through X and through the world-to-world
    transform X implies; the eye frames the kept poses' 2..98 % box (rejected poses, which
    may lie far off, do not zoom it out)."""
    from simcalib.estimation.path import align_worlds
    sp, ms = r.synced, r.motions
    T_a, T_b = np.asarray(sp.T_a, np.float64), np.asarray(sp.T_b, np.float64)
    X = np.asarray(r.X, dtype=np.float64)
    rej = rejected_instants(sp.n, ms.i, ms.j, r.robust.inlier_mask)
    b_from_a, b_meas = T_a @ X, align_worlds(T_a[~rej], T_b[~rej], X) @ T_b
    P = np.concatenate([b_from_a[~rej, :3, 3], b_meas[~rej, :3, 3], T_a[~rej, :3, 3]])
    lo, hi = np.percentile(P, 2, axis=0), np.percentile(P, 98, axis=0)
    ext = max(float(np.linalg.norm(hi - lo)), 0.05)
    eye = _eye(lo, hi, (1.0, -1.3, 0.9), (0.0, 0.0, 1.0))
    eye["position"] = (np.asarray(eye["look_target"]) + 0.75 * (
        np.asarray(eye["position"]) - np.asarray(eye["look_target"]))).tolist()
    return CalibrationScene(_since_start(r), T_a, b_from_a, b_meas, rej,
                            eye, 0.1 * ext)


def calibration_blueprint(r, only: str | None = None, rrb=None):
    """The layout the calibration recording opens on: left the trajectories (3D, a's world)
    above the summary, right the inlier residuals (rotation, translation) and the
    angular-speed correlation over the lag (when the offset was estimated from it).
    ``only="world"``: the 3D view alone (the screenshot tool's framing check)."""
    if rrb is None:
        import rerun.blueprint as rrb
    e = calibration_scene(r).eye
    world = rrb.Spatial3DView(
        origin="world", name="b through X (orange) and b measured (blue), a's world; "
        "rejected poses red", background=CALIBRATION_BACKGROUND,
        line_grid=rrb.LineGrid3D(visible=False), eye_controls=rrb.EyeControls3D(
            kind=rrb.Eye3DKind.Orbital, position=e["position"], look_target=e["look_target"],
            eye_up=e["eye_up"]))
    tail = (rrb.TimePanel(timeline="time", state="hidden" if only else "collapsed",
                          play_state="paused"),
            rrb.BlueprintPanel(state="hidden" if only else "collapsed"),
            rrb.SelectionPanel(state="hidden" if only else "collapsed"))
    if only == "world":
        return rrb.Blueprint(world, *tail, rrb.TopPanel(state="hidden"), auto_views=False)
    if only is not None:
        raise ValueError(f"only must be None or 'world'; received {only!r}")
    caps = _residual_caps(r)
    import rerun.encodings as enc
    everything = enc.TimeRange(start=enc.TimeRangeBoundary.infinite(),
                               end=enc.TimeRangeBoundary.infinite())
    plots = [rrb.TimeSeriesView(
        origin=f"residuals/{q}", axis_x=rrb.TimeAxis(view_range=everything), name=f"motion residuals: {q.replace('_', ' [')}] of the "
        f"inliers; rejected (red) drawn at most at the top", axis_y=rrb.ScalarAxis(
            range=(0.0, caps[q]), zoom_lock=False)) for q in ("rotation_deg", "translation_mm")]
    if _has_correlation(r.time_offset):
        plots.append(rrb.BarChartView(
            origin="time_offset", name="angular-speed correlation over lag [s]: window "
            "(teal), its peak (red), offset used (yellow)"))
    summary = rrb.TextDocumentView(origin="summary", name="summary")
    body = rrb.Horizontal(rrb.Vertical(world, summary, row_shares=[5, 3]),
                          rrb.Vertical(*plots), column_shares=[11, 9])
    return rrb.Blueprint(body, *tail, auto_views=False)


def save_calibration_blueprint(r, path, only: str | None = None) -> Path:
    """Write :func:`calibration_blueprint` to a blueprint file (``.rbl``) for
    ``rerun recording.rrd FILE.rbl``."""
    calibration_blueprint(r, only).save("simcalib", str(path))
    return Path(path)


def _since_start(r) -> np.ndarray:
    """The synchronised instants in seconds since the first (clock a): the ``time``
    timeline (file stamps may be epoch seconds)."""
    t = np.asarray(r.synced.time_s, dtype=np.float64)
    return t - t[0] if t.size else t


def _has_correlation(off) -> bool:
    lags, corr = np.asarray(off.lags_s, np.float64), np.asarray(off.correlation, np.float64)
    return lags.size > 1 and lags.size == corr.size and bool(np.isfinite(corr).any())


def _residuals(r) -> dict:
    """Per-motion residuals of ``C X = X H``: ``{"rotation_deg", "translation_mm"}``."""
    from simcalib.solvers.robust import constraint_errors
    rot, trans = constraint_errors(r.C, r.H, r.X)
    return {"rotation_deg": np.degrees(rot), "translation_mm": 1e3 * np.asarray(trans)}


def _residual_caps(r) -> dict:
    """The top of each residual plot: 1.25 x the largest inlier residual (all motions'
    when none is an inlier), so that rejected motions do not flatten the inliers."""
    inl = np.asarray(r.robust.inlier_mask, dtype=bool)
    out = {}
    for q, v in _residuals(r).items():
        base = v[inl] if inl.any() else v
        base = base[np.isfinite(base)]
        out[q] = float(1.25 * base.max()) if base.size and base.max() > 0 else 1.0
    return out


def _log_scene(rec, rr, sc: CalibrationScene) -> None:
    """The 3D view: both kept trajectories, the rejected poses as marks, the rig (a, b
    through X and the link) per synchronised instant."""
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    keep = ~sc.rejected
    for name, T, radius in (("b_from_a", sc.b_from_a, 0.004), ("b_measured", sc.b_measured,
                                                              0.002)):
        strips = trajectory_strips(T[:, :3, 3], keep, sc.time_s)
        rec.log(f"world/{name}/trajectory", rr.LineStrips3D(
            strips, colors=CALIBRATION_COLORS[name], radii=radius * sc.axis_m / 0.08),
            static=True)
    if sc.rejected.any():
        rec.log("world/rejected/poses", rr.Points3D(
            sc.b_from_a[sc.rejected, :3, 3], colors=CALIBRATION_COLORS["rejected"],
            radii=0.05 * sc.axis_m), static=True)
    t = rr.TimeColumn("time", duration=sc.time_s)
    for name, T in (("rig/a", sc.T_a), ("rig/b_measured", sc.b_measured)):
        rec.send_columns(f"world/{name}", indexes=[t], columns=rr.Transform3D.columns(
            translation=T[:, :3, 3], mat3x3=T[:, :3, :3]))
        rec.log(f"world/{name}", rr.TransformAxes3D(sc.axis_m), static=True)
    X = np.linalg.solve(sc.T_a[0], sc.b_from_a[0])
    rec.log("world/rig/a/b_through_X", rr.Transform3D(translation=X[:3, 3], mat3x3=X[:3, :3]),
            rr.TransformAxes3D(sc.axis_m), static=True)
    rec.log("world/rig/a/link", rr.LineStrips3D([[[0, 0, 0], X[:3, 3]]], colors=(
        235, 235, 235), radii=0.03 * sc.axis_m), static=True)


def _log_residuals(rec, rr, r) -> None:
    """Residual plots (timeline ``time`` = the motion's start): inliers in their colour,
    rejected motions as red crosses at ``min(value, top of the plot)``."""
    t_start = _since_start(r)[np.asarray(r.motions.i)]
    inl = np.asarray(r.robust.inlier_mask, dtype=bool)
    caps = _residual_caps(r)
    for q, v in _residuals(r).items():
        color = CALIBRATION_COLORS["rotation" if q == "rotation_deg" else "translation"]
        for part, m, style in (("inliers", inl, dict(colors=color, marker_sizes=2.0)),
                               ("rejected", ~inl, dict(colors=CALIBRATION_COLORS["rejected"],
                                                       markers="cross", marker_sizes=4.0))):
            if not m.any():
                continue
            ent = f"residuals/{q}/{part}"
            rec.log(ent, rr.SeriesPoints(names=f"{part} ({int(m.sum())})", **style),
                    static=True)
            rec.send_columns(ent, indexes=[rr.TimeColumn("time", duration=t_start[m])],
                             columns=rr.Scalars.columns(scalars=np.minimum(v[m], caps[q])))


def _log_correlation(rec, rr, off) -> None:
    """The angular-speed correlation over the lag as bars (``time_offset/window``: inside
    the plausibility window, ``time_offset/outside``: outside it), its peak inside the
    window (``time_offset/peak``) and the offset used (``time_offset/chosen``, full height)."""
    if not _has_correlation(off):
        return
    lags, corr = np.asarray(off.lags_s, np.float64), np.asarray(off.correlation, np.float64)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    lo, hi = off.window_s
    inside = (lags >= lo) & (lags <= hi)
    width = float(np.median(np.diff(lags)))
    for name, m in (("window", inside), ("outside", ~inside)):
        rec.log(f"time_offset/{name}", rr.BarChart(
            np.where(m, corr, 0.0), abscissa=lags, widths=np.full(lags.size, width),
            color=CALIBRATION_COLORS["correlation" if name == "window" else "outside"]),
            static=True)
    k = int(np.argmax(np.where(inside, corr, -np.inf))) if inside.any() else int(
        np.argmax(corr))
    span = max(float(lags[-1] - lags[0]), width)
    for name, x, y in (("peak", lags[k], corr[k]), ("chosen", off.offset_s, 1.0)):
        rec.log(f"time_offset/{name}", rr.BarChart(
            [float(y)], abscissa=[float(x)], widths=[0.006 * span],
            color=CALIBRATION_COLORS[name]), static=True)


def _log_offset_cost(rec, rr, off) -> None:
    """``offset_cost``: the refinement's calibration cost over the offset (bars; not in
    the default layout, its scale is not the correlation's)."""
    x, y = np.asarray(off.cost_offsets_s, np.float64), np.asarray(off.cost, np.float64)
    ok = np.isfinite(x) & np.isfinite(y) if x.size == y.size else np.zeros(0, dtype=bool)
    if ok.sum() < 2:
        return
    order = np.argsort(x[ok])
    x, y = x[ok][order], y[ok][order]
    rec.log("offset_cost", rr.BarChart(y, abscissa=x, widths=np.full(x.size, float(
        np.median(np.diff(x))) or 1e-3), color=CALIBRATION_COLORS["chosen"]), static=True)


def _reading(conv) -> str:
    def one(k):
        inv, sw = getattr(conv, f"invert_{k}"), getattr(conv, f"swap_scalar_{k}")
        return (f"{k} {'inverted' if inv else 'as written'}"
                + (", quaternion order swapped" if sw else ""))
    margin = ("only one reading" if not math.isfinite(conv.ratio) else
              f"margin {conv.ratio:.3g}x over the runner-up")
    return (f"{one('a')}; {one('b')} ({margin}, "
            f"{'clear' if conv.clear else 'NOT clear'})")


def _offset_line(off) -> str:
    how = {"estimated": "estimated", "zero": "not told by the data: 0 used",
           "given": "given", "shared_stamps": "paired by stamp"}.get(off.decision,
                                                                     off.decision)
    sig = (f" +- {1e3 * off.uncertainty_s:.2f}" if math.isfinite(off.uncertainty_s)
           and off.uncertainty_s > 0 else "")
    extra = []
    if math.isfinite(off.evidence):
        extra.append(f"evidence against 0: {off.evidence:.3g}")
    if _has_correlation(off):
        lo, hi = off.window_s
        extra.append(f"correlation peak r = {off.peak_correlation:.2f}, "
                     f"window {lo:.3g}..{hi:.3g} s")
    return (f"time offset t_b - t_a: {1e3 * off.offset_s:.2f}{sig} ms ({how})"
            + ("; " + "; ".join(extra) if extra else ""))


def calibration_summary(r, report: dict) -> str:
    """The summary pane (markdown, one bullet per line, ASCII so that a screenshot's OCR
    can check it is whole): verdict, X, sigma, offset, reading and its margin, inliers and
    rejected poses, inlier residuals, warnings, status."""
    v, u, res = report["verdict"], report["uncertainty"], report["residuals"]["inliers"]
    t, rv = report["X"]["translation_m"], report["X"]["rotvec_deg"]
    rej = rejected_instants(r.synced.n, r.motions.i, r.motions.j, r.robust.inlier_mask)
    vec = lambda x, s=1.0, d=3: "[" + ", ".join(  # noqa: E731
        "inf" if a is None else f"{s * a:.{d}f}" for a in x) + "]"
    sigma = ("sigma (1-sigma, frame a): not available" if u is None or not u.get(
        "std_rotation_deg") else f"sigma (1-sigma, frame a): rotation "
        f"{vec(u['std_rotation_deg'], d=4)} deg, translation "
        f"{vec(u['std_translation_m'], 1e3, 2)} mm")
    lines = [
        f"**verdict: {v['verdict'].upper()}**" + (f" - {v['message']}" if v["message"]
                                                 else ""),
        f"X = T_a_b: t = {vec(t, 1e3, 2)} mm, rotation vector {vec(rv)} deg",
        sigma,
        _offset_line(r.time_offset),
        f"reading: {_reading(r.conventions)}",
        f"inliers: {r.robust.n_inliers} of {r.motions.n} motions ({r.robust_choice}); "
        f"rejected poses: {int(rej.sum())} of {r.synced.n} (red marks)",
        "residuals of the inliers: rotation rms " + (
            f"{res['rot_rms_deg']:.3f} deg, translation rms {res['trans_rms_mm']:.2f} mm"
            if res["rot_rms_deg"] is not None else "n/a"),
        *[f"WARNING: {w}" for w in report.get("warnings", [])],
        f"status: {report['status']} (exit {report['exit_code']})",
    ]
    return "\n".join(f"- {x}" for x in lines)


def record_calibration(path, r, report: dict, console: str = "") -> Path:
    """The recording of ``simcalib calibrate`` (self-contained; headless, no viewer):
    ``r`` a :class:`simcalib.estimation.path.StreamCalibration`, ``report`` its
    calibration.json content, ``console`` the console report.

    Entities (timeline ``time`` = synchronised instants, seconds since the first, clock a),
    in a's world:

    * ``world/b_from_a/trajectory`` — a's poses through X (``T_wa_a X``: where b should
      be); ``world/b_measured/trajectory`` — b's measured poses mapped into a's world
      (``T_wa_wb T_wb_b``, the world-to-world transform X implies). Both at the estimated
      offset, without the rejected poses (:func:`rejected_instants`; the strip joins their
      neighbours, :func:`trajectory_strips`); they coincide when X is right.
    * ``world/rejected/poses`` — the rejected instants as red marks (on ``b_from_a``).
    * ``world/rig/a`` (axes, per time), ``world/rig/a/b_through_X`` (axes),
      ``world/rig/a/link`` (a to b), ``world/rig/b_measured`` (axes, per time): the rig.
    * ``residuals/<rotation_deg|translation_mm>/<inliers|rejected>`` — per-motion errors of
      ``C X = X H`` at the motion's start; the plot's top is 1.25 x the largest inlier,
      rejected motions are red crosses at ``min(value, top)``.
    * ``time_offset/window|outside|peak|chosen`` — the angular-speed correlation over the
      lag as bar charts (inside / outside the plausibility window, the peak in it, the
      offset used); absent when the streams were paired by stamp or the offset given.
    * ``offset_cost`` — the refinement's cost over the offset (bars, not in the layout).
    * ``summary`` — :func:`calibration_summary`; ``report`` — the console report.
    """
    import rerun as rr
    path = Path(path)
    rec = _open_recording(rr, "simcalib", path,
                          default_blueprint=calibration_blueprint(r))
    try:
        _log_scene(rec, rr, calibration_scene(r))
        _log_residuals(rec, rr, r)
        _log_correlation(rec, rr, r.time_offset)
        _log_offset_cost(rec, rr, r.time_offset)
        rec.log("summary", rr.TextDocument(calibration_summary(r, report),
                                           media_type="text/markdown"), static=True)
        if console:
            rec.log("report", rr.TextDocument(console), static=True)
    finally:
        rec.flush()
        rec.disconnect()
    return path


# ------------------------------------------------------------------- motion advice
def record_advice(path, base, adv) -> Path:
    """Recording of motion advice (``simcalib advise``): the marker field, each camera's
    recorded trajectory, its pose at the reference stop and at every proposed stop (axes,
    labelled ``stop k``, a line from the reference), and the predicted 1-sigma per axis
    (deg / cm) against the number of added stops. ``base``/``adv``:
    :class:`simcalib.studies.advise.Baseline` / :class:`simcalib.studies.advise.Advice`. Self-contained."""
    import rerun as rr
    path = Path(path)
    rec = _open_recording(rr, "simcalib-advice", path)
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    mf = base.truth.marker_field
    if mf is not None and len(getattr(mf, "ids", ())):
        T = np.asarray(mf.T_world_marker)
        h = 0.5 * float(mf.side_m)
        rec.log("world/markers", rr.Boxes3D(
            centers=T[:, :3, 3], half_sizes=np.tile([h, h, 0.002], (T.shape[0], 1)),
            quaternions=quat_from_matrix(T[:, :3, :3]), colors=(40, 40, 40)), static=True)
    cand = adv.candidates
    for cam, s in base.truth.streams.items():
        _log_stops(rec, rr, cam, np.asarray(s.T_world_cam), cand.ref["T_world_cam"][cam],
                   cand.T_world_cam[cam][adv.chosen])
    _log_predicted_std(rec, rr, adv.std_before, adv.std_after)
    rec.flush() if hasattr(rec, "flush") else None
    rec.disconnect() if hasattr(rec, "disconnect") else None
    return path


def record_recorded_advice(path, T_frame_a, adv) -> Path:
    """Recording of advice for recorded pose files (``simcalib advise a=... b=...``), in
    file a's frame: sensor a's recorded trajectory ``T_frame_a`` (N, 4, 4), sensor b's
    through the estimate (``T_frame_a @ X``), both sensors at the reference and at every
    proposed stop, and the predicted 1-sigma against the number of added stops. ``adv``:
    :class:`simcalib.studies.advise.recorded.RecordedAdvice`. Self-contained."""
    import rerun as rr
    path = Path(path)
    rec = _open_recording(rr, "simcalib-advice", path)
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    T_frame_a = np.asarray(T_frame_a, dtype=np.float64)
    stops = adv.T_ref_a @ adv.motion_a[adv.chosen]
    for cam, right in (("cam_a", np.eye(4)), ("cam_b", adv.X)):
        _log_stops(rec, rr, cam, T_frame_a @ right, adv.T_ref_a @ right, stops @ right)
    _log_predicted_std(rec, rr, adv.std_before, adv.std_after)
    rec.flush() if hasattr(rec, "flush") else None
    rec.disconnect() if hasattr(rec, "disconnect") else None
    return path


def _log_stops(rec, rr, cam, T_recorded, ref, Tp) -> None:
    """A camera's recorded trajectory ``T_recorded`` (N, 4, 4), its pose at the reference
    ``ref`` and at the proposed stops ``Tp`` (k, 4, 4): axes, labels, lines from the
    reference."""
    color = _COLORS.get(cam, (200, 200, 200))
    rec.log(f"world/recorded/{cam}", rr.LineStrips3D([T_recorded[:, :3, 3]], colors=color,
                                                     radii=0.002), static=True)
    rec.log(f"world/advice/{cam}/reference", rr.Transform3D(
        translation=ref[:3, 3], mat3x3=ref[:3, :3]), rr.TransformAxes3D(0.08), static=True)
    for k, Tk in enumerate(Tp):
        rec.log(f"world/advice/{cam}/stop_{k + 1}", rr.Transform3D(
            translation=Tk[:3, 3], mat3x3=Tk[:3, :3]), rr.TransformAxes3D(0.06), static=True)
    if len(Tp):
        rec.log(f"world/advice/{cam}/stops", rr.Points3D(
            Tp[:, :3, 3], colors=color, radii=0.01,
            labels=[f"stop {k + 1}" for k in range(len(Tp))]), static=True)
        rec.log(f"world/advice/{cam}/moves", rr.LineStrips3D(
            [[ref[:3, 3], p] for p in Tp[:, :3, 3]], colors=color, radii=0.002), static=True)


def _log_predicted_std(rec, rr, before, after) -> None:
    """Predicted 1-sigma per axis (deg / cm) against the number of added stops."""
    names = ["wx [deg]", "wy [deg]", "wz [deg]", "vx [cm]", "vy [cm]", "vz [cm]"]
    rec.log("advice/predicted_std", rr.SeriesLines(names=names), static=True)
    for k, s in enumerate([before] + list(after)):
        rec.set_time("added_stops", sequence=k)
        v = np.concatenate([s[:3], 100.0 * s[3:]])
        rec.log("advice/predicted_std", rr.Scalars(np.where(np.isfinite(v), v, np.nan)))
