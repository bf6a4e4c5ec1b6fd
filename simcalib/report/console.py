"""The console table of a run: each solver's error +- predicted sigma, its verdict and the
footnotes for every number that is not a measurement; rendered from the same entries as
results.json (:mod:`simcalib.report.results`), so the two cannot disagree.
"""

from __future__ import annotations

import math

import numpy as np

from simcalib.report.results import (NOT_MEASURED, REASON_ALL_PROJECTED, REASON_SIGMA_INFINITE,
                                     _sigma_reason, determined_translation, direction_state_of)

__all__ = ["summary_table"]

def _fmt(v, scale=1.0, digits=3):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    v = v * scale
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 10 ** -digits):
        return f"{v:.2e}"
    return f"{v:.{digits}f}"


def _pm(err, sigma, scale, digits):
    """``error ± predicted sigma`` (sigma :data:`NOT_MEASURED` when infinite: footnoted)."""
    e = _fmt(err, scale, digits)
    if sigma is None:
        return e
    sg = NOT_MEASURED if not math.isfinite(sigma) else _fmt(sigma, scale, digits)
    return f"{e} ± {sg}"


def _direction_tag(d: dict) -> str:
    word = d["kind"] if d["kind"] != "coupled" else "rot+trans"
    ax = d["translation_dir_a"] if d["kind"] == "translation" else d["rotation_axis_a"]
    i = int(np.argmax(np.abs(ax)))
    return f"{word} {'xyz'[i]}" if abs(ax[i]) > 0.9 else word


def _verdict_cell(s) -> str:
    """The flagged directions grouped by their state (worst first), each state in the words
    of ``Direction.summary`` (:func:`direction_state_of`)."""
    from simcalib.solvers.diagnostics.uncertainty import DIRECTION_STATES
    if s.verdict in ("determined", "unknown", "FAILED") or not s.undetermined_directions:
        return s.verdict
    by_state: dict[str, list[str]] = {}
    for d in s.undetermined_directions:
        tags = by_state.setdefault(direction_state_of(s, d), [])
        if _direction_tag(d) not in tags:
            tags.append(_direction_tag(d))
    order = sorted(by_state, key=lambda st: -DIRECTION_STATES.index(st)
                   if st in DIRECTION_STATES else 1)
    parts, shown = [], 0
    for st in order:
        tags = by_state[st][:max(0, 3 - shown)]
        shown += len(tags)
        if tags:
            parts.append(f"{st}: {', '.join(tags)}")
    hidden = sum(len(t) for t in by_state.values()) - shown
    return "; ".join(parts) + (f", +{hidden}" if hidden else "")


def _determined_cell(s) -> str:
    value, reason = determined_translation(s)
    return NOT_MEASURED if reason else _fmt(value, 100, 2)


def _not_measured_notes(solvers) -> list[str]:
    """One footnote per reason a number of the table is shown as :data:`NOT_MEASURED`."""
    ok = [s for s in solvers if s.X is not None]
    notes = []
    projected = [s.label for s in ok if determined_translation(s)[1]]
    if projected:
        notes.append(f"{NOT_MEASURED} in 'determined [cm]' [{', '.join(projected)}]: "
                     f"{REASON_ALL_PROJECTED}")
    infinite = [s.label for s in ok if _sigma_reason(s.sigma_rotation_deg)
                or _sigma_reason(s.sigma_translation_m)]
    if infinite:
        notes.append(f"{NOT_MEASURED} as σ [{', '.join(infinite)}]: {REASON_SIGMA_INFINITE}")
    return notes


#: the columns of the console table
COLUMNS = ["method", "alpha", "rot err ± σ [deg]", "trans err ± σ [cm]", "determined [cm]",
           "time [ms]", "verdict"]


def summary_table(result) -> str:
    """Console summary: one row per solver (error ± predicted 1-sigma, runtime, verdict;
    FAILED rows with the reason), the flagged directions beneath, the data-chosen alpha and
    the oracle alpha (labelled: it uses the ground truth), then pose-source errors and
    pairing counts."""
    out = [f"scenario {result.config.scenario!r} (source={result.config.source}, "
           f"seed={result.config.seed}, {result.pairing.get('used', '?')} motions)"]
    out += _table(_solver_rows(result.solvers))
    out += _flagged_lines(result.solvers)
    out += _not_measured_notes(result.solvers)
    out += _alpha_lines(result.solvers)
    if getattr(result, "solver_kernels", "compiled") == "interpreted":
        from simcalib.solvers.kernels.mode import INTERPRETED_NOTE
        out.append(INTERPRETED_NOTE)
    out += _frames_line(result) + _pairing_line(result) + _pose_error_line(result)
    return "\n".join(out)


