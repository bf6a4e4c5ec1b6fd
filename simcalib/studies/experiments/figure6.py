"""Figure 6: effect of α on the mean errors of daniilidis, dqopt and dqconvrlx on ``random``.

Two sweeps of the measurement noise: vary σ_t with σ_r fixed (``fixed_sigma_r_rad``), and
vary σ_r with σ_t fixed (``fixed_sigma_t_m``). At every noise level a D.2 ``random`` data set
is generated (common random numbers: the same motions, standardised noise draws and samples at
every level), ``samples`` problems are bootstrapped (paper: 60) and each algorithm runs over
the α grid. Plotted: mean rotation error (left two columns) and mean translation error
(right two columns) against α, one row per algorithm, one line per noise level.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from simcalib.studies.experiments import common, experiment
from simcalib.studies.experiments.common import ExperimentResult, fmt

__all__ = ["Figure6Config", "run", "CSV_COLUMNS"]

CSV_COLUMNS = ["varied", "sigma_r_deg", "sigma_t_cm", "algorithm", "alpha", "rot_mean_deg",
               "rot_median_deg", "trans_mean_cm", "trans_median_cm"]


@dataclass(frozen=True)
class Figure6Config:
    samples: int = 60
    n: int = 100
    scenario: str = "random"
    algorithms: tuple[str, ...] = ("daniilidis", "dqopt", "dqconvrlx")
    sigma_r_rad: tuple[float, ...] = tuple(math.radians(d) for d in (0.1, 0.25, 0.57, 1.0, 2.0))
    sigma_t_m: tuple[float, ...] = (0.0025, 0.005, 0.01, 0.02, 0.04)
    fixed_sigma_r_rad: float = math.radians(0.57)
    fixed_sigma_t_m: float = 0.01
    num_alphas: int = 100
    alpha_min: float = 1e-2
    alpha_max: float = 10 ** 1.7
    num_motions: int = 1000
    seed: int = 0
    chunk: int = 4096
    workers: int = 0
    progress: bool = True
    output: str = "results/figure6"

    def __post_init__(self):
        from simcalib.config.checks import check_positive, check_that, set_fields
        set_fields(self, **common.noise_grid_fields(self),
                   fixed_sigma_r_rad=check_positive("fixed_sigma_r_rad",
                                                    self.fixed_sigma_r_rad, allow_zero=True),
                   fixed_sigma_t_m=check_positive("fixed_sigma_t_m", self.fixed_sigma_t_m,
                                                  allow_zero=True))
        common.alpha_grid(self.num_alphas, self.alpha_min, self.alpha_max)
        common.check_scenarios("scenario", (self.scenario,))
        common.check_methods("algorithms", self.algorithms)
        check_that(self.n <= self.num_motions, "n", self.n,
                   f"<= num_motions ({self.num_motions})")


def _level(cfg: Figure6Config, sr: float, st: float) -> dict:
    """One noise level: every algorithm over the α grid; ``{alg: (rot_mean, rot_median,
    trans_mean, trans_median)}`` each ``(A,)``."""
    from simcalib.world.synthetic import SyntheticConfig, generate_dataset, sample_problems
    alphas = common.alpha_grid(cfg.num_alphas, cfg.alpha_min, cfg.alpha_max)
    # common random numbers: every level uses the same motions, standardised noise draws
    # and samples (scaled by the level's sigmas), so curves differ by the noise level only
    ss = np.random.SeedSequence(cfg.seed)
    data_rng, sample_rng, solver_rng = (np.random.default_rng(x) for x in ss.spawn(3))
    ds = generate_dataset(SyntheticConfig(motion=cfg.scenario, num_motions=cfg.num_motions,
                                          sigma_r_rad=sr, sigma_t_m=st), data_rng)
    C, H, _ = sample_problems(ds, cfg.samples, cfg.n, sample_rng)
    out = {}
    for alg in cfg.algorithms:
        sw = common.sweep_errors(C, H, ds.X, alg, alphas, solver_rng, chunk=cfg.chunk)
        out[alg] = (sw.rot_deg.mean(axis=1), np.array([common.median(r) for r in sw.rot_deg]),
                    sw.trans_cm.mean(axis=1), np.array([common.median(t) for t in sw.trans_cm]))
    return out


@experiment('figure6', config=Figure6Config,
            description="the paper's Figure 6: the effect of alpha on the mean errors")
def run(cfg: Figure6Config) -> ExperimentResult:
    t_start = time.perf_counter()
    out = common.output_dir(cfg.output)
    workers = common.check_workers(cfg.workers)
    alphas = common.alpha_grid(cfg.num_alphas, cfg.alpha_min, cfg.alpha_max)
    levels = ([("sigma_t", cfg.fixed_sigma_r_rad, st) for st in cfg.sigma_t_m]
              + [("sigma_r", sr, cfg.fixed_sigma_t_m) for sr in cfg.sigma_r_rad])
    tasks = [(cfg, sr, st) for _, sr, st in levels]
    per_task = len(cfg.algorithms) * cfg.samples * alphas.size
    with common.progress(per_task * len(tasks), "figure6", cfg.progress) as bar:
        results = common.run_tasks(_level, tasks, workers, bar, [per_task] * len(tasks))
    curves = {}   # (varied, σ_r, σ_t, algorithm) -> (rot_mean (A,), trans_mean (A,))
    rows = []
    for (varied, sr, st), res in zip(levels, results):
        for alg in cfg.algorithms:
            rot_mean, rot_med, trans_mean, trans_med = res[alg]
            curves[(varied, sr, st, alg)] = (rot_mean, trans_mean)
            for ia, a in enumerate(alphas):
                rows.append({"varied": varied, "sigma_r_deg": math.degrees(sr),
                             "sigma_t_cm": 100 * st, "algorithm": alg, "alpha": float(a),
                             "rot_mean_deg": float(rot_mean[ia]),
                             "rot_median_deg": float(rot_med[ia]),
                             "trans_mean_cm": float(trans_mean[ia]),
                             "trans_median_cm": float(trans_med[ia])})
    runtime = time.perf_counter() - t_start
    notes = [f"scenario {cfg.scenario}; {cfg.samples} samples of n = {cfg.n} per noise level; "
             f"{cfg.num_alphas} alpha values in [{cfg.alpha_min:g}, {cfg.alpha_max:.4g}]; "
             f"fixed sigma_r = {math.degrees(cfg.fixed_sigma_r_rad):.3g} deg, fixed sigma_t = "
             f"{100 * cfg.fixed_sigma_t_m:.3g} cm",
             f"wall time {runtime:.1f} s with {workers} worker process(es), seed={cfg.seed}"]
    files = {"csv": common.write_csv(out / "figure6.csv", rows, CSV_COLUMNS)}
    md = markdown(curves, alphas, cfg, notes)
    (out / "figure6.md").write_text(md)
    files["md"] = out / "figure6.md"
    from simcalib.studies.experiments import plots
    files["png"] = plots.figure6(curves, alphas, cfg, out / "figure6.png")
    from simcalib.studies.experiments.recording import log_experiment
    files["rrd"] = log_experiment(out, "figure6", {"figure6": files["png"]}, {"figure6": md})
    return ExperimentResult("figure6", out, files, rows, runtime, tuple(notes),
                            {"curves": curves, "alphas": alphas})


def markdown(curves, alphas, cfg: Figure6Config, notes) -> str:
    """Per noise level and algorithm: the α minimising the mean rotation / translation error
    and the minimum, plus the errors at α = the grid value nearest 1."""
    i_one = int(np.argmin(np.abs(np.log(alphas))))
    lines = ["# Figure 6: effect of alpha on mean errors (random scenario)\n\n"]
    body = []
    for (varied, sr, st, alg), (rot, tr) in curves.items():
        ir, it = int(np.argmin(rot)), int(np.argmin(tr))
        body.append([varied, fmt(math.degrees(sr)), fmt(100 * st), alg,
                     f"{fmt(rot[ir])} @ {fmt(alphas[ir], 2)}", f"{fmt(tr[it])} @ {fmt(alphas[it], 2)}",
                     fmt(rot[i_one]), fmt(tr[i_one])])
    lines.append(common.markdown_table(
        ["varied", "σr (deg)", "σt (cm)", "algorithm", "min mean rot (deg) @ alpha",
         "min mean trans (cm) @ alpha", f"rot @ alpha={fmt(alphas[i_one], 2)}",
         f"trans @ alpha={fmt(alphas[i_one], 2)}"], body))
    lines.append("\n" + "\n".join(f"- {n}" for n in notes) + "\n")
    return "".join(lines)
