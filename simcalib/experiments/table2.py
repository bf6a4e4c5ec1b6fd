"""Table 2 (synthetic part): accuracy per scenario and algorithm at the best α.

For each scenario (random, line, circle) one D.2 data set is generated; ``samples`` problems
of ``n`` motions are bootstrapped from it; every algorithm solves every problem at every α of
the grid (100 log-spaced values in [1e-2, 10^1.7]) through ``solve_batch``. For each
algorithm the α with the lowest median rotation error and the α with the lowest median
translation error are reported, with median / 25th / 75th percentiles of both errors there.
The slow nonlinear methods (chvecopt, quatvecopt, dqnlopt, dqnloptrnd) run on the first
``slow_samples`` problems and every k-th α (``slow_alphas`` values) — stated in the output.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from simcalib.experiments import common
from simcalib.experiments.common import ExperimentResult, fmt

__all__ = ["Table2Config", "run", "CSV_COLUMNS", "DEFAULT_ALGORITHMS"]

CSV_COLUMNS = ["scenario", "algorithm", "alpha_kind", "alpha", "rot_median_deg", "rot_p25_deg",
               "rot_p75_deg", "trans_median_cm", "trans_p25_cm", "trans_p75_cm"]
SWEEP_COLUMNS = ["scenario", "algorithm", "alpha", "samples", "failed", "rot_median_deg",
                 "rot_mean_deg", "trans_median_cm", "trans_mean_cm"]
DEFAULT_ALGORITHMS = ("dqopt", "dq2ndord", "dqconvrlx", "dq2steps", "daniilidis", "chvecopt",
                      "quatvecopt", "opencv_tsai", "opencv_park", "opencv_horaud",
                      "opencv_andreff", "opencv_daniilidis")


@dataclass(frozen=True)
class Table2Config:
    """``samples``: bootstrap problems per scenario (paper 1000); ``n``: motions per problem
    (100); ``num_alphas``/``alpha_min``/``alpha_max``: the α grid (100 in [1e-2, 10^1.7],
    1/m); ``slow_samples``/``slow_alphas``: subsampling of :data:`common.SLOW_METHODS`;
    ``num_motions``: size of each D.2 data set; ``sigma_r_rad``/``sigma_t_m``: eq. 38 noise;
    ``seed``: everything random derives from it; ``chunk``: problems per solve_batch call."""
    samples: int = 1000
    n: int = 100
    num_alphas: int = 100
    alpha_min: float = 1e-2
    alpha_max: float = 10 ** 1.7
    scenarios: tuple[str, ...] = ("random", "line", "circle")
    algorithms: tuple[str, ...] = DEFAULT_ALGORITHMS
    slow_samples: int = 100
    slow_alphas: int = 25
    num_motions: int = 1000
    sigma_r_rad: float = math.radians(0.57)
    sigma_t_m: float = 0.01
    seed: int = 0
    chunk: int = 4096
    progress: bool = True
    output: str = "results/table2"

    def __post_init__(self):
        for name in ("samples", "num_alphas", "slow_samples", "slow_alphas", "chunk"):
            common.check_positive_int(name, getattr(self, name))
        common.check_positive_int("n", self.n, 2)
        common.check_positive_int("num_motions", self.num_motions, 2)
        common.check_positive_int("seed", self.seed, 0)
        common.check_positive_float("sigma_r_rad", self.sigma_r_rad, allow_zero=True)
        common.check_positive_float("sigma_t_m", self.sigma_t_m, allow_zero=True)
        common.alpha_grid(self.num_alphas, self.alpha_min, self.alpha_max)
        common.check_scenarios("scenarios", self.scenarios)
        common.check_methods("algorithms", self.algorithms)
        if self.n > self.num_motions:
            raise ValueError(f"n={self.n} must be <= num_motions={self.num_motions}")


def _subgrid(num: int, k: int) -> np.ndarray:
    """Indices of ``k`` (about evenly spread) points of a grid of ``num``."""
    if k >= num:
        return np.arange(num)
    return np.unique(np.round(np.linspace(0, num - 1, k)).astype(int))


def best_alpha_rows(scenario: str, sweep: common.SweepResult) -> list[dict]:
    """The two Table 2 rows (best rotation α, best translation α) of one sweep."""
    rot_med = np.median(sweep.rot_deg, axis=1)
    trans_med = np.median(sweep.trans_cm, axis=1)
    rows = []
    for kind, med in (("rotation", rot_med), ("translation", trans_med)):
        i = int(np.nanargmin(med))
        r = sweep.rot_deg[i]
        t = sweep.trans_cm[i]
        rows.append({
            "scenario": scenario, "algorithm": sweep.method, "alpha_kind": kind,
            "alpha": float(sweep.alphas[i]) if sweep.uses_alpha else math.nan,
            "rot_median_deg": float(np.median(r)),
            "rot_p25_deg": float(np.percentile(r, 25)),
            "rot_p75_deg": float(np.percentile(r, 75)),
            "trans_median_cm": float(np.median(t)),
            "trans_p25_cm": float(np.percentile(t, 25)),
            "trans_p75_cm": float(np.percentile(t, 75)),
        })
    return rows


def run(cfg: Table2Config) -> ExperimentResult:
    from simcalib.synthetic import SyntheticConfig, generate_dataset, sample_problems
    t_start = time.perf_counter()
    out = common.output_dir(cfg.output)
    alphas = common.alpha_grid(cfg.num_alphas, cfg.alpha_min, cfg.alpha_max)
    slow_idx = _subgrid(cfg.num_alphas, cfg.slow_alphas)
    rngs = common.child_rngs(cfg.seed, len(cfg.scenarios))
    rows, sweep_rows, curves = [], [], {}
    timing = {}
    total = 0
    for alg in cfg.algorithms:
        slow = alg in common.SLOW_METHODS
        total += (min(cfg.samples, cfg.slow_samples) * len(slow_idx) if slow
                  else cfg.samples * cfg.num_alphas)
    total *= len(cfg.scenarios)
    notes = []
    with common.progress(total, "table2", cfg.progress) as bar:
        for scenario, rng in zip(cfg.scenarios, rngs):
            data_rng, sample_rng, solver_rng = rng.spawn(3)
            scfg = SyntheticConfig(motion=scenario, num_motions=cfg.num_motions,
                                   sigma_r_rad=cfg.sigma_r_rad, sigma_t_m=cfg.sigma_t_m)
            ds = generate_dataset(scfg, data_rng)
            C, H, _ = sample_problems(ds, cfg.samples, cfg.n, sample_rng)
            for alg in cfg.algorithms:
                slow = alg in common.SLOW_METHODS
                if slow:
                    m = min(cfg.samples, cfg.slow_samples)
                    sweep = common.sweep_errors(C[:m], H[:m], ds.X, alg, alphas[slow_idx],
                                                solver_rng, chunk=cfg.chunk, bar=bar)
                else:
                    sweep = common.sweep_errors(C, H, ds.X, alg, alphas, solver_rng,
                                                chunk=cfg.chunk, bar=bar)
                t = timing.setdefault(alg, [0.0, 0])
                t[0] += sweep.solve_s
                t[1] += sweep.solves
                rows.extend(best_alpha_rows(scenario, sweep))
                if sweep.failed.any():
                    worst = int(sweep.failed.sum(axis=1).max())
                    notes.append(f"{alg} on {scenario}: up to {worst} of "
                                 f"{sweep.rot_deg.shape[1]} solves per alpha reported failure "
                                 "(no estimate; counted as infinite error)")
                curves[(scenario, alg)] = sweep
                for ia, a in enumerate(sweep.alphas):
                    sweep_rows.append({
                        "scenario": scenario, "algorithm": alg,
                        "alpha": float(a) if sweep.uses_alpha else math.nan,
                        "samples": sweep.rot_deg.shape[1],
                        "failed": int(sweep.failed[ia].sum()),
                        "rot_median_deg": float(np.median(sweep.rot_deg[ia])),
                        "rot_mean_deg": float(np.mean(sweep.rot_deg[ia])),
                        "trans_median_cm": float(np.median(sweep.trans_cm[ia])),
                        "trans_mean_cm": float(np.mean(sweep.trans_cm[ia])),
                    })
                    if not sweep.uses_alpha:
                        break
    slow_used = [a for a in cfg.algorithms if a in common.SLOW_METHODS]
    if slow_used:
        notes.append(f"subsampled (slow nonlinear): {', '.join(slow_used)} on "
                     f"{min(cfg.samples, cfg.slow_samples)} of {cfg.samples} samples and "
                     f"{len(slow_idx)} of {cfg.num_alphas} alpha values")
    no_alpha = [a for a in cfg.algorithms if not common.solver_info(a).uses_alpha]
    if no_alpha:
        notes.append(f"independent of alpha (solved once per sample): {', '.join(no_alpha)}")
    runtime = time.perf_counter() - t_start
    notes.append(f"wall time {runtime:.1f} s; samples={cfg.samples}, n={cfg.n}, "
                 f"alphas={cfg.num_alphas}, num_motions={cfg.num_motions}, seed={cfg.seed}")
    files = {
        "csv": common.write_csv(out / "table2.csv", rows, CSV_COLUMNS),
        "sweep_csv": common.write_csv(out / "table2_sweep.csv", sweep_rows, SWEEP_COLUMNS),
    }
    timing_rows = [{"algorithm": a, "solves": n_, "solve_s": s,
                    "us_per_problem": 1e6 * s / max(n_, 1)} for a, (s, n_) in timing.items()]
    files["timing_csv"] = common.write_csv(out / "table2_timing.csv", timing_rows,
                                           ["algorithm", "solves", "solve_s", "us_per_problem"])
    md = markdown(rows, cfg, notes, timing_rows)
    (out / "table2.md").write_text(md)
    files["md"] = out / "table2.md"
    from simcalib.experiments import plots
    files["png"] = plots.table2_sweep_figure(curves, cfg.scenarios, cfg.algorithms,
                                             out / "table2_sweep.png")
    from simcalib.experiments.recording import log_experiment
    files["rrd"] = log_experiment(out, "table2", {"table2_sweep": files["png"]}, {"table2": md})
    return ExperimentResult("table2", out, files, rows, runtime, tuple(notes),
                            {"timing": timing_rows})


def _cell(row, paper=None) -> tuple[str, str, str]:
    rot = f"{fmt(row['rot_median_deg'])} [{fmt(row['rot_p25_deg'])}, {fmt(row['rot_p75_deg'])}]"
    tr = (f"{fmt(row['trans_median_cm'])} [{fmt(row['trans_p25_cm'])}, "
          f"{fmt(row['trans_p75_cm'])}]")
    a = "-" if math.isnan(row["alpha"]) else fmt(row["alpha"], 2)
    return rot, tr, a


def markdown(rows: list[dict], cfg: Table2Config, notes, timing_rows=None,
             with_paper: bool = True) -> str:
    """Table 2 as markdown: one block per α kind, one row per algorithm, per scenario the
    median [p25, p75] of rotation (deg) and translation (cm) errors and α; with the paper's
    median (ours / paper) where the paper has the algorithm."""
    from simcalib.experiments.paper import TABLE2_SYNTHETIC
    idx = {(r["scenario"], r["algorithm"], r["alpha_kind"]): r for r in rows}
    lines = [f"# Table 2 (synthetic): {cfg.samples} samples of n = {cfg.n}, "
             f"{cfg.num_alphas} alpha values in [{cfg.alpha_min:g}, {cfg.alpha_max:.4g}]\n",
             "Cells: median [25th, 75th percentile]. Rotation error in degrees, translation "
             "error in cm; alpha in 1/m. `paper` = the paper's median.\n"]
    for kind in ("rotation", "translation"):
        header = ["algorithm"]
        for s in cfg.scenarios:
            header += [f"{s} rot (deg)", f"{s} trans (cm)", f"{s} alpha"]
            if with_paper:
                header += [f"{s} paper rot / trans / alpha"]
        body = []
        for alg in cfg.algorithms:
            line = [alg]
            for s in cfg.scenarios:
                r = idx.get((s, alg, kind))
                line += list(_cell(r)) if r else ["-", "-", "-"]
                if with_paper:
                    p = TABLE2_SYNTHETIC.get(s, {}).get(kind, {}).get(alg)
                    line.append("-" if p is None else
                                f"{fmt(p[0])} / {fmt(p[3])} / {'-' if p[6] is None else p[6]}")
            body.append(line)
        lines.append(f"\n## best {kind} alpha\n")
        lines.append(common.markdown_table(header, body))
    if timing_rows:
        lines.append("\n## solve time\n")
        lines.append(common.markdown_table(
            ["algorithm", "problems solved", "total s", "µs / problem"],
            [[t["algorithm"], t["solves"], f"{t['solve_s']:.2f}", f"{t['us_per_problem']:.1f}"]
             for t in timing_rows]))
    if notes:
        lines.append("\n" + "\n".join(f"- {n}" for n in notes) + "\n")
    return "".join(lines)
