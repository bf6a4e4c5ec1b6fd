"""Figure 3: Daniilidis vs DQOpt over a grid of rotation x translation noise.

For each scenario and each (σ_r, σ_t) cell a D.2 data set is generated with that
measurement noise (common random numbers: the same motions, standardised noise draws and
samples in every cell of a scenario, so cells differ by the noise level only) (the line/circle jitter stays at the paper's 0.57° / 1 cm, it is part of
the motion), ``samples`` problems of ``n`` motions are bootstrapped (paper: 60), and both
solvers run over the α grid. Plotted: ``log(mean_i(err_dan_i / err_dqopt_i))`` with each
solver at its own best α (lowest mean error of the plotted quantity), for rotation (top
row) and translation (bottom row); and the same at α = 1 (the paper's last column; here
for every scenario). Positive (blue) = DQOpt's error is e^value times lower.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from simcalib.studies.experiments import common, experiment
from simcalib.studies.experiments.common import ExperimentResult, fmt

__all__ = ["Figure3Config", "run", "CSV_COLUMNS"]

CSV_COLUMNS = ["scenario", "alpha_mode", "error", "sigma_r_deg", "sigma_t_cm",
               "dqopt_alpha", "daniilidis_alpha", "dqopt_mean", "daniilidis_mean",
               "log_mean_ratio"]


@dataclass(frozen=True)
class Figure3Config:
    """``sigma_r_rad`` / ``sigma_t_m``: the noise grid (rows x columns of each heat map);
    ``samples``: problems per cell (paper 60); ``num_alphas``: α grid size for the best-α
    search (log-spaced in [alpha_min, alpha_max])."""
    samples: int = 60
    n: int = 100
    scenarios: tuple[str, ...] = ("line", "circle", "random")
    sigma_r_rad: tuple[float, ...] = tuple(math.radians(d) for d in
                                           (0.05, 0.1, 0.25, 0.57, 1.0, 2.0))
    sigma_t_m: tuple[float, ...] = (0.001, 0.0025, 0.005, 0.01, 0.025, 0.05)
    num_alphas: int = 100
    alpha_min: float = 1e-2
    alpha_max: float = 10 ** 1.7
    num_motions: int = 1000
    seed: int = 0
    chunk: int = 4096
    workers: int = 0
    progress: bool = True
    output: str = "results/figure3"

    def __post_init__(self):
        from simcalib.config.checks import check_that, set_fields
        set_fields(self, **common.noise_grid_fields(self))
        common.alpha_grid(self.num_alphas, self.alpha_min, self.alpha_max)
        common.check_scenarios("scenarios", self.scenarios)
        check_that(self.n <= self.num_motions, "n", self.n,
                   f"<= num_motions ({self.num_motions})")


def _ratio(num: np.ndarray, den: np.ndarray) -> float:
    """log of the mean of per-sample ratios (floors at 1e-12 keep exact zeros finite)."""
    return float(np.log(np.mean(np.maximum(num, 1e-12) / np.maximum(den, 1e-12))))


def _cell(cfg: Figure3Config, s: str, sr: float, st: float) -> dict:
    """One (scenario, σ_r, σ_t) cell: both solvers over the α grid (+ α = 1); returns
    ``{(mode, error): (value, dqopt α, dan α, dqopt mean, dan mean)}``."""
    from simcalib.world.synthetic import SyntheticConfig, generate_dataset, sample_problems
    alphas = common.alpha_grid(cfg.num_alphas, cfg.alpha_min, cfg.alpha_max)
    alphas_run = np.unique(np.concatenate([alphas, [1.0]]))
    i_one = int(np.argmin(np.abs(alphas_run - 1.0)))
    grid = np.isin(alphas_run, alphas)
    # common random numbers: within a scenario every cell uses the same motions, the same
    # standardised noise draws (scaled by the cell's sigmas) and the same samples, so the
    # map varies with the noise level only
    ss = np.random.SeedSequence(cfg.seed).spawn(len(cfg.scenarios))[cfg.scenarios.index(s)]
    data_rng, sample_rng, solver_rng = (np.random.default_rng(x) for x in ss.spawn(3))
    ds = generate_dataset(SyntheticConfig(motion=s, num_motions=cfg.num_motions,
                                          sigma_r_rad=sr, sigma_t_m=st), data_rng)
    C, H, _ = sample_problems(ds, cfg.samples, cfg.n, sample_rng)
    sw = {m: common.sweep_errors(C, H, ds.X, m, alphas_run, solver_rng, chunk=cfg.chunk)
          for m in ("dqopt", "daniilidis")}
    out = {}
    for err, attr in (("rotation", "rot_deg"), ("translation", "trans_cm")):
        e_opt = getattr(sw["dqopt"], attr)
        e_dan = getattr(sw["daniilidis"], attr)
        j_opt = int(np.argmin(np.where(grid, e_opt.mean(axis=1), np.inf)))
        j_dan = int(np.argmin(np.where(grid, e_dan.mean(axis=1), np.inf)))
        for mode, jo, jd in (("best", j_opt, j_dan), ("alpha1", i_one, i_one)):
            out[(mode, err)] = (_ratio(e_dan[jd], e_opt[jo]), float(alphas_run[jo]),
                                float(alphas_run[jd]), float(e_opt[jo].mean()),
                                float(e_dan[jd].mean()))
    return out


@experiment('figure3', config=Figure3Config,
            description="the paper's Figure 3: Daniilidis vs DQOpt over rotation x translation noise")
def run(cfg: Figure3Config) -> ExperimentResult:
    t_start = time.perf_counter()
    out = common.output_dir(cfg.output)
    workers = common.check_workers(cfg.workers)
    R, T = len(cfg.sigma_r_rad), len(cfg.sigma_t_m)
    tasks = []
    for s in cfg.scenarios:
        for sr in cfg.sigma_r_rad:
            for st in cfg.sigma_t_m:
                tasks.append((cfg, s, sr, st))
    per_task = cfg.samples * (cfg.num_alphas + 1) * 2
    with common.progress(per_task * len(tasks), "figure3", cfg.progress) as bar:
        results = common.run_tasks(_cell, tasks, workers, bar, [per_task] * len(tasks))
    maps = {}   # (scenario, mode, error) -> (R, T) array
    rows = []
    for (_, s, sr, st), res in zip(tasks, results):
        ir, it = cfg.sigma_r_rad.index(sr), cfg.sigma_t_m.index(st)
        for (mode, err), (val, a_opt, a_dan, m_opt, m_dan) in res.items():
            maps.setdefault((s, mode, err), np.full((R, T), np.nan))[ir, it] = val
            rows.append({"scenario": s, "alpha_mode": mode, "error": err,
                         "sigma_r_deg": math.degrees(sr), "sigma_t_cm": 100 * st,
                         "dqopt_alpha": a_opt, "daniilidis_alpha": a_dan,
                         "dqopt_mean": m_opt, "daniilidis_mean": m_dan,
                         "log_mean_ratio": val})
    runtime = time.perf_counter() - t_start
    notes = [f"{cfg.samples} samples of n = {cfg.n} per cell; best alpha from "
             f"{cfg.num_alphas} values in [{cfg.alpha_min:g}, {cfg.alpha_max:.4g}] per solver, "
             f"cell and error kind (lowest mean error); value = log(mean(dan/dqopt))",
             f"wall time {runtime:.1f} s with {workers} worker process(es), seed={cfg.seed}"]
    files = {"csv": common.write_csv(out / "figure3.csv", rows, CSV_COLUMNS)}
    md = markdown(maps, cfg, notes)
    (out / "figure3.md").write_text(md)
    files["md"] = out / "figure3.md"
    from simcalib.studies.experiments import plots
    files["png"] = plots.figure3(maps, cfg, out / "figure3.png")
    from simcalib.studies.experiments.recording import log_experiment
    files["rrd"] = log_experiment(out, "figure3", {"figure3": files["png"]}, {"figure3": md})
    return ExperimentResult("figure3", out, files, rows, runtime, tuple(notes), {"maps": maps})


def markdown(maps, cfg: Figure3Config, notes) -> str:
    lines = ["# Figure 3: log(mean(err_daniilidis / err_dqopt)) over noise\n\n",
             "Rows: rotation noise sigma_r (deg); columns: translation noise sigma_t (cm). "
             "Positive = DQOpt better by a factor e^value.\n"]
    cols = [f"σt={fmt(100 * t)}" for t in cfg.sigma_t_m]
    for s in cfg.scenarios:
        for mode in ("best", "alpha1"):
            for err in ("rotation", "translation"):
                m = maps[(s, mode, err)]
                lines.append(f"\n## {s}, {err} error, "
                             f"{'best alpha' if mode == 'best' else 'alpha = 1'}\n\n")
                lines.append(common.markdown_table(
                    ["σr (deg)"] + cols,
                    [[fmt(math.degrees(r))] + [f"{v:+.2f}" for v in m[i]]
                     for i, r in enumerate(cfg.sigma_r_rad)]))
    lines.append("\n" + "\n".join(f"- {n}" for n in notes) + "\n")
    return "".join(lines)
