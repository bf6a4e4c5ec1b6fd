"""Matplotlib figures of the experiments (imported lazily).

Figures are built with the object-oriented API (``matplotlib.figure.Figure``), not pyplot:
no backend is selected or forced, so a user's own matplotlib backend stays untouched, and
``savefig`` renders the PNG with Agg by itself (no display needed).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["table2_sweep_figure", "table1_figure", "figure3", "figure6"]


def _subplots(*args, figsize=None, layout=None, **kwargs):
    """``(fig, axes)`` like ``pyplot.subplots``, on a standalone ``Figure``."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout=layout)
    return fig, fig.subplots(*args, **kwargs)


def _cmap(name: str):
    import matplotlib
    return matplotlib.colormaps[name]


def _finite(x: np.ndarray) -> np.ndarray:
    """Non-finite / non-positive values (failed solves) become NaN: gaps on log axes."""
    x = np.asarray(x, dtype=np.float64).copy()
    x[~np.isfinite(x) | (x <= 0)] = np.nan
    return x


def _log_axes(ax, x=True, y=True):
    """Log scales where the axis holds positive data (else linear), never an error."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if x:
            ax.set_xscale("log")
        if y:
            ys = [ln.get_ydata() for ln in ax.get_lines()]
            ok = any(np.any(np.isfinite(np.asarray(v, float)) & (np.asarray(v, float) > 0))
                     for v in ys)
            ax.set_yscale("log" if ok else "linear")


def _save(fig, path: Path) -> Path:
    path = Path(path)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path


def table2_sweep_figure(curves: dict, scenarios, algorithms, path: Path) -> Path:
    """Median rotation (top) and translation (bottom) error vs α, one column per scenario."""
    fig, axes = _subplots(2, len(scenarios), figsize=(5 * len(scenarios), 7.5),
                             squeeze=False, layout="constrained")
    cmap = _cmap("tab20")
    for j, s in enumerate(scenarios):
        for k, alg in enumerate(algorithms):
            sw = curves.get((s, alg))
            if sw is None:
                continue
            rot = _finite(np.median(sw.rot_deg, axis=1))
            tr = _finite(np.median(sw.trans_cm, axis=1))
            style = dict(color=cmap(k % 20), label=alg, lw=1.4)
            if sw.uses_alpha:
                axes[0, j].plot(sw.alphas, rot, **style)
                axes[1, j].plot(sw.alphas, tr, **style)
            else:
                if np.isfinite(rot[0]):
                    axes[0, j].axhline(rot[0], ls="--", **style)
                if np.isfinite(tr[0]):
                    axes[1, j].axhline(tr[0], ls="--", **style)
        for i, lab in enumerate(("median rotation error (deg)", "median translation error (cm)")):
            ax = axes[i, j]
            _log_axes(ax)
            ax.set_xlabel("alpha (1/m)")
            ax.set_ylabel(lab)
            ax.grid(True, which="both", alpha=0.3)
        axes[0, j].set_title(s)
    axes[0, -1].legend(fontsize=7, loc="best")
    fig.suptitle("Table 2 sweep: median errors over the alpha grid (dashed: no alpha)")
    return _save(fig, path)


def table1_figure(rel: dict, timing_rows: list, path: Path) -> Path:
    """Left: distribution of the relative cost differences (symlog); right: timing bars."""
    fig, (a1, a2) = _subplots(1, 2, figsize=(13, 4.5), layout="constrained")
    names = list(rel)
    data = [np.nan_to_num(np.concatenate(rel[m]), nan=0.0, posinf=1.0, neginf=-1.0)
            for m in names]
    a1.boxplot(data, orientation="horizontal", showfliers=True, whis=(0, 100))
    a1.set_yticks(range(1, len(names) + 1), names)
    a1.set_xscale("symlog", linthresh=1e-15)
    a1.axvline(0, color="k", lw=0.8)
    a1.set_xlabel("(alg - dqopt) / (alg + dqopt)")
    a1.set_title("relative cost difference to DQOpt (>0: higher cost)")
    t = sorted(timing_rows, key=lambda r: r["mean_us"])
    y = np.arange(len(t))
    a2.barh(y, [r["mean_us"] for r in t], xerr=[r["std_us"] for r in t], color="tab:blue",
            alpha=0.7, label="single solve (mean ± std)")
    a2.scatter([r["batch_us_per_problem"] for r in t], y, color="tab:red", zorder=3,
               label="solve_batch per problem")
    a2.set_yticks(y, [r["algorithm"] for r in t])
    a2.set_xscale("log")
    a2.set_xlabel("µs per problem (N = 100)")
    a2.legend(fontsize=8)
    a2.set_title("timing")
    return _save(fig, path)


def figure3(maps: dict, cfg, path: Path) -> Path:
    """2 rows (rotation, translation) x (scenarios at best α, then scenarios at α = 1)."""
    cols = [(s, "best") for s in cfg.scenarios] + [(s, "alpha1") for s in cfg.scenarios]
    fig, axes = _subplots(2, len(cols), figsize=(3.3 * len(cols), 6.4), squeeze=False)
    vals = np.concatenate([m.ravel() for m in maps.values()])
    vmax = max(1e-3, float(np.nanmax(np.abs(vals))))
    sr = [math.degrees(v) for v in cfg.sigma_r_rad]
    st = [100 * v for v in cfg.sigma_t_m]
    im = None
    for j, (s, mode) in enumerate(cols):
        for i, err in enumerate(("rotation", "translation")):
            ax = axes[i, j]
            m = maps[(s, mode, err)]
            im = ax.imshow(m, cmap="RdBu", vmin=-vmax, vmax=vmax, origin="lower", aspect="auto")
            for (r, c), v in np.ndenumerate(m):
                ax.text(c, r, f"{v:.1f}", ha="center", va="center", fontsize=6)
            ax.set_xticks(range(len(st)), [f"{v:g}" for v in st], fontsize=7, rotation=45)
            ax.set_yticks(range(len(sr)), [f"{v:g}" for v in sr], fontsize=7)
            if i == 1:
                ax.set_xlabel("σt (cm)")
            if j == 0:
                ax.set_ylabel(f"{err}\nσr (deg)")
            if i == 0:
                ax.set_title(f"{s}" + (" (best α)" if mode == "best" else " (α = 1)"), fontsize=10)
    fig.colorbar(im, ax=axes, shrink=0.8, label="log(mean err_dan / err_dqopt)")
    fig.suptitle("Figure 3: blue = DQOpt has e^value times lower error than Daniilidis")
    return _save(fig, path)


def figure6(curves: dict, alphas, cfg, path: Path) -> Path:
    """Rows: algorithms. Columns: mean rotation error vs α (σ_t varied, σ_r varied), mean
    translation error vs α (σ_t varied, σ_r varied)."""
    algs = list(cfg.algorithms)
    fig, axes = _subplots(len(algs), 4, figsize=(18, 3.6 * len(algs)), squeeze=False,
                             layout="constrained")
    panels = [("rot", "sigma_t", "Purples"), ("rot", "sigma_r", "Purples"),
              ("trans", "sigma_t", "Greens"), ("trans", "sigma_r", "Greens")]
    for i, alg in enumerate(algs):
        for j, (err, varied, cmap_name) in enumerate(panels):
            ax = axes[i, j]
            keys = [k for k in curves if k[0] == varied and k[3] == alg]
            cmap = _cmap(cmap_name)
            for n, k in enumerate(keys):
                rot, tr = curves[k]
                lvl = (f"σt={100 * k[2]:.3g} cm" if varied == "sigma_t"
                       else f"σr={math.degrees(k[1]):.3g}°")
                ax.plot(alphas, _finite(rot if err == "rot" else tr),
                        color=cmap(0.35 + 0.65 * n / max(1, len(keys) - 1)), label=lvl)
            _log_axes(ax)
            ax.grid(True, which="both", alpha=0.3)
            ax.set_xlabel("alpha (1/m)")
            ax.set_ylabel(f"{alg}: mean {'rotation (deg)' if err == 'rot' else 'translation (cm)'}")
            if i == 0:
                fixed = (f"σr = {math.degrees(cfg.fixed_sigma_r_rad):.3g}° fixed"
                         if varied == "sigma_t" else f"σt = {100 * cfg.fixed_sigma_t_m:.3g} cm fixed")
                ax.set_title(f"{'rotation' if err == 'rot' else 'translation'} error, "
                             f"{fixed}", fontsize=9)
            ax.legend(fontsize=6)
    fig.suptitle(f"Figure 6: effect of alpha ({cfg.scenario} scenario, {cfg.samples} samples)")
    return _save(fig, path)
