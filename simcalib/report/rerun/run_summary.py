"""A run recording's summary pane (``summary``): the console summary as markdown, rendered
from the same cells and sentences as the console (:func:`simcalib.report.console.
solver_rows`, each solver's :class:`~simcalib.report.directions.SolverView`): the same
error ± sigma, determined error and verdict per solver, the same words per flagged
direction, the same footnotes for every number that is not a measurement."""

from __future__ import annotations

from simcalib.report.console import direction_lines, solver_rows, unknown_lines
from simcalib.report.directions import not_measured_notes
from simcalib.report.rerun.common import decades, fmt, log_bar

__all__ = ["summary_markdown"]

_HEAD = "| method | rot err ± σ [deg] | log | trans err ± σ [cm] | log | determined [cm] |"


def _rows(result, rows) -> tuple[list[str], list[str]]:
    """The table's rows (log-scale bars beside the errors; FAILED rows in bold) and the
    notes they need (each failure's reason, the bars' scale)."""
    by_label = {s.label: s for s in result.solvers}
    ok = [by_label[v.label] for v, c in rows if c is not None]
    rlo, rhi = decades([s.rotation_error_deg for s in ok])
    tlo, thi = decades([100 * s.translation_error_m for s in ok])
    out, notes = [], []
    for v, c in rows:
        if c is None:
            reason = v.failed.replace("|", "/")
            out.append(f"| **{v.label}** | **FAILED** | | | | |")
            notes.append(f"**{v.label} FAILED**: "
                         + (reason if len(reason) <= 160 else reason[:157] + "..."))
            continue
        s = by_label[v.label]
        t_cm = 100 * s.translation_error_m
        out.append(f"| {v.label} | {c[1]} | {log_bar(s.rotation_error_deg, rlo, rhi)} | "
                   f"{c[2]} | {log_bar(t_cm, tlo, thi)} | {c[3]} |")
    if ok:
        notes.append(f"log bars: rotation 1e{int(rlo)}–1e{int(rhi)} deg, translation "
                     f"1e{int(tlo)}–1e{int(thi)} cm")
    return out, notes


def _context_notes(result) -> list[str]:
    """Frames, motion pairs and the pose-source errors."""
    notes = []
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
                         f"{fmt(sm['rotation_deg']['median'])} deg / "
                         f"{fmt(1000 * sm['translation_m']['median'])} mm")
    return notes


def summary_markdown(result) -> str:
    """The console summary as markdown: one table row per solver (error ± predicted sigma
    with log-scale bars, determined error; FAILED rows in bold, their reason below), the
    verdict of each (the console's cell: a list, since it does not fit a half-wide pane's
    table), then each flagged direction in words, the footnotes of every
    :data:`~simcalib.report.directions.NOT_MEASURED`, frames, motion pairs and pose-source
    errors."""
    cfg = result.config
    rows = solver_rows(result)
    alphas = sorted({s.alpha for s in result.solvers if s.X is not None and s.alpha is not None})
    table, notes = _rows(result, rows)
    views = [v for v, _ in rows]
    verdicts: dict[str, list[str]] = {}    # the console's verdict cell, solvers sharing it
    for v, c in rows:
        if c is not None:
            verdicts.setdefault(c[5], []).append(v.label)
    notes = [f"verdict [{', '.join(labels)}]: **{cell}**" for cell, labels in verdicts.items()
             ] + notes
    notes += [f"not determined within tolerance ({', '.join(labels)}): " + "; ".join(words)
              + " — along such a direction the error is not a measurement; *determined* = "
              "the translation error with the flagged translation directions projected out"
              for labels, words in direction_lines(views)]
    notes += unknown_lines(views) + not_measured_notes(views) + _context_notes(result)
    head = (f"**{cfg.scenario}** — kind {cfg.kind}, source {cfg.source}, seed {cfg.seed}, "
            f"{(result.pairing or {}).get('used', '?')} motions, alpha "
            f"{', '.join(fmt(a) for a in alphas) or '–'}")
    return "\n".join([head, "", _HEAD, "|---|---:|:---|---:|:---|---:|", *table, ""]
                     + [f"- {n}" for n in notes])
