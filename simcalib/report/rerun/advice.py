"""The recording of ``simcalib advise`` (``advice.rrd``) and the layout it opens on.

Left, the proposed stops in 3D (a view framed on the recorded trajectories, the reference
and every stop — markers far away do not zoom it out): each camera's recorded trajectory,
its pose at the reference and at every proposed stop (axes), a line from the reference to
each stop, and one label per stop laid out on the view's screen so that no two overlap
(:func:`simcalib.report.rerun.labels.place_labels`). Right, the predicted 1-sigma against
the number of added stops — rotation [deg] and translation [cm] in two plots of their own,
log10 (the first stops shrink it by orders of magnitude) — and a summary: per stop the
camera motions FROM THE PREVIOUS STOP and the predicted 1-sigma after it (from the
advice.json content).

Entities: ``world/markers``; ``world/recorded/<cam>``; ``world/advice/<cam>/reference``,
``.../stop_<k>`` (axes), ``.../stops`` (points), ``.../moves`` (lines);
``world/advice/labels/<k>`` (the stop labels); ``advice/log10_std_deg/<wx|wy|wz>``,
``advice/log10_std_cm/<vx|vy|vz>`` (timeline ``added_stops``); ``advice/summary``.
Written through the recording worker unless this process imported rerun already.
"""

from __future__ import annotations

import json
import math
import uuid
from pathlib import Path

import numpy as np

from simcalib.geometry import quat_from_matrix
from simcalib.report.rerun.common import (CAMERA_COLORS, LABEL_COLOR, eye_controls, orbital_eye,
                                          panel_tail)
from simcalib.report.rerun.labels import layout_labels
from simcalib.report.rerun.worker import finish_stream, open_stream, worker_pays_off

__all__ = ["record_advice", "record_recorded_advice", "advice_blueprint", "advice_eye",
           "advice_markdown", "ADVICE_BACKGROUND", "VIEW_ASPECT", "ADVICE_APP_ID"]

#: the 3D view's background (dark: the stop labels are white on the viewer's grey boxes)
ADVICE_BACKGROUND = (28, 30, 34)
#: the recordings' application id (a blueprint file must name it to apply)
ADVICE_APP_ID = "simcalib-advice"
#: width / height of the 3D view in the layout (3/5 of a 1600 x 1000 window)
VIEW_ASPECT = 1.0
_ROT, _TRANS = ("wx", "wy", "wz"), ("vx", "vy", "vz")


