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

from simcalib.studies.experiments import common, experiment
from simcalib.studies.experiments.common import ExperimentResult, fmt
from simcalib.world.synthetic import PAPER_X_ROTVEC_RAD, PAPER_X_TRANSLATION_M

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
    1/m); ``slow_samples``/``slow_alphas``: subsampling of the slow methods (``SolverInfo.slow``);
    ``opencv_samples``: samples for the OpenCV methods (each builds all i<j pairs of the
    chained poses, ~20-85 ms per problem); ``workers``: processes (0 = one per CPU);
    ``num_motions``: size of each D.2 data set; ``sigma_r_rad``/``sigma_t_m``: eq. 38 noise;
    ``seed``: everything random derives from it; ``chunk``: problems per solve_batch call."""
    samples: int = 1000
    n: int = 100
    num_alphas: int = 100
    alpha_min: float = 1e-2
    alpha_max: float = 10 ** 1.7
    scenarios: tuple[str, ...] = ("random", "line", "circle")
    algorithms: tuple[str, ...] = DEFAULT_ALGORITHMS
    slow_samples: int = 50
    slow_alphas: int = 20
    opencv_samples: int = 100
    workers: int = 0
    num_motions: int = 1000
    sigma_r_rad: float = math.radians(0.57)
    sigma_t_m: float = 0.01
    jitter_sigma_r_rad: float = math.radians(0.57)
    jitter_sigma_t_m: float = 0.01
    X_translation_m: tuple[float, ...] = PAPER_X_TRANSLATION_M
    X_rotvec_rad: tuple[float, ...] = PAPER_X_ROTVEC_RAD
    seed: int = 0
    chunk: int = 4096
    progress: bool = True
    output: str = "results/table2"

    def synthetic(self, scenario: str):
        """The :class:`SyntheticConfig` of one scenario."""
        from simcalib.world.synthetic import SyntheticConfig
        return SyntheticConfig(motion=scenario, num_motions=self.num_motions,
                               sigma_r_rad=self.sigma_r_rad, sigma_t_m=self.sigma_t_m,
                               jitter_sigma_r_rad=self.jitter_sigma_r_rad,
                               jitter_sigma_t_m=self.jitter_sigma_t_m,
                               X_translation_m=self.X_translation_m,
                               X_rotvec_rad=self.X_rotvec_rad)

    def __post_init__(self):
        from simcalib.config.checks import check_int, check_positive, check_that, set_fields
        set_fields(self,
                   **{name: check_int(name, getattr(self, name), lo=1)
                      for name in ("samples", "num_alphas", "slow_samples", "slow_alphas",
                                   "opencv_samples", "chunk")},
                   workers=check_int("workers", self.workers, lo=0),
                   n=check_int("n", self.n, lo=2),
                   num_motions=check_int("num_motions", self.num_motions, lo=2),
                   seed=check_int("seed", self.seed, lo=0),
                   sigma_r_rad=check_positive("sigma_r_rad", self.sigma_r_rad, allow_zero=True),
                   sigma_t_m=check_positive("sigma_t_m", self.sigma_t_m, allow_zero=True))
        common.alpha_grid(self.num_alphas, self.alpha_min, self.alpha_max)
        common.check_scenarios("scenarios", self.scenarios)
        common.check_methods("algorithms", self.algorithms)
        check_that(self.n <= self.num_motions, "n", self.n,
                   f"<= num_motions ({self.num_motions})")
        self.synthetic(self.scenarios[0])   # validates noise, jitter and X


def _subgrid(num: int, k: int) -> np.ndarray:
    """Indices of ``k`` (about evenly spread) points of a grid of ``num``."""
    if k >= num:
        return np.arange(num)
    return np.unique(np.round(np.linspace(0, num - 1, k)).astype(int))


def best_alpha_rows(scenario: str, sweep: common.SweepResult) -> list[dict]:
    """The two Table 2 rows (best rotation α, best translation α) of one sweep."""
    rot_med = np.array([common.median(r) for r in sweep.rot_deg])
    trans_med = np.array([common.median(t) for t in sweep.trans_cm])
    rows = []
    for kind, med in (("rotation", rot_med), ("translation", trans_med)):
        i = int(np.nanargmin(med))
        r = sweep.rot_deg[i]
        t = sweep.trans_cm[i]
        rows.append({
            "scenario": scenario, "algorithm": sweep.method, "alpha_kind": kind,
            "alpha": float(sweep.alphas[i]) if sweep.uses_alpha else math.nan,
            "rot_median_deg": common.median(r),
            "rot_p25_deg": common.percentile(r, 25),
            "rot_p75_deg": common.percentile(r, 75),
            "trans_median_cm": common.median(t),
            "trans_p25_cm": common.percentile(t, 25),
            "trans_p75_cm": common.percentile(t, 75),
        })
    return rows


def _plan(cfg: Table2Config, alg: str) -> tuple[int, np.ndarray, str]:
    """(number of samples, α indices, reason) for one algorithm."""
    all_alphas = np.arange(cfg.num_alphas)
    if common.is_slow(alg):
        return (min(cfg.samples, cfg.slow_samples), _subgrid(cfg.num_alphas, cfg.slow_alphas),
                "slow nonlinear")
    if alg.startswith("opencv_"):
        return min(cfg.samples, cfg.opencv_samples), all_alphas, "OpenCV (all i<j pairs)"
    return cfg.samples, all_alphas, ""


_DATA_CACHE: dict = {}


def scenario_problems(cfg: Table2Config, si: int):
    """The data set and bootstrap problems of scenario ``si`` (deterministic in the seed;
    cached per process)."""
    from simcalib.world.synthetic import generate_dataset, sample_problems
    key = (cfg.synthetic(cfg.scenarios[si]), cfg.seed, cfg.samples, cfg.n, si)
    if key not in _DATA_CACHE:
        _DATA_CACHE.clear()
        ss = np.random.SeedSequence(cfg.seed).spawn(len(cfg.scenarios))[si]
        data_ss, sample_ss, _ = ss.spawn(3)
        ds = generate_dataset(cfg.synthetic(cfg.scenarios[si]), np.random.default_rng(data_ss))
        C, H, _ = sample_problems(ds, cfg.samples, cfg.n, np.random.default_rng(sample_ss))
        _DATA_CACHE[key] = (ds, C, H)
    return _DATA_CACHE[key]


def _task(cfg: Table2Config, si: int, alg: str) -> common.SweepResult:
    """One (scenario, algorithm) sweep; module level so worker processes can run it."""
    ds, C, H = scenario_problems(cfg, si)
    m, a_idx, _ = _plan(cfg, alg)
    ai = cfg.algorithms.index(alg)
    solver_ss = np.random.SeedSequence(cfg.seed).spawn(len(cfg.scenarios))[si].spawn(3)[2]
    rng = np.random.default_rng(solver_ss.spawn(len(cfg.algorithms))[ai])
    alphas = common.alpha_grid(cfg.num_alphas, cfg.alpha_min, cfg.alpha_max)[a_idx]
    return common.sweep_errors(C[:m], H[:m], ds.X, alg, alphas, rng, chunk=cfg.chunk)


@experiment('table2', config=Table2Config,
            description="the paper's Table 2 (synthetic): accuracy per scenario and method at the best alpha")
def run(cfg: Table2Config) -> ExperimentResult:
    t_start = time.perf_counter()
    out = common.output_dir(cfg.output)
    workers = common.check_workers(cfg.workers)
    tasks, sweeps = _run_sweeps(cfg, workers)
    rows, sweep_rows, curves, notes, timing = [], [], {}, [], {}
    for (_, si, alg), sweep in zip(tasks, sweeps):
        scenario = cfg.scenarios[si]
        t = timing.setdefault(alg, [0.0, 0])
        t[0] += sweep.solve_s
        t[1] += sweep.solves
        rows.extend(best_alpha_rows(scenario, sweep))
        curves[(scenario, alg)] = sweep
        notes += _failure_notes(scenario, alg, sweep)
        sweep_rows += _sweep_rows(scenario, alg, sweep)
    notes += _plan_notes(cfg)
    runtime = time.perf_counter() - t_start
    notes.append(f"wall time {runtime:.1f} s with {workers} worker process(es); "
                 f"samples={cfg.samples}, n={cfg.n}, alphas={cfg.num_alphas}, "
                 f"num_motions={cfg.num_motions}, seed={cfg.seed}")
    timing_rows = [{"algorithm": a, "solves": n_, "solve_s": s_,
                    "us_per_problem": 1e6 * s_ / max(n_, 1)} for a, (s_, n_) in timing.items()]
    files = _write(cfg, out, rows, sweep_rows, timing_rows, curves, notes)
    return ExperimentResult("table2", out, files, rows, runtime, tuple(notes),
                            {"timing": timing_rows, "sweeps": curves})


def _run_sweeps(cfg: Table2Config, workers: int):
    """``(tasks, sweeps)``: one alpha sweep per scenario x algorithm, spread over the
    workers, the most expensive first."""
    tasks, weights, priority = [], [], []
    for si, _ in enumerate(cfg.scenarios):
        for alg in cfg.algorithms:
            m, a_idx, _ = _plan(cfg, alg)
            n_alpha = a_idx.size if common.uses_alpha(alg) else 1
            tasks.append((cfg, si, alg))
            weights.append(m * n_alpha)
            priority.append(m * n_alpha * common.expected_cost_us(alg))
    with common.progress(sum(weights), "table2", cfg.progress) as bar:
        sweeps = common.run_tasks(_task, tasks, workers, bar, weights, priority)
    return tasks, sweeps


def _failure_notes(scenario: str, alg: str, sweep) -> list[str]:
    notes = [f"{alg} on {scenario}: {cnt} solve(s) raised in solve_batch (counted as failed): "
             f"{msg}" for msg, cnt in sweep.errors.items()]
    if sweep.failed.any():
        worst = int(sweep.failed.sum(axis=1).max())
        notes.append(f"{alg} on {scenario}: up to {worst} of {sweep.rot_deg.shape[1]} "
                     "solves per alpha reported failure (no estimate; counted as "
                     "infinite error)")
    return notes


def _sweep_rows(scenario: str, alg: str, sweep) -> list[dict]:
    """One row per alpha of the sweep (one row for a method that takes no alpha)."""
    rows = []
    for ia, a in enumerate(sweep.alphas):
        rows.append({
            "scenario": scenario, "algorithm": alg,
            "alpha": float(a) if sweep.uses_alpha else math.nan,
            "samples": sweep.rot_deg.shape[1],
            "failed": int(sweep.failed[ia].sum()),
            "rot_median_deg": common.median(sweep.rot_deg[ia]),
            "rot_mean_deg": float(np.mean(sweep.rot_deg[ia])),
            "trans_median_cm": common.median(sweep.trans_cm[ia]),
            "trans_mean_cm": float(np.mean(sweep.trans_cm[ia])),
        })
        if not sweep.uses_alpha:
            break
    return rows


def _plan_notes(cfg: Table2Config) -> list[str]:
    """What was subsampled (slow methods) and which methods take no alpha."""
    notes = []
    for alg in cfg.algorithms:
        m, a_idx, why = _plan(cfg, alg)
        if m < cfg.samples or a_idx.size < cfg.num_alphas:
            n_alpha = a_idx.size if common.uses_alpha(alg) else 1
            notes.append(f"subsampled ({why}): {alg} on the first {m} of {cfg.samples} "
                         f"samples" + (f" and {n_alpha} of {cfg.num_alphas} alpha values"
                                       if common.uses_alpha(alg) else ""))
    no_alpha = [a for a in cfg.algorithms if not common.uses_alpha(a)]
    if no_alpha:
        notes.append(f"independent of alpha (solved once per sample): {', '.join(no_alpha)}")
    return notes


def _write(cfg, out, rows, sweep_rows, timing_rows, curves, notes) -> dict:
    """table2.csv, table2_sweep.csv, table2_timing.csv, table2.md, the sweep figure and the
    recording; their paths by kind."""
    files = {
        "csv": common.write_csv(out / "table2.csv", rows, CSV_COLUMNS),
        "sweep_csv": common.write_csv(out / "table2_sweep.csv", sweep_rows, SWEEP_COLUMNS),
        "timing_csv": common.write_csv(out / "table2_timing.csv", timing_rows,
                                       ["algorithm", "solves", "solve_s", "us_per_problem"]),
    }
    md = markdown(rows, cfg, notes, timing_rows)
    (out / "table2.md").write_text(md)
    files["md"] = out / "table2.md"
    from simcalib.studies.experiments import plots
    files["png"] = plots.table2_sweep_figure(curves, cfg.scenarios, cfg.algorithms,
                                             out / "table2_sweep.png")
    from simcalib.studies.experiments.recording import log_experiment
    files["rrd"] = log_experiment(out, "table2", {"table2_sweep": files["png"]}, {"table2": md})
    return files


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
    from simcalib.studies.experiments.paper import TABLE2_SYNTHETIC
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
