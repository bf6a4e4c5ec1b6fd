"""Recordings of studies: a sweep's per-axis error series (:func:`record_sweep`) and an
experiment's figures and tables (:func:`log_experiment`). In-process (a study's run time
dwarfs rerun's import)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from simcalib.report.rerun.common import (
    SOLVER_COLORS,
    entity_name,
    open_recording,
    panel_tail,
)

__all__ = ["record_sweep", "log_experiment"]


def _sweep_per_axis(summary: dict) -> dict:
    per_axis = summary.get("per_axis", summary) if isinstance(summary, dict) else None
    if not isinstance(per_axis, dict):
        raise TypeError(f"summary must be a dict (simcalib.studies.sweep.report.summarise "
                        f"output or its 'per_axis'); received {type(summary).__name__}")
    return per_axis


def _sorted_values(by_value: dict) -> list:
    values = list(by_value)
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    return sorted(values) if numeric else sorted(values, key=str)


def _log_series(rec, rr, ent, label, color, width, points) -> None:
    """A named series ``ent`` and its ``(index, value)`` points on ``sweep_index``."""
    rec.log(ent, rr.SeriesLines(names=label, colors=color, widths=width), static=True)
    for i, y in points:
        rec.set_time("sweep_index", sequence=i)
        rec.log(ent, rr.Scalars([y]))


def _log_solver(rec, rr, a, solver, color, values, by_value) -> None:
    """One solver's log10 median / IQR series of both quantities and its failure rate."""
    sname = entity_name(solver)
    for key, qty, scale in (("rot", "log10_rotation_deg", 1.0),
                            ("tr", "log10_translation_cm", 100.0)):
        for q, width in (("med", 2.5), ("q1", 0.8), ("q3", 0.8)):
            part = "median" if q == "med" else q
            pts = []
            for i, v in enumerate(values):
                st = by_value[v].get(solver)
                x = None if st is None else st.get(f"{key}_{q}")
                if x is not None and np.isfinite(x) and x * scale > 0:
                    pts.append((i, math.log10(x * scale)))
            _log_series(rec, rr, f"sweep/{a}/{qty}/{sname}/{part}", f"{solver} {part}",
                        color, width, pts)
    fail = [(i, float((by_value[v].get(solver) or {})["failed"]))
            for i, v in enumerate(values)
            if (by_value[v].get(solver) or {}).get("failed") is not None
            and np.isfinite(by_value[v][solver]["failed"])]
    _log_series(rec, rr, f"sweep/{a}/failed/{sname}", f"{solver} failed", color, None, fail)


def _log_axis(rec, rr, rrb, axis, by_value):
    """One swept axis: its values table and every solver's series; returns its row of
    views."""
    values = _sorted_values(by_value)
    solvers = sorted({s for v in values for s in by_value[v]})
    a = entity_name(str(axis))
    rec.log(f"sweep/{a}/values", rr.TextDocument(
        f"**{axis}** (x axis = index)\n\n| index | value |\n|---:|---|\n" + "\n".join(
            f"| {i} | {v} |" for i, v in enumerate(values)),
        media_type="text/markdown"), static=True)
    for k, solver in enumerate(solvers):
        _log_solver(rec, rr, a, solver, SOLVER_COLORS[k % len(SOLVER_COLORS)], values,
                    by_value)
    rec.reset_time()
    return rrb.Horizontal(
        rrb.TimeSeriesView(origin=f"sweep/{a}/log10_rotation_deg",
                           name=f"{axis}: log10 rotation error [deg] (median, IQR)"),
        rrb.TimeSeriesView(origin=f"sweep/{a}/log10_translation_cm",
                           name=f"{axis}: log10 translation error [cm] (median, IQR)"),
        rrb.TimeSeriesView(origin=f"sweep/{a}/failed", name=f"{axis}: failure rate"),
        rrb.TextDocumentView(origin=f"sweep/{a}/values", name=f"{axis} values"),
        column_shares=[3, 3, 2, 1])


def record_sweep(path, summary: dict) -> Path:
    """Write ``path`` (.rrd): a sweep's per-axis, per-solver median and IQR series.

    ``summary``: ``{"per_axis": {axis: {value: {solver: stats}}}}`` (the output of
    ``simcalib.studies.sweep.report.summarise``) or that ``per_axis`` dict itself; ``stats``
    holds ``rot_med``, ``rot_q1``, ``rot_q3`` (deg), ``tr_med``, ``tr_q1``, ``tr_q3`` (m) and
    optionally ``failed`` (fraction). Timeline ``sweep_index`` = position of the value in
    the axis (sorted); ``sweep/<axis>/values`` maps indices to values. Errors are plotted
    as log10 (one plot per axis and quantity: ``sweep/<axis>/log10_rotation_deg/<solver>/
    median|q1|q3``, ``.../log10_translation_cm/...``), failure rates linearly."""
    import rerun as rr
    import rerun.blueprint as rrb
    per_axis = _sweep_per_axis(summary)
    path = Path(path)
    rec = open_recording(rr, "simcalib_sweep", path)
    try:
        views = [_log_axis(rec, rr, rrb, axis, by_value) for axis, by_value in per_axis.items()]
        if views:
            rec.send_blueprint(rrb.Blueprint(rrb.Vertical(*views), *panel_tail(
                rrb, rrb.TimePanel(timeline="sweep_index", state="collapsed")),
                auto_views=False))
        rec.flush()
    finally:
        rec.disconnect()
    return path


def log_experiment(path, name: str, pngs: dict, documents: dict) -> Path:
    """Write ``path`` (.rrd): an experiment's figures (PNG, ``figures/<key>``) and markdown
    tables (``tables/<key>``), laid out as a grid of figures above tabs of tables."""
    import rerun as rr
    import rerun.blueprint as rrb
    path = Path(path)
    rec = open_recording(rr, f"simcalib_experiment_{name}", path)
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
                *panel_tail(rrb, rrb.TimePanel(state="hidden")), auto_views=False))
        rec.flush()
    finally:
        rec.disconnect()
    return path