def advice_eye(points) -> dict:
    """The 3D view's eye: from above and aside, on the box of ``points`` (the recorded
    trajectories, the reference and the stops of every camera)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    lo, hi = P.min(0), P.max(0)
    return orbital_eye(lo - 0.05, hi + 0.05, (-1.0, -1.3, 1.1), (0, 0, 1), distance=1.05)


def _stop_labels(eye, stops: dict) -> list[tuple]:
    """``(anchor, placed point, leader end, text)`` of one label per stop: at the stop of the first
    camera, laid out so that no two labels overlap on the view's screen (both cameras'
    stops are dots that no label covers)."""
    cams = list(stops)
    first = stops[cams[0]]
    items = [(first[k, :3, 3], [f"stop {k + 1}"]) for k in range(len(first))]
    others = [T[:3, 3] for c in cams[1:] for T in stops[c]]
    placed = layout_labels(eye, items, aspect=VIEW_ASPECT, avoid=others)
    return [(a, p, end, lines[0]) for (a, lines), (p, end) in zip(items, placed)]


def _log_camera(rec, rr, cam, T_recorded, ref, Tp) -> None:
    """A camera's recorded trajectory, its pose at the reference and at the stops ``Tp``
    (k, 4, 4): axes, dots, lines from the reference."""
    color = CAMERA_COLORS.get(cam, (200, 200, 200))
    rec.log(f"world/recorded/{cam}", rr.LineStrips3D([T_recorded[:, :3, 3]], colors=color,
                                                     radii=0.002), static=True)
    rec.log(f"world/advice/{cam}/reference", rr.Transform3D(
        translation=ref[:3, 3], mat3x3=ref[:3, :3]), rr.TransformAxes3D(0.08), static=True)
    for k, Tk in enumerate(Tp):
        rec.log(f"world/advice/{cam}/stop_{k + 1}", rr.Transform3D(
            translation=Tk[:3, 3], mat3x3=Tk[:3, :3]), rr.TransformAxes3D(0.06), static=True)
    if len(Tp):
        rec.log(f"world/advice/{cam}/stops", rr.Points3D(Tp[:, :3, 3], colors=color,
                                                          radii=0.012), static=True)
        rec.log(f"world/advice/{cam}/moves", rr.LineStrips3D(
            [[ref[:3, 3], p] for p in Tp[:, :3, 3]], colors=color, radii=0.002), static=True)


def _log_labels(rec, rr, labels, scale: float) -> None:
    for k, (anchor, p, end, text) in enumerate(labels):
        # from the stop to the label's nearest edge (never across the text), dim
        leader = rr.LineStrips3D([[anchor, end]], colors=(110, 110, 120), radii=0.001 * scale)
        # the label's point without a size: its dot just above the text read as part of
        # it (OCR read "stop 5" as "stop i)"); the text takes the point's colour
        rec.log(f"world/advice/labels/{k + 1}", rr.Points3D(
            [p], radii=0.0, colors=LABEL_COLOR, labels=[text]), leader, static=True)


def _log_predicted_std(rec, rr, before, after) -> None:
    """log10 of the predicted 1-sigma per axis against the number of added stops: rotation
    [deg] and translation [cm] as separate plots (an infinite one is left out)."""
    stds = [np.asarray(before, float)] + [np.asarray(s, float) for s in after]
    for unit, names, part, scale in (("deg", _ROT, slice(0, 3), 1.0),
                                     ("cm", _TRANS, slice(3, 6), 100.0)):
        for i, name in enumerate(names):
            ent = f"advice/log10_std_{unit}/{name}"
            rec.log(ent, rr.SeriesLines(names=f"{name} [{unit}]", colors=_AXIS_COLORS[i],
                                        widths=2.0), static=True)
            for k, s in enumerate(stds):
                v = scale * s[part][i]
                if np.isfinite(v) and v > 0:
                    rec.set_time("added_stops", sequence=k)
                    rec.log(ent, rr.Scalars([math.log10(v)]))
    rec.reset_time()


_AXIS_COLORS = [(230, 80, 80), (80, 200, 100), (90, 140, 240)]


def _n(v, scale=1.0) -> str:
    return "—" if v is None else f"{scale * v:.3g}"


def advice_markdown(out: dict | None) -> str:
    """The summary pane from the advice.json content ``out``: the predicted 1-sigma before
    and after each stop, and each stop's motion of every camera from the previous stop."""
    if not out:
        return "(no advice.json content)"
    lines = ["**advice**: the next stops, each a motion **from the previous stop** (stop 1:"
             " from the reference, the last recorded pose)", "",
             "| | " + " | ".join(f"σ {a} [deg]" for a in _ROT) + " | "
             + " | ".join(f"σ {a} [cm]" for a in _TRANS) + " |", "|---" + "|---:" * 6 + "|"]

    def row(label, s):
        return (f"| {label} | " + " | ".join(_n(s.get(f"{a}_deg")) for a in _ROT) + " | "
                + " | ".join(_n(s.get(f"{a}_m"), 100) for a in _TRANS) + " |")
    lines.append(row("before", out.get("predicted_std_before") or {}))
    lines += [row(f"+ stop {m['step']}", m["predicted_std_after"]) for m in out["motions"]]
    lines.append("")
    for m in out["motions"]:
        cm = m.get("camera_motions") or m.get("sensor_motions") or {}
        lines.append(f"- stop {m['step']}: " + "; ".join(
            f"{c}: {v['angle_deg']:.1f} deg, {100 * math.hypot(*v['translation_m']):.1f} cm"
            for c, v in cm.items()) + " (from the previous stop)")
    return "\n".join(lines)


def _stops_view(rrb, eye):
    return rrb.Spatial3DView(
        origin="world", name="proposed stops (cam_a orange, cam_b blue; lines from the "
        "reference)", eye_controls=eye_controls(rrb, eye), background=ADVICE_BACKGROUND,
        line_grid=rrb.LineGrid3D(visible=False))


def advice_blueprint(eye: dict, rrb=None, only: str | None = None):
    """The layout advice.rrd opens on: the stops in 3D (left), the predicted 1-sigma in
    deg and in cm and the summary (right). ``only="stops"``: the 3D view alone (every
    panel hidden; the screenshot tool's label check)."""
    if only not in (None, "stops"):
        raise ValueError(f"only must be None or 'stops'; received {only!r}")
    if rrb is None:
        import rerun.blueprint as rrb
    if only:
        return rrb.Blueprint(_stops_view(rrb, eye), *panel_tail(
            rrb, rrb.TimePanel(state="hidden"), hidden=True), auto_views=False)
    everything = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                               end=rrb.TimeRangeBoundary.infinite())
    plots = [rrb.TimeSeriesView(
        origin=f"advice/log10_std_{u}", axis_x=rrb.TimeAxis(view_range=everything),
        plot_legend=rrb.PlotLegend("RightTop"),
        name=f"log10 predicted 1-sigma, {what} [{u}], against the stops added")
        for u, what in (("deg", "rotation"), ("cm", "translation"))]
    body = rrb.Horizontal(_stops_view(rrb, eye), rrb.Vertical(*plots, rrb.TextDocumentView(
        origin="advice/summary", name="advice: each stop from the previous one"),
        row_shares=[1, 1, 2]), column_shares=[3, 2])
    return rrb.Blueprint(body, *panel_tail(rrb, rrb.TimePanel(
        timeline="added_stops", state="collapsed", play_state="paused")), auto_views=False)


