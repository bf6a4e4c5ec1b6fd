"""The report of a sweep directory: ``report.md``, PNG plots and ``report.rrd``, rebuilt
from the stored cells (``simcalib sweep report DIR``), never from memory.

Per swept axis and solver: median and interquartile range of the rotation and translation
errors, failure rate (no estimate) and degeneracy rate (flagged by the verdict), runtime.
Solver comparisons ("dqopt vs daniilidis: median error ratio") are computed cell by cell
over the cells where both succeeded.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from simcalib.studies.sweep import store

__all__ = ["write_report", "summarise"]


def _num(v) -> float:
    return float(v) if isinstance(v, (int, float)) and v is not None and not isinstance(
        v, bool) else math.nan


def _groups(rows: list[dict], axis: str | None) -> dict:
    out: dict[Any, dict[str, list[dict]]] = {}
    for r in rows:
        if r.get("solver") is None:
            continue
        val = r.get(axis) if axis else "all"
        out.setdefault(val, {}).setdefault(r["solver"], []).append(r)
    return out


def _stats(rs: list[dict]) -> dict[str, float]:
    rot = np.array([_num(r.get("rotation_error_deg")) for r in rs])
    tr = np.array([_num(r.get("translation_error_m")) for r in rs])
    ok = np.isfinite(rot)
    q = (lambda a, p: float(np.percentile(a[np.isfinite(a)], p)) if np.isfinite(a).any()
         else math.nan)
    deg = [r.get("degenerate") for r in rs]
    return {"n": len(rs), "failed": float(np.mean(~ok)) if rs else math.nan,
            "degenerate": float(np.mean([bool(d) for d in deg])) if rs else math.nan,
            "rot_med": q(rot, 50), "rot_q1": q(rot, 25), "rot_q3": q(rot, 75),
            "tr_med": q(tr, 50), "tr_q1": q(tr, 25), "tr_q3": q(tr, 75),
            "runtime_med": q(np.array([_num(r.get("runtime_s")) for r in rs]), 50),
            "sig_rot_med": q(np.array([_num(r.get("sigma_rotation_deg")) for r in rs]), 50),
            "sig_tr_med": q(np.array([_num(r.get("sigma_translation_m")) for r in rs]), 50)}


def summarise(rows: list[dict], axes: list[str]) -> dict:
    """Statistics per axis value and solver, and pairwise median error ratios."""
    per_axis = {}
    for axis in axes or [None]:
        per_axis[axis or "all"] = {val: {s: _stats(rs) for s, rs in by_solver.items()}
                                   for val, by_solver in _groups(rows, axis).items()}
    solvers = sorted({r["solver"] for r in rows if r.get("solver")})
    by_cell: dict[int, dict[str, dict]] = {}
    for r in rows:
        if r.get("solver"):
            by_cell.setdefault(r["cell"], {})[r["solver"]] = r
    ratios = {}
    for a in solvers:
        for b in solvers:
            if a >= b:
                continue
            rr, tt = [], []
            for sols in by_cell.values():
                if a in sols and b in sols:
                    ra, rb = _num(sols[a].get("rotation_error_deg")), _num(
                        sols[b].get("rotation_error_deg"))
                    ta, tb = _num(sols[a].get("translation_error_m")), _num(
                        sols[b].get("translation_error_m"))
                    if np.isfinite([ra, rb]).all() and rb > 0:
                        rr.append(ra / rb)
                    if np.isfinite([ta, tb]).all() and tb > 0:
                        tt.append(ta / tb)
            if rr or tt:
                ratios[(a, b)] = {"n": max(len(rr), len(tt)),
                                  "rotation": float(np.median(rr)) if rr else math.nan,
                                  "translation": float(np.median(tt)) if tt else math.nan}
    return {"per_axis": per_axis, "ratios": ratios, "solvers": solvers}


def _fmt(x, digits=3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def _plot(per_axis: dict, axis: str, out: Path) -> Path | None:
    from matplotlib.figure import Figure
    vals = list(per_axis[axis])
    if not vals:
        return None
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals)
    order = sorted(vals) if numeric else sorted(vals, key=str)
    xs = order if numeric else list(range(len(order)))
    solvers = sorted({s for v in order for s in per_axis[axis][v]})
    fig = Figure(figsize=(11, 3.6), layout="constrained")
    panels = [("rot", "rotation error [deg]"), ("tr", "translation error [cm]"),
              ("failed", "failure / degeneracy rate")]
    axs = fig.subplots(1, 3)
    for ax, (what, label) in zip(axs, panels):
        for s in solvers:
            st = [per_axis[axis][v].get(s) for v in order]
            if what == "failed":
                ax.plot(xs, [x["failed"] if x else np.nan for x in st], "o-", label=f"{s} failed")
                ax.plot(xs, [x["degenerate"] if x else np.nan for x in st], "x--",
                        label=f"{s} degenerate")
                continue
            scale = 100.0 if what == "tr" else 1.0
            med = np.array([x[f"{what}_med"] if x else np.nan for x in st]) * scale
            lo = np.array([x[f"{what}_q1"] if x else np.nan for x in st]) * scale
            hi = np.array([x[f"{what}_q3"] if x else np.nan for x in st]) * scale
            ax.plot(xs, med, "o-", label=s)
            ax.fill_between(xs, lo, hi, alpha=0.2)
        if what != "failed" and _log_scale_wanted(ax):
            ax.set_yscale("log")
        ax.set_xlabel(axis)
        ax.set_ylabel(label)
        if numeric and len(xs) > 2 and min(xs) > 0 and max(xs) / min(xs) > 20:
            ax.set_xscale("log")
        if not numeric:
            ax.set_xticks(xs, [str(v) for v in order], rotation=30)
        ax.grid(alpha=0.3)
    axs[0].legend(fontsize=7)
    axs[2].legend(fontsize=6)
    fig.suptitle(f"error against {axis} (median, IQR band)")
    path = out / f"plot_{axis.replace('.', '_')}.png"
    fig.savefig(path, dpi=90)
    return path


def _cells_text(manifest: dict) -> str:
    """What ran, counted from the manifest's cells (not the sweep file's description):
    ``20 = 10 combinations of the swept values x 2 seeds``."""
    cells = manifest["cells"]
    seeds = len({c["replicate"] for c in cells})
    combos = len({json.dumps(c["values"], sort_keys=True, default=str) for c in cells})
    return (f"{len(cells)} = {combos} combination{'s' if combos != 1 else ''} of the swept "
            f"values x {seeds} seed{'s' if seeds != 1 else ''}")


def _log_scale_wanted(ax) -> bool:
    """Error panels are drawn on a log scale whenever they hold a positive value: errors
    of good and bad solvers differ by decades, and on a linear axis one bad solver
    flattens the others onto zero."""
    ys = np.concatenate([np.asarray(ln.get_ydata(), dtype=float).ravel()
                         for ln in ax.get_lines()] or [np.zeros(0)])
    return bool((np.isfinite(ys) & (ys > 0)).any())


def write_report(output: str | Path) -> Path:
    """Write ``report.md`` (+ ``plot_<axis>.png``) from the stored cells."""
    out = Path(output)
    manifest = store.read_manifest(out)
    rows = store.table(out)
    axes = [a for a in manifest["axes"]]
    summ = summarise(rows, axes)
    st = store.status(out)
    spec = manifest["spec"]
    lines = [f"# Sweep `{spec['name']}`", "", spec.get("description") or "", "",
             f"Base scenario `{spec['base']}`, sweep seed {spec['seed']}; axes: "
             f"{', '.join(f'`{a}`' for a in axes) or '(none)'}.",
             f"Cells: {_cells_text(manifest)} ({st['done']} done, {st['failed']} failed, "
             f"{st['remaining']} remaining); mean cell time "
             f"{_fmt(st['cell_s_mean'])} s "
             f"(about {_fmt(3600 / st['cell_s_mean'], 4) if st['cell_s_mean'] else '–'} "
             f"cells per hour per core).", ""]
    if summ["ratios"]:
        lines += ["## Solver comparisons (cell by cell, both succeeded)", "",
                  "| solver A vs B | cells | median rotation error ratio A/B | "
                  "median translation error ratio A/B |", "|---|---|---|---|"]
        for (a, b), r in sorted(summ["ratios"].items()):
            lines.append(f"| {a} vs {b} | {r['n']} | {_fmt(r['rotation'])} | "
                         f"{_fmt(r['translation'])} |")
        lines.append("")
    for axis, table in summ["per_axis"].items():
        lines += [f"## Against `{axis}`", "",
                  f"| {axis} | solver | n | rotation error [deg] median (IQR) | translation "
                  f"error [cm] median (IQR) | predicted σ [deg / cm] median | failed | "
                  f"degenerate | runtime [ms] |",
                  "|---|---|---|---|---|---|---|---|---|"]
        keyf = (lambda v: (0, v)) if all(isinstance(v, (int, float)) for v in table) else (
            lambda v: (1, str(v)))
        for val in sorted(table, key=keyf):
            for s, x in sorted(table[val].items()):
                lines.append(
                    f"| {_fmt(val)} | {s} | {x['n']} | {_fmt(x['rot_med'])} "
                    f"({_fmt(x['rot_q1'])}–{_fmt(x['rot_q3'])}) | {_fmt(x['tr_med'] * 100)} "
                    f"({_fmt(x['tr_q1'] * 100)}–{_fmt(x['tr_q3'] * 100)}) | "
                    f"{_fmt(x['sig_rot_med'])} / {_fmt(x['sig_tr_med'] * 100)} | "
                    f"{x['failed']:.0%} | {x['degenerate']:.0%} | "
                    f"{_fmt(x['runtime_med'] * 1000)} |")
        png = _plot(summ["per_axis"], axis, out) if rows else None
        if png is not None:
            lines += ["", f"![{axis}]({png.name})"]
        lines.append("")
    if st["failed_cells"]:
        lines += ["## Failed cells", ""]
        lines += [f"- cell {c['index']} (`{c['key']}`): {(c['error'] or {}).get('type')}: "
                  f"{(c['error'] or {}).get('message')}" for c in st["failed_cells"]]
        lines.append("")
    if rows:
        from simcalib.report.rerun.studies import record_sweep
        record_sweep(out / "report.rrd", summ)
        lines += ["The same plots as a rerun recording: `rerun report.rrd`.", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path
