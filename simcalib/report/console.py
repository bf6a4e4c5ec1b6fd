"""The console table of a run: each solver's error +- predicted sigma, its verdict and the
footnotes for every number that is not a measurement; rendered from each solver's
:class:`~simcalib.report.directions.SolverView`, as results.json and the recording's
summary pane are, so that none can disagree with another.
"""

from __future__ import annotations

from simcalib.report.directions import (determined_cell, fmt_number, not_measured_notes,
                                        pm_cell, solver_view)

__all__ = ["summary_table", "solver_rows", "direction_lines", "unknown_lines"]

_fmt = fmt_number


def solver_rows(result) -> list[tuple]:
    """``(view, cells)`` per solver: its :class:`~simcalib.report.directions.SolverView`
    and the table's cells (alpha, rotation and translation error ± sigma, determined,
    time, verdict); a failed solver has no cells."""
    rows = []
    for s in result.solvers:
        v = solver_view(s)
        if v.failed is not None:
            rows.append((v, None))
            continue
        rows.append((v, [_fmt(s.alpha, digits=3),
                         pm_cell(s.rotation_error_deg, v.sigma_rotation_deg,
                                 v.sigma_rotation_reason, 1.0, 3),
                         pm_cell(s.translation_error_m, v.sigma_translation_m,
                                 v.sigma_translation_reason, 100, 2),
                         determined_cell(v), _fmt(s.runtime_s, 1e3, 2), v.verdict_cell()]))
    return rows


def direction_lines(views) -> list[tuple[list[str], list[str]]]:
    """``(labels, sentences)``: the flagged directions of the solvers that share them, each
    in its words (state and the 1-sigma that applies)."""
    groups: dict[tuple, list[str]] = {}
    for v in views:
        if v.failed is None and v.directions:
            groups.setdefault(tuple(d["words"] for d in v.directions), []).append(v.label)
    return [(labels, list(words)) for words, labels in groups.items()]


def unknown_lines(views) -> list[str]:
    """Why a solver has no verdict (its uncertainty could not be computed)."""
    return [f"no verdict [{v.label}]: {v.unknown_reason}" for v in views
            if v.failed is None and v.unknown_reason]


_HEAD = ["method", "alpha", "rot err ± σ [deg]", "trans err ± σ [cm]", "determined [cm]",
         "time [ms]", "verdict"]


def _table(result, srows) -> list[str]:
    """The title, the header and one aligned row per solver (a failed one: its reason)."""
    rows = [[v.label, f"FAILED: {v.failed}"] if c is None else [v.label, *c]
            for v, c in srows]
    full = [r for r in rows if len(r) == len(_HEAD)]
    widths = [max(len(h), *(len(r[i]) for r in full)) if full else len(h)
              for i, h in enumerate(_HEAD)]
    widths[0] = max([widths[0]] + [len(r[0]) for r in rows])

    def align(cells):
        return "  ".join(c.ljust(w) if i in (0, len(_HEAD) - 1) else c.rjust(w)
                         for i, (c, w) in enumerate(zip(cells, widths)))
    line = align(_HEAD)
    out = [f"scenario {result.config.scenario!r} (source={result.config.source}, "
           f"seed={result.config.seed}, {result.pairing.get('used', '?')} motions)",
           line, "-" * len(line)]
    for r in rows:
        out.append(align(r) if len(r) == len(_HEAD) else f"{r[0].ljust(widths[0])}  {r[1]}")
    return out


def _verdict_notes(views) -> list[str]:
    """Each flagged direction in words, and the footnotes of every '—'."""
    out = []
    flagged = direction_lines(views)
    for labels, words in flagged:
        out.append(f"not determined within tolerance [{', '.join(labels)}]: "
                   + "; ".join(words))
    if flagged:
        out.append("  -> along an undetermined direction the estimate is arbitrary (its error "
                   "is not a measurement); 'determined [cm]' = the translation error with the "
                   "flagged translation directions that no prior fixed projected out")
    out += unknown_lines(views) + not_measured_notes(views)
    return out


def _context(result) -> list[str]:
    """alpha and how it was chosen, the oracle alpha, the kernels' note, frames, motion
    pairs and the pose-source errors."""
    out = []
    choice = next((s.alpha_choice for s in result.solvers if s.alpha_choice), None)
    if choice:
        out.append(f"alpha = {_fmt(choice['alpha'], digits=3)} ({choice['source']}: "
                   f"{choice['how']})")
    orc = [s for s in result.solvers if s.oracle]
    if orc:
        out.append("oracle_alpha (USES THE GROUND TRUTH, for comparison only): " + "; ".join(
            f"{s.label} alpha {_fmt(s.oracle['oracle_alpha'], digits=3)}: "
            f"{_fmt(s.oracle['rotation_error_deg'], digits=3)} deg / "
            f"{_fmt(s.oracle['translation_error_m'], 100, 2)} cm" for s in orc))
    if getattr(result, "solver_kernels", "compiled") == "interpreted":
        from simcalib.solvers.kernels.mode import INTERPRETED_NOTE
        out.append(INTERPRETED_NOTE)
    fr = result.frames or {}
    if fr.get("rendered"):
        cams = []
        for cam in result.camera_names:
            c = fr.get(cam) or {}
            reasons = ", ".join(f"{k} {v}" for k, v in (c.get("drop_reasons") or {}).items())
            cams.append(f"{cam} used {c.get('used')}, dropped {c.get('dropped')}"
                        + (f" ({reasons})" if reasons else ""))
        n = {(fr.get(cam) or {}).get("frames") for cam in result.camera_names}
        head = (f"{fr['rendered']} per camera" if len(n) == 1 else "per camera "
                + ", ".join(f"{cam} {(fr.get(cam) or {}).get('frames')}"
                            for cam in result.camera_names))
        out.append(f"frames: {head}; " + "; ".join(cams))
    p = result.pairing or {}
    if p.get("candidate_pairs") is not None and p.get("matched") is not None:
        out.append(f"motion pairs: {p.get('used')} used of {p.get('candidate_pairs')} "
                   f"candidates (pre-filter dropped {p.get('dropped_translation')} for "
                   f"translation, {p.get('dropped_rotation')} for rotation; "
                   f"{p.get('dropped_time_diff')} datapoints for timestamp difference)")
    if result.pose_errors:
        parts = []
        for cam, e in result.pose_errors.items():
            sm = e.summary()
            if sm["n"]:
                parts.append(f"{cam}: median {_fmt(sm['rotation_deg']['median'], digits=3)} deg "
                             f"/ {_fmt(sm['translation_m']['median'], 1000, 2)} mm, p95 "
                             f"{_fmt(sm['rotation_deg']['p95'], digits=3)} deg / "
                             f"{_fmt(sm['translation_m']['p95'], 1000, 2)} mm")
        if parts:
            src = next(iter(result.pose_errors.values())).source
            out.append(f"pose error of source '{src}' vs ground truth: " + "; ".join(parts))
    return out


def summary_table(result) -> str:
    """Console summary: one row per solver (error ± predicted 1-sigma, runtime, verdict;
    FAILED rows with the reason), the flagged directions beneath, the data-chosen alpha and
    the oracle alpha (labelled: it uses the ground truth), then pose-source errors and
    pairing counts."""
    srows = solver_rows(result)
    return "\n".join(_table(result, srows) + _verdict_notes([v for v, _ in srows])
                     + _context(result))