def _solver_rows(solvers) -> list[list[str]]:
    """One row of cells per solver (:data:`COLUMNS`); a failed solver's row is its label and
    ``FAILED: <reason>``."""
    rows = []
    for s in solvers:
        if s.X is None:
            rows.append([s.label, f"FAILED: {s.error or 'no estimate'}"])
            continue
        rows.append([s.label, _fmt(s.alpha, digits=3),
                     _pm(s.rotation_error_deg, s.sigma_rotation_deg, 1.0, 3),
                     _pm(s.translation_error_m, s.sigma_translation_m, 100, 2),
                     _determined_cell(s),
                     _fmt(s.runtime_s, 1e3, 2), _verdict_cell(s)])
    return rows


def _table(rows) -> list[str]:
    """The header, a rule and the rows, columns aligned (first and last left, the numbers
    right); a failed solver's reason runs past the columns."""
    full = [r for r in rows if len(r) == len(COLUMNS)]
    widths = [max(len(h), *(len(r[i]) for r in full)) if full else len(h)
              for i, h in enumerate(COLUMNS)]
    widths[0] = max([widths[0]] + [len(r[0]) for r in rows])
    line = "  ".join(h.ljust(w) if i in (0, len(COLUMNS) - 1) else h.rjust(w)
                     for i, (h, w) in enumerate(zip(COLUMNS, widths)))
    out = [line, "-" * len(line)]
    for r in rows:
        if len(r) != len(COLUMNS):  # a failed solver: its reason instead of numbers
            out.append(f"{r[0].ljust(widths[0])}  {r[1]}")
            continue
        out.append("  ".join(c.ljust(w) if i in (0, len(COLUMNS) - 1) else c.rjust(w)
                             for i, (c, w) in enumerate(zip(r, widths))))
    return out


def _flagged_lines(solvers) -> list[str]:
    """The directions not determined within tolerance, per group of solvers that share
    them, and what that means for the error columns."""
    undet = {}
    for s in solvers:
        if s.X is None or not s.degenerate:
            continue
        undet.setdefault(tuple(s.verdict_directions or s.undetermined), []).append(s.label)
    out = [f"not determined within tolerance [{', '.join(labels)}]: " + "; ".join(dirs)
           for dirs, labels in undet.items()]
    if undet:
        out.append("  -> along an undetermined direction the estimate is arbitrary (its error "
                   "is not a measurement); 'determined [cm]' = the translation error with the "
                   "flagged translation directions that no prior fixed projected out")
    return out


def _alpha_lines(solvers) -> list[str]:
    """How alpha was chosen, and the oracle alpha (labelled: it uses the ground truth)."""
    out = []
    choice = next((s.alpha_choice for s in solvers if s.alpha_choice), None)
    if choice:
        out.append(f"alpha = {_fmt(choice['alpha'], digits=3)} ({choice['source']}: "
                   f"{choice['how']})")
    orc = [s for s in solvers if s.oracle]
    if orc:
        out.append("oracle_alpha (USES THE GROUND TRUTH, for comparison only): " + "; ".join(
            f"{s.label} alpha {_fmt(s.oracle['oracle_alpha'], digits=3)}: "
            f"{_fmt(s.oracle['rotation_error_deg'], digits=3)} deg / "
            f"{_fmt(s.oracle['translation_error_m'], 100, 2)} cm" for s in orc))
    return out


def _frames_line(result) -> list[str]:
    """Rendered frames per camera: used, dropped and why (none without rendering)."""
    fr = result.frames or {}
    if not fr.get("rendered"):
        return []
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
    return [f"frames: {head}; " + "; ".join(cams)]


def _pairing_line(result) -> list[str]:
    """The motion pairs used of the candidates, and what the pre-filter dropped."""
    p = result.pairing or {}
    if p.get("candidate_pairs") is None or p.get("matched") is None:
        return []
    return [f"motion pairs: {p.get('used')} used of {p.get('candidate_pairs')} "
            f"candidates (pre-filter dropped {p.get('dropped_translation')} for "
            f"translation, {p.get('dropped_rotation')} for rotation; "
            f"{p.get('dropped_time_diff')} datapoints for timestamp difference)"]


def _pose_error_line(result) -> list[str]:
    """The pose source's errors against the ground truth per camera (median, p95)."""
    if not result.pose_errors:
        return []
    parts = []
    for cam, e in result.pose_errors.items():
        sm = e.summary()
        if sm["n"]:
            parts.append(f"{cam}: median {_fmt(sm['rotation_deg']['median'], digits=3)} deg "
                         f"/ {_fmt(sm['translation_m']['median'], 1000, 2)} mm, p95 "
                         f"{_fmt(sm['rotation_deg']['p95'], digits=3)} deg / "
                         f"{_fmt(sm['translation_m']['p95'], 1000, 2)} mm")
    if not parts:
        return []
    src = next(iter(result.pose_errors.values())).source
    return [f"pose error of source '{src}' vs ground truth: " + "; ".join(parts)]