def _record(path, cameras: dict, before, after, out, markers=None, background=None) -> Path:
    """Write an advice recording: ``cameras`` ``{cam: (T_recorded, ref, stops)}``."""
    path = Path(path)
    if background is None:
        background = worker_pays_off()
    rec, rr, background = open_stream(path, background, application_id=ADVICE_APP_ID,
                                      recording_id=str(uuid.uuid4()), send_properties=False)
    try:
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        if markers is not None:
            markers(rec, rr)
        pts = [np.concatenate([T[:, :3, 3], ref[None, :3, 3], Tp[:, :3, 3]])
               for T, ref, Tp in cameras.values()]
        eye = advice_eye(np.concatenate(pts))
        P = np.concatenate(pts)
        scale = max(float(np.linalg.norm(P.max(0) - P.min(0))), 0.1)
        for cam, (T, ref, Tp) in cameras.items():
            _log_camera(rec, rr, cam, T, ref, Tp)
        _log_labels(rec, rr, _stop_labels(eye, {c: v[2] for c, v in cameras.items()}), scale)
        _log_predicted_std(rec, rr, before, after)
        rec.log("advice/summary", rr.TextDocument(advice_markdown(out),
                                                  media_type="text/markdown"), static=True)
        rec.send_blueprint(advice_blueprint(eye, rrb=rr.blueprint), make_active=True,
                           make_default=True)
    finally:
        finish_stream(rec, background)
    # the 3D view's eye, for tools that open it alone (tools/screenshots.py)
    path.with_name("advice_view.json").write_text(json.dumps({"eye": eye}))
    return path


def record_advice(path, base, adv, out: dict | None = None,
                  background: bool | None = None) -> Path:
    """Recording of motion advice (``simcalib advise``): the marker field, each camera's
    recorded trajectory, its pose at the reference stop and at every proposed stop, and
    the predicted 1-sigma per axis against the number of added stops. ``base``/``adv``:
    :class:`simcalib.studies.advise.Baseline` / :class:`simcalib.studies.advise.Advice`;
    ``out``: the advice.json content (the summary pane)."""
    mf = base.truth.marker_field

    def markers(rec, rr):
        if mf is None or not len(getattr(mf, "ids", ())):
            return
        T = np.asarray(mf.T_world_marker)
        h = 0.5 * float(mf.side_m)
        rec.log("world/markers", rr.Boxes3D(
            centers=T[:, :3, 3], half_sizes=np.tile([h, h, 0.002], (T.shape[0], 1)),
            quaternions=quat_from_matrix(T[:, :3, :3]), colors=(85, 85, 92)), static=True)
    cand = adv.candidates
    cams = {cam: (np.asarray(s.T_world_cam), cand.ref["T_world_cam"][cam],
                  np.asarray(cand.T_world_cam[cam][adv.chosen]))
            for cam, s in base.truth.streams.items()}
    return _record(path, cams, adv.std_before, adv.std_after, out, markers, background)


def record_recorded_advice(path, T_frame_a, adv, out: dict | None = None,
                           background: bool | None = None) -> Path:
    """Recording of advice for recorded pose files (``simcalib advise a=... b=...``), in
    file a's frame: sensor a's recorded trajectory ``T_frame_a`` (N, 4, 4), sensor b's
    through the estimate (``T_frame_a @ X``), both sensors at the reference and at every
    proposed stop, and the predicted 1-sigma against the number of added stops. ``adv``:
    :class:`simcalib.studies.advise.recorded.RecordedAdvice`; ``out``: advice.json."""
    T_frame_a = np.asarray(T_frame_a, dtype=np.float64)
    stops = adv.T_ref_a @ adv.motion_a[adv.chosen]
    cams = {cam: (T_frame_a @ right, adv.T_ref_a @ right, stops @ right)
            for cam, right in (("cam_a", np.eye(4)), ("cam_b", adv.X))}
    return _record(path, cams, adv.std_before, adv.std_after, out, None, background)
