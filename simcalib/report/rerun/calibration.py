"""The recording of ``simcalib calibrate`` (``recording.rrd``, docs/recording.md): both
trajectories in a's world after X and the offset, rejected poses as red marks, the rig
per instant, the motion residuals on the inliers' scale, the angular-speed correlation over
the lag and a summary (from the calibration.json content). Written through the recording
worker (:mod:`simcalib.report.rerun.worker`) unless this process imported rerun already."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.report.rerun.common import eye_controls, orbital_eye, panel_tail
from simcalib.report.rerun.worker import finish_stream, open_stream, worker_pays_off

__all__ = ["record_calibration", "calibration_blueprint", "save_calibration_blueprint",
           "calibration_scene", "calibration_summary", "CalibrationScene",
           "rejected_instants", "trajectory_strips", "has_correlation", "residuals",
           "residual_caps", "CALIBRATION_COLORS", "CALIBRATION_BACKGROUND",
           "CALIBRATION_PANE_COLORS"]

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
    from simcalib.estimation.world_jumps import align_worlds
    sp, ms = r.synced, r.motions
    T_a, T_b = np.asarray(sp.T_a, np.float64), np.asarray(sp.T_b, np.float64)
    X = np.asarray(r.X, dtype=np.float64)
    rej = rejected_instants(sp.n, ms.i, ms.j, r.robust.inlier_mask)
    b_from_a, b_meas = T_a @ X, align_worlds(T_a, T_b, X, sp.world, ~rej) @ T_b \
        if sp.world is not None else align_worlds(T_a[~rej], T_b[~rej], X) @ T_b
    P = np.concatenate([b_from_a[~rej, :3, 3], b_meas[~rej, :3, 3], T_a[~rej, :3, 3]])
    lo, hi = np.percentile(P, 2, axis=0), np.percentile(P, 98, axis=0)
    ext = max(float(np.linalg.norm(hi - lo)), 0.05)
    eye = orbital_eye(lo, hi, (1.0, -1.3, 0.9), (0.0, 0.0, 1.0))
    eye["position"] = (np.asarray(eye["look_target"]) + 0.75 * (
        np.asarray(eye["position"]) - np.asarray(eye["look_target"]))).tolist()
    return CalibrationScene(_since_start(r), T_a, b_from_a, b_meas, rej,
                            eye, 0.1 * ext)


def calibration_blueprint(r, only: str | None = None, rrb=None, scene=None):
    """The layout the calibration recording opens on: left the trajectories (3D, a's world)
    above the summary, right the inlier residuals (rotation, translation) and the
    angular-speed correlation over the lag (when the offset was estimated from it).
    ``only="world"``: the 3D view alone (the screenshot tool's framing check). ``rrb``:
    ``rerun.blueprint`` (default) or the worker's stand-in; ``scene``: the
    :func:`calibration_scene` of ``r`` when already computed."""
    if only not in (None, "world"):
        raise ValueError(f"only must be None or 'world'; received {only!r}")
    if rrb is None:
        import rerun.blueprint as rrb
    e = (scene or calibration_scene(r)).eye
    world = rrb.Spatial3DView(
        origin="world", name="b through X (orange) and b measured (blue), a's world; "
        "rejected poses red", background=CALIBRATION_BACKGROUND,
        line_grid=rrb.LineGrid3D(visible=False), eye_controls=eye_controls(rrb, e))
    tail = panel_tail(rrb, rrb.TimePanel(timeline="time", state="hidden" if only else
                                         "collapsed", play_state="paused"), hidden=bool(only))
    if only == "world":
        return rrb.Blueprint(world, *tail, auto_views=False)
    caps = residual_caps(r)
    everything = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                               end=rrb.TimeRangeBoundary.infinite())
    plots = [rrb.TimeSeriesView(
        origin=f"residuals/{q}", axis_x=rrb.TimeAxis(view_range=everything),
        name=f"motion residuals: {q.replace('_', ' [')}] of the inliers; rejected (red) "
        "drawn at most at the top", axis_y=rrb.ScalarAxis(range=(0.0, caps[q]),
                                                          zoom_lock=False))
        for q in ("rotation_deg", "translation_mm")]
    if has_correlation(r.time_offset):
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


def has_correlation(off) -> bool:
    lags, corr = np.asarray(off.lags_s, np.float64), np.asarray(off.correlation, np.float64)
    return lags.size > 1 and lags.size == corr.size and bool(np.isfinite(corr).any())


def residuals(r) -> dict:
    """Per-motion residuals of ``C X = X H``: ``{"rotation_deg", "translation_mm"}``."""
    from simcalib.solvers.robust import constraint_errors
    rot, trans = constraint_errors(r.C, r.H, r.X)
    return {"rotation_deg": np.degrees(rot), "translation_mm": 1e3 * np.asarray(trans)}


def residual_caps(r) -> dict:
    """The top of each residual plot: 1.25 x the largest inlier residual (all motions'
    when none is an inlier), so that rejected motions do not flatten the inliers."""
    inl = np.asarray(r.robust.inlier_mask, dtype=bool)
    out = {}
    for q, v in residuals(r).items():
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
    caps = residual_caps(r)
    for q, v in residuals(r).items():
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
    if not has_correlation(off):
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
    if has_correlation(off):
        lo, hi = off.window_s
        extra.append(f"correlation peak r = {off.peak_correlation:.2f}, "
                     f"window {lo:.3g}..{hi:.3g} s")
    return (f"time offset t_b - t_a: {1e3 * off.offset_s:.2f}{sig} ms ({how})"
            + ("; " + "; ".join(extra) if extra else ""))


def calibration_summary(r, report: dict) -> str:
    """The summary pane (markdown, one bullet per line, ASCII so that a screenshot's OCR
    can check it is whole): verdict, X, sigma, offset, reading and its margin, inliers and
    rejected poses, inlier residuals, warnings, status."""
    from simcalib.report.calibration import sigma_line, verdict_line
    v, u, res = report["verdict"], report["uncertainty"], report["residuals"]["inliers"]
    t, rv = report["X"]["translation_m"], report["X"]["rotvec_deg"]
    rej = rejected_instants(r.synced.n, r.motions.i, r.motions.j, r.robust.inlier_mask)
    vec = lambda x, s=1.0, d=3: "[" + ", ".join(  # noqa: E731
        "inf" if a is None else f"{s * a:.{d}f}" for a in x) + "]"
    lines = [
        verdict_line(v, bold=True),
        f"X = T_a_b: t = {vec(t, 1e3, 2)} mm, rotation vector {vec(rv)} deg",
        sigma_line(u),
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


def record_calibration(path, r, report: dict, console: str = "",
                       background: bool | None = None) -> Path:
    """The recording of ``simcalib calibrate`` (self-contained; headless, no viewer):
    ``r`` a :class:`simcalib.estimation.path.StreamCalibration`, ``report`` its
    calibration.json content, ``console`` the console report. ``background``: written by
    the recording worker (None: when this process has not imported rerun,
    :func:`~simcalib.report.rerun.worker.worker_pays_off`); the call returns when the
    file is written.

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
    import uuid
    path = Path(path)
    if background is None:
        background = worker_pays_off()
    rec, rr, background = open_stream(path, background, application_id="simcalib",
                                      recording_id=str(uuid.uuid4()), send_properties=False)
    scene = calibration_scene(r)
    try:
        _log_scene(rec, rr, scene)
        _log_residuals(rec, rr, r)
        _log_correlation(rec, rr, r.time_offset)
        _log_offset_cost(rec, rr, r.time_offset)
        rec.log("summary", rr.TextDocument(calibration_summary(r, report),
                                           media_type="text/markdown"), static=True)
        if console:
            rec.log("report", rr.TextDocument(console), static=True)
        rec.send_blueprint(calibration_blueprint(r, rrb=rr.blueprint, scene=scene),
                           make_active=True, make_default=True)
    finally:
        finish_stream(rec, background)
    return path
