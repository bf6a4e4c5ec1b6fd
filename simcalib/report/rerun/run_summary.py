"""A run recording's summary pane (``summary``): the console summary as markdown."""

from __future__ import annotations

from simcalib.report.rerun.common import decades, fmt, log_bar

__all__ = ["summary_markdown"]


def summary_markdown(result) -> str:
    """The console summary (:func:`simcalib.report.console.summary_table`) as markdown: one table
    row per solver with its errors and log-scale bars (FAILED rows in bold, their reason
    below; degenerate ones flagged), then the undetermined directions, frames, motion pairs
    and pose-source errors."""
    cfg = result.config
    solvers = list(result.solvers)
    ok = [s for s in solvers if s.X is not None]
    alphas = sorted({s.alpha for s in ok if s.alpha is not None})
    rlo, rhi = decades([s.rotation_error_deg for s in ok])
    tlo, thi = decades([100 * s.translation_error_m for s in ok])
    out = [f"**{cfg.scenario}** — kind {cfg.kind}, source {cfg.source}, seed {cfg.seed}, "
           f"{(result.pairing or {}).get('used', '?')} motions, alpha "
           f"{', '.join(fmt(a) for a in alphas) or '–'}", "",
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
        out.append(f"| {s.label} | {fmt(s.rotation_error_deg)} | "
                   f"{log_bar(s.rotation_error_deg, rlo, rhi)} | {fmt(t_cm)} | "
                   f"{log_bar(t_cm, tlo, thi)} | {fmt(None if det is None else 100 * det)} | "
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
                         f"{fmt(sm['rotation_deg']['median'])} deg / "
                         f"{fmt(1000 * sm['translation_m']['median'])} mm")
    return "\n".join(out + [""] + [f"- {n}" for n in notes])
