"""Table 1: optimality (relative cost difference to DQOpt) and timing per method.

Upper table: for each method, over problems from the three synthetic scenarios (the paper
used 2450 real-data runs), the signed relative difference of the paper's cost (8),
``(alg - dqopt) / (alg + dqopt)``: mean, std, min, max. Each problem gets an α drawn
log-uniformly from the paper's grid, so the whole α range is covered. Positive means the
method's cost is higher than DQOpt's.

Lower table: time per solve (µs) through ``simcalib.solve`` (``Solution.runtime_s``: from
the ``(N, 4, 4)`` arrays to ``X``, validation included) — mean, std, min, max — plus the
amortised time per problem through ``solve_batch``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from simcalib.studies.experiments import common, experiment
from simcalib.studies.experiments.common import ExperimentResult, fmt

__all__ = ["Table1Config", "run", "COST_COLUMNS", "TIMING_COLUMNS"]

COST_COLUMNS = ["scenario", "algorithm", "problems", "failed", "mean", "std", "min", "max",
                "negative_below_minus_1e-12", "above_1e-6"]
TIMING_COLUMNS = ["algorithm", "runs", "mean_us", "std_us", "min_us", "max_us", "median_us",
                  "batch_us_per_problem"]
DEFAULT_COST_METHODS = ("dqnlopt", "dqnloptrnd", "dq2ndord", "dq2ndord_lambda", "dqconvrlx",
                        "dq2steps", "dqitr", "dqoptpoly")
DEFAULT_TIMING_METHODS = ("dqopt", "dq2ndord", "dq2ndord_lambda", "daniilidis", "dqconvrlx",
                          "dq2steps", "dqitr", "dqoptpoly", "opencv_daniilidis", "dqnlopt",
                          "dqnloptrnd")


@dataclass(frozen=True)
class Table1Config:
    """``samples``: problems per scenario for the cost table; ``slow_samples``: the same for
    ``slow_methods`` (nonlinear least squares, ~ms each); ``timing_runs`` /
    ``slow_timing_runs``: single solves timed per method; ``n``: motions per problem."""
    samples: int = 1000
    n: int = 100
    scenarios: tuple[str, ...] = ("random", "line", "circle")
    methods: tuple[str, ...] = DEFAULT_COST_METHODS
    timing_methods: tuple[str, ...] = DEFAULT_TIMING_METHODS
    slow_methods: tuple[str, ...] = ("dqnlopt", "dqnloptrnd", "dqoptpoly")
    slow_samples: int = 100
    timing_runs: int = 1000
    slow_timing_runs: int = 50
    alpha_min: float = 1e-2
    alpha_max: float = 10 ** 1.7
    num_motions: int = 1000
    sigma_r_rad: float = math.radians(0.57)
    sigma_t_m: float = 0.01
    seed: int = 0
    chunk: int = 4096
    progress: bool = True
    output: str = "results/table1"

    def __post_init__(self):
        from simcalib.config.checks import check_int, check_positive, check_that, set_fields
        set_fields(self,
                   **{name: check_int(name, getattr(self, name), lo=1)
                      for name in ("samples", "slow_samples", "timing_runs",
                                   "slow_timing_runs", "chunk")},
                   n=check_int("n", self.n, lo=2),
                   num_motions=check_int("num_motions", self.num_motions, lo=2),
                   seed=check_int("seed", self.seed, lo=0),
                   sigma_r_rad=check_positive("sigma_r_rad", self.sigma_r_rad, allow_zero=True),
                   sigma_t_m=check_positive("sigma_t_m", self.sigma_t_m, allow_zero=True))
        common.alpha_grid(2, self.alpha_min, self.alpha_max)
        common.check_scenarios("scenarios", self.scenarios)
        common.check_methods("methods", self.methods)
        common.check_methods("timing_methods", self.timing_methods)
        check_that("dqopt" not in self.methods, "methods", list(self.methods),
                   "a list without 'dqopt' (it is the reference)")
        check_that(self.n <= self.num_motions, "n", self.n,
                   f"<= num_motions ({self.num_motions})")


def relative_difference(cost_alg: np.ndarray, cost_ref: np.ndarray) -> np.ndarray:
    """``(alg - ref) / (alg + ref)`` (0 where both are 0)."""
    a = np.asarray(cost_alg, dtype=np.float64)
    r = np.asarray(cost_ref, dtype=np.float64)
    den = a + r
    return np.where(den > 0, (a - r) / np.where(den > 0, den, 1.0), 0.0)


def _stats(x: np.ndarray) -> dict:
    if x.size == 0:
        return {"mean": math.nan, "std": math.nan, "min": math.nan, "max": math.nan}
    return {"mean": float(np.mean(x)), "std": float(np.std(x)), "min": float(np.min(x)),
            "max": float(np.max(x))}


@experiment('table1', config=Table1Config,
            description="the paper's Table 1: optimality and timing per method")
def run(cfg: Table1Config) -> ExperimentResult:
    t_start = time.perf_counter()
    out = common.output_dir(cfg.output)
    rngs = common.child_rngs(cfg.seed, len(cfg.scenarios) + 1)
    problems = _problems(cfg, rngs[:-1])
    rows, rel, notes = _cost_rows(cfg, problems)
    timing_rows = _timing_rows(cfg, problems, rngs[-1])
    runtime = time.perf_counter() - t_start
    notes = notes + [f"data: synthetic {', '.join(cfg.scenarios)} ({cfg.samples} problems each of "
             f"n = {cfg.n}; slow methods {', '.join(cfg.slow_methods)} on the first "
             f"{min(cfg.samples, cfg.slow_samples)}), alpha log-uniform in "
             f"[{cfg.alpha_min:g}, {cfg.alpha_max:.4g}] per problem",
             "timing: Solution.runtime_s of simcalib.solve (arrays -> X incl. validation), "
             "one process on this machine; batch = solve_batch wall time / problems",
             f"wall time {runtime:.1f} s, seed={cfg.seed}"]
    files = {"csv": common.write_csv(out / "table1.csv", rows, COST_COLUMNS),
             "timing_csv": common.write_csv(out / "table1_timing.csv", timing_rows,
                                            TIMING_COLUMNS)}
    md = markdown(rows, timing_rows, notes)
    (out / "table1.md").write_text(md)
    files["md"] = out / "table1.md"
    from simcalib.studies.experiments import plots
    files["png"] = plots.table1_figure(rel, timing_rows, out / "table1.png")
    from simcalib.studies.experiments.recording import log_experiment
    files["rrd"] = log_experiment(out, "table1", {"table1": files["png"]}, {"table1": md})
    return ExperimentResult("table1", out, files, rows, runtime, tuple(notes),
                            {"timing": timing_rows})


def _problems(cfg: Table1Config, rngs) -> dict:
    """scenario -> ``(C, H, alphas, solver_rng)``: the sampled problems of each scenario
    and their log-uniform alphas."""
    from simcalib.world.synthetic import SyntheticConfig, generate_dataset, sample_problems
    lo, hi = math.log10(cfg.alpha_min), math.log10(cfg.alpha_max)
    problems = {}
    for scenario, rng in zip(cfg.scenarios, rngs):
        data_rng, sample_rng, alpha_rng, solver_rng = rng.spawn(4)
        ds = generate_dataset(SyntheticConfig(motion=scenario, num_motions=cfg.num_motions,
                                              sigma_r_rad=cfg.sigma_r_rad,
                                              sigma_t_m=cfg.sigma_t_m), data_rng)
        C, H, _ = sample_problems(ds, cfg.samples, cfg.n, sample_rng)
        alphas = 10.0 ** alpha_rng.uniform(lo, hi, cfg.samples)
        problems[scenario] = (C, H, alphas, solver_rng)
    return problems


def _cost_row(scenario, method, problems, failed, d) -> dict:
    return {"scenario": scenario, "algorithm": method, "problems": problems, "failed": failed,
            **_stats(d), "negative_below_minus_1e-12": int(np.sum(d < -1e-12)),
            "above_1e-6": int(np.sum(d > 1e-6))}


def _cost_rows(cfg: Table1Config, problems: dict):
    """``(rows, rel, notes)``: each method's cost relative to dqopt's on the same problems,
    per scenario and over all; ``rel`` method -> the relative differences per scenario."""
    def count(m):
        return min(cfg.samples, cfg.slow_samples) if m in cfg.slow_methods else cfg.samples
    total = len(cfg.scenarios) * (cfg.samples + sum(count(m) for m in cfg.methods))
    rel = {m: [] for m in cfg.methods}
    fails = {m: 0 for m in cfg.methods}
    rows, notes = [], []
    with common.progress(total, "table1 cost", cfg.progress) as bar:
        for scenario, (C, H, alphas, solver_rng) in problems.items():
            ref, ref_ok = _batched_cost(C, H, "dqopt", alphas, solver_rng, cfg.chunk, bar,
                                        notes, scenario)
            for m in cfg.methods:
                k = count(m)
                c, ok = _batched_cost(C[:k], H[:k], m, alphas[:k], solver_rng, cfg.chunk, bar,
                                      notes, scenario)
                both = ok & ref_ok[:k]
                d = relative_difference(c[both], ref[:k][both])
                rel[m].append(d)
                fails[m] += int(np.sum(~ok))
                rows.append(_cost_row(scenario, m, k, int(np.sum(~ok)), d))
    for m in cfg.methods:
        rows.append(_cost_row("all", m, sum(r["problems"] for r in rows if r["algorithm"] == m),
                              fails[m], np.concatenate(rel[m])))
    return rows, rel, notes


def _timing_rows(cfg: Table1Config, problems: dict, t_rng) -> list[dict]:
    """Single solves (``Solution.runtime_s``) and batch throughput per timed method, on
    problems drawn from every scenario; slowest first."""
    C_all = np.concatenate([p[0] for p in problems.values()])
    H_all = np.concatenate([p[1] for p in problems.values()])
    a_all = np.concatenate([p[2] for p in problems.values()])
    order = t_rng.permutation(C_all.shape[0])
    runs_of = {m: min(C_all.shape[0], cfg.slow_timing_runs if m in cfg.slow_methods
                      or common.is_slow(m) else cfg.timing_runs)
               for m in cfg.timing_methods}
    timing_rows = []
    with common.progress(2 * sum(runs_of.values()), "table1 timing", cfg.progress) as bar:
        for m in cfg.timing_methods:
            idx = order[:runs_of[m]]
            timing_rows.append(_time_method(m, C_all[idx], H_all[idx], a_all[idx], t_rng, bar))
    timing_rows.sort(key=lambda r: -r["mean_us"])
    return timing_rows


def _time_method(m: str, C, H, alphas, t_rng, bar) -> dict:
    """One method's timing row: a warm-up solve (imports, compiled kernels), each problem
    solved alone (its runtime_s, or the time to give up), then all of them as a batch."""
    from simcalib.solvers.api import solve
    runs = C.shape[0]
    try:
        solve(C[0], H[0], method=m, alpha=float(alphas[0]), rng=np.random.default_rng(0))
    except common.SOLVER_ERRORS:
        pass
    us = []
    for i in range(runs):
        t0 = time.perf_counter()
        try:
            sol = solve(C[i], H[i], method=m, alpha=float(alphas[i]), rng=t_rng)
            us.append(1e6 * sol.runtime_s)
        except common.SOLVER_ERRORS:
            us.append(1e6 * (time.perf_counter() - t0))   # time to give up
        bar.update(1)
    us = np.asarray(us)
    t0 = time.perf_counter()
    common.solve_guarded(C, H, m, alphas, t_rng, {})
    batch_us = 1e6 * (time.perf_counter() - t0) / runs
    bar.update(runs)
    return {"algorithm": m, "runs": runs, "mean_us": float(us.mean()),
            "std_us": float(us.std()), "min_us": float(us.min()), "max_us": float(us.max()),
            "median_us": float(np.median(us)), "batch_us_per_problem": batch_us}


def _batched_cost(C, H, method, alphas, rng, chunk, bar, notes, scenario):
    """Costs (B,) and success flags (B,) of ``method``; failures are noted."""
    out = np.empty(C.shape[0])
    ok = np.empty(C.shape[0], dtype=bool)
    errors: dict = {}
    for s in range(0, C.shape[0], chunk):
        e = min(C.shape[0], s + chunk)
        _, out[s:e], ok[s:e] = common.solve_guarded(C[s:e], H[s:e], method, alphas[s:e], rng,
                                                    errors)
        bar.update(e - s)
    for msg, cnt in errors.items():
        notes.append(f"{method} on {scenario}: {cnt} of {C.shape[0]} solves raised "
                     f"(excluded): {msg}")
    other = int(np.sum(~ok)) - sum(errors.values())
    if other:
        notes.append(f"{method} on {scenario}: {other} of {C.shape[0]} solves reported "
                     "failure (excluded)")
    return out, ok


def markdown(rows, timing_rows, notes) -> str:
    from simcalib.studies.experiments.paper import TABLE1_COST, TABLE1_TIMING_US
    lines = ["# Table 1: optimality and timing\n",
             "\n## Relative cost difference (alg - dqopt) / (alg + dqopt), all scenarios\n\n"]
    body = []
    for r in rows:
        if r["scenario"] != "all":
            continue
        p = TABLE1_COST.get(r["algorithm"])
        body.append([r["algorithm"], r["problems"], r["failed"], r["above_1e-6"],
                     fmt(r["mean"], 2), fmt(r["std"], 2),
                     fmt(r["min"], 2), fmt(r["max"], 2),
                     "-" if p is None else " / ".join(fmt(v, 2) for v in p)])
    lines.append(common.markdown_table(
        ["alg", "problems", "failed", "> 1e-6", "mean", "std", "min", "max",
         "paper mean / std / min / max"], body))
    lines.append("\n## Per scenario (mean / max)\n\n")
    scen = sorted({r["scenario"] for r in rows if r["scenario"] != "all"})
    algs = list(dict.fromkeys(r["algorithm"] for r in rows))
    idx = {(r["scenario"], r["algorithm"]): r for r in rows}
    lines.append(common.markdown_table(
        ["alg"] + scen,
        [[a] + [f"{fmt(idx[(s, a)]['mean'], 2)} / {fmt(idx[(s, a)]['max'], 2)}"
                if (s, a) in idx else "-" for s in scen] for a in algs]))
    lines.append("\n## Timing in µs per solve (N = 100 motions)\n\n")
    tb = []
    for t in timing_rows:
        p = TABLE1_TIMING_US.get(t["algorithm"])
        tb.append([t["algorithm"], t["runs"], f"{t['mean_us']:.0f}", f"{t['std_us']:.0f}",
                   f"{t['min_us']:.0f}", f"{t['max_us']:.0f}", f"{t['median_us']:.0f}",
                   f"{t['batch_us_per_problem']:.1f}",
                   "-" if p is None else " / ".join(str(v) for v in p)])
    lines.append(common.markdown_table(
        ["alg", "runs", "mean", "std", "min", "max", "median", "batch µs/problem",
         "paper mean / std / min / max"], tb))
    lines.append("\n" + "\n".join(f"- {n}" for n in notes) + "\n")
    return "".join(lines)
