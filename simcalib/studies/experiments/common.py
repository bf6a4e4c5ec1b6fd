"""Shared machinery of the paper experiments: key=value configs (through the one config
engine of :mod:`simcalib.config`, lists written ``[a,b]`` as for runs), the α grid, batched
α sweeps through :func:`simcalib.solve_batch`, error statistics and output files."""

from __future__ import annotations

import csv
import math
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simcalib.config.checks import check_int, check_names, check_positive, check_that
from simcalib.errors import unknown_choice
from simcalib.geometry import rotation_error_rad, translation_error_m

__all__ = [
    "ExperimentResult",
    "parse_overrides",
    "build_config",
    "alpha_grid",
    "solver_info",
    "sweep_errors",
    "SweepResult",
    "progress",
    "write_csv",
    "markdown_table",
    "fmt",
    "child_rngs",
    "is_slow",
    "uses_alpha",
    "run_tasks",
]

def is_slow(method: str) -> bool:
    """Methods solved by iterative nonlinear least squares (``SolverInfo.slow``), ~ms per
    problem: the experiments subsample these (``slow_samples`` / ``slow_alphas``)."""
    return solver_info(method).slow


@dataclass(frozen=True)
class ExperimentResult:
    """What an experiment wrote: its name, output directory, files (name -> path), the
    main table rows (list of dicts), wall time and free-form notes (e.g. subsampling)."""
    name: str
    output_dir: Path
    files: dict
    rows: list
    runtime_s: float
    notes: tuple = ()
    extra: dict = field(default_factory=dict)


# ------------------------------------------------------------------------ configuration
def parse_overrides(args: list[str]) -> dict[str, str]:
    """``["samples=100", "output=out"]`` -> ``{"samples": "100", "output": "out"}``
    (:func:`simcalib.config.engine.parse_overrides`: a key given twice is an error)."""
    from simcalib.config.engine import parse_overrides as _parse
    return _parse(args)


def build_config(cls, values: dict):
    """Instantiate the frozen config dataclass ``cls`` from override strings (parsed like a
    run's: YAML numbers and booleans, lists in brackets ``[a,b]``) or Python values,
    through the one config engine (:func:`simcalib.config.engine.build`): unknown keys are rejected
    naming the closest valid key and listing all of them."""
    from simcalib.config.engine import _parse_value, build, leaf_paths
    leaves = leaf_paths(cls)
    data = {}
    for key, value in values.items():
        key = str(key)
        if key in leaves and isinstance(value, str):
            value = _parse_value(value, leaves[key][0], key)
        data[key] = value
    return build(cls, data)


def check_positive_int(name: str, value, minimum: int = 1) -> int:
    """An integer >= ``minimum`` (:func:`simcalib.config.checks.check_int`)."""
    return check_int(name, value, lo=minimum)


def check_positive_float(name: str, value, allow_zero: bool = False) -> float:
    """A finite number > 0 (>= 0 with ``allow_zero``; :func:`simcalib.config.checks.check_positive`)."""
    return check_positive(name, value, allow_zero=allow_zero)


def check_methods(name: str, methods) -> None:
    """Registered solver names, none repeated."""
    from simcalib.solvers import registry
    valid = registry.available()
    for m in check_names(name, methods):
        if m not in valid:
            raise unknown_choice("method", m, valid, key=name)


def check_scenarios(name: str, scenarios) -> None:
    """Names of synthetic motions (``random``, ``line``, ``circle``)."""
    from simcalib.world.synthetic import MOTIONS
    for s in check_names(name, scenarios):
        if s not in MOTIONS:
            raise unknown_choice("scenario", s, MOTIONS, key=name)


def noise_grid_fields(cfg) -> dict:
    """Checked values of the fields the noise-grid experiments (figure3, figure6) share:
    ``samples``/``num_alphas``/``chunk`` >= 1, ``workers`` >= 0, ``n``/``num_motions`` >= 2,
    ``seed`` >= 0, and the non-negative ``sigma_r_rad``/``sigma_t_m`` grids (as tuples).
    Pass the result to :func:`simcalib.config.checks.set_fields`."""
    fields = {name: check_int(name, getattr(cfg, name), lo=1)
              for name in ("samples", "num_alphas", "chunk")}
    fields.update(workers=check_int("workers", cfg.workers, lo=0),
                  n=check_int("n", cfg.n, lo=2),
                  num_motions=check_int("num_motions", cfg.num_motions, lo=2),
                  seed=check_int("seed", cfg.seed, lo=0))
    for name in ("sigma_r_rad", "sigma_t_m"):
        fields[name] = tuple(check_positive(f"{name}[{i}]", v, allow_zero=True)
                             for i, v in enumerate(getattr(cfg, name)))
    return fields


def alpha_grid(num: int = 100, low: float = 1e-2, high: float = 10 ** 1.7) -> np.ndarray:
    """The paper's α grid: ``num`` log-spaced values in ``[low, high]`` (1/m)."""
    check_positive_int("num_alphas", num)
    check_positive_float("alpha_min", low)
    check_positive_float("alpha_max", high)
    check_that(high >= low, "alpha_max", high, f">= alpha_min ({low:g})")
    return np.logspace(math.log10(low), math.log10(high), num)


def child_rngs(seed: int, k: int) -> list[np.random.Generator]:
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(k)]


def solver_info(method: str):
    from simcalib.solvers import registry
    return registry.get(method)


def uses_alpha(method: str) -> bool:
    """Whether the method's estimate depends on alpha (``SolverInfo.depends_on_alpha``:
    dq2steps takes alpha but alpha^2 cancels, paper Table 2 caption)."""
    return solver_info(method).depends_on_alpha


def expected_cost_us(method: str) -> float:
    """Rough single-problem cost (µs, N = 100; ``SolverInfo.expected_cost_us``), used only
    to schedule the slowest tasks first."""
    return solver_info(method).expected_cost_us


# ----------------------------------------------------------------------------- sweeps
@dataclass(frozen=True)
class SweepResult:
    """Errors of one method over an α grid: ``rot_deg``, ``trans_cm`` and ``cost`` of shape
    ``(A, B)`` (α x sample), ``alphas`` (A,), ``uses_alpha``, solve wall time and count.
    A solve that reported failure (``success`` False: no estimate) counts as an infinite
    error and infinite cost; ``failed`` (A, B) marks them."""
    method: str
    alphas: np.ndarray
    rot_deg: np.ndarray
    trans_cm: np.ndarray
    cost: np.ndarray
    uses_alpha: bool
    solve_s: float
    solves: int
    failed: np.ndarray | None = None
    errors: dict = field(default_factory=dict)

    @property
    def failures(self) -> int:
        """Failed solves at the first α (all α for methods without α)."""
        return 0 if self.failed is None else int(self.failed[0].sum())


def sweep_errors(C: np.ndarray, H: np.ndarray, X_true: np.ndarray, method: str,
                 alphas, rng: np.random.Generator, *, chunk: int = 4096,
                 bar=None) -> SweepResult:
    """Solve every problem of ``C, H (B, n, 4, 4)`` at every α through ``solve_batch``.

    Methods that do not use α are solved once and their errors repeated over the grid.
    ``chunk`` bounds the problems per ``solve_batch`` call (memory): with many problems
    each call is one α over a slice of the problems (no copy); with few problems (B <
    chunk / 2) several α are packed into one call with a per-problem α array. ``bar`` is a
    tqdm bar advanced by the number of (problem, α) pairs done.
    """
    with_alpha = uses_alpha(method)
    alphas = np.atleast_1d(np.asarray(alphas, dtype=np.float64))
    B = C.shape[0]
    A = alphas.shape[0]
    run_alphas = alphas if with_alpha else alphas[:1]
    RA = run_alphas.shape[0]
    rot = np.empty((RA, B))
    trans = np.empty_like(rot)
    cost = np.empty_like(rot)
    failed = np.zeros(rot.shape, dtype=bool)
    out = (rot, trans, cost, failed, {})
    per_pair = 1 if with_alpha else A
    sweep = _sweep_by_alpha if B >= chunk // 2 or RA == 1 else _sweep_packed
    solve_s = sweep(C, H, X_true, method, run_alphas, rng, chunk, out,
                    (lambda n: bar.update(n * per_pair)) if bar is not None else None)
    errors = out[4]
    rot[failed] = np.inf
    trans[failed] = np.inf
    cost[failed] = np.inf
    if not with_alpha:
        rot = np.broadcast_to(rot, (A, B))
        trans = np.broadcast_to(trans, (A, B))
        cost = np.broadcast_to(cost, (A, B))
        failed = np.broadcast_to(failed, (A, B))
    return SweepResult(method, alphas, rot, trans, cost, with_alpha, solve_s, RA * B,
                       failed, errors)


def _sweep_by_alpha(C, H, X_true, method, run_alphas, rng, chunk, out, advance) -> float:
    """Many problems: each solve_batch call is one alpha over a slice of the problems (no
    copy). Fills ``out`` = (rot, trans, cost, failed, errors); returns the solve time."""
    from simcalib.solvers.api import solve_batch
    rot, trans, cost, failed, errors = out
    B, solve_s = C.shape[0], 0.0
    for ia, a in enumerate(run_alphas):
        for s in range(0, B, chunk):
            e = min(B, s + chunk)
            t0 = time.perf_counter()
            X, c, ok = _solve_guarded(solve_batch, C[s:e], H[s:e], method, float(a), rng,
                                      errors)
            solve_s += time.perf_counter() - t0
            rot[ia, s:e] = np.degrees(rotation_error_rad(X, X_true))
            trans[ia, s:e] = 100.0 * translation_error_m(X, X_true)
            cost[ia, s:e] = c
            failed[ia, s:e] = ~ok
            if advance is not None:
                advance(e - s)
    return solve_s


def _sweep_packed(C, H, X_true, method, run_alphas, rng, chunk, out, advance) -> float:
    """Few problems: several alphas packed into one solve_batch call with a per-problem
    alpha array. Fills ``out`` = (rot, trans, cost, failed, errors); returns the solve
    time."""
    from simcalib.solvers.api import solve_batch
    rot, trans, cost, failed, errors = out
    B, RA, solve_s = C.shape[0], run_alphas.shape[0], 0.0
    per_call = max(1, chunk // B)
    for s in range(0, RA, per_call):
        e = min(RA, s + per_call)
        ia = np.repeat(np.arange(s, e), B)
        ib = np.tile(np.arange(B), e - s)
        t0 = time.perf_counter()
        X, c, ok = _solve_guarded(solve_batch, C[ib], H[ib], method, run_alphas[ia], rng,
                                  errors)
        solve_s += time.perf_counter() - t0
        rot[s:e] = np.degrees(rotation_error_rad(X, X_true)).reshape(e - s, B)
        trans[s:e] = (100.0 * translation_error_m(X, X_true)).reshape(e - s, B)
        cost[s:e] = np.asarray(c).reshape(e - s, B)
        failed[s:e] = ~ok.reshape(e - s, B)
        if advance is not None:
            advance((e - s) * B)
    return solve_s


# What a solver may raise on a hard problem (besides reporting success=False): the API's
# rejection of an invalid estimate (ValueError), a numerical give-up (RuntimeError),
# LinAlgError / FloatingPointError.
SOLVER_ERRORS = (ValueError, RuntimeError, ArithmeticError, np.linalg.LinAlgError)


def solve_guarded(C, H, method, alpha, rng, errors: dict):
    """``solve_batch`` -> (X (B,4,4), cost (B,), ok (B,)). If the batch raises (a solver
    returned something the API rejects, e.g. a reflection, or gave up with an exception),
    the problems are re-solved one by one and those that raise are marked failed; ``errors``
    counts the messages, which the experiments report (never hidden)."""
    from simcalib.solvers.api import solve_batch
    return _solve_guarded(solve_batch, C, H, method, alpha, rng, errors)


def _solve_guarded(solve_batch, C, H, method, alpha, rng, errors: dict):
    try:
        sol = solve_batch(C, H, method=method, alpha=alpha, rng=rng)
        ok = np.asarray(sol.success, dtype=bool).copy()
        X = np.where(ok[:, None, None], sol.X, np.eye(4))
        return X, np.where(ok, np.asarray(sol.cost, dtype=np.float64), np.inf), ok
    except SOLVER_ERRORS:
        pass
    B = C.shape[0]
    X = np.broadcast_to(np.eye(4), (B, 4, 4)).copy()
    cost = np.full(B, np.inf)
    ok = np.zeros(B, dtype=bool)
    alpha = np.broadcast_to(np.asarray(alpha, dtype=np.float64), (B,))
    for b in range(B):
        try:
            sol = solve_batch(C[b:b + 1], H[b:b + 1], method=method, alpha=float(alpha[b]),
                              rng=rng)
        except SOLVER_ERRORS as exc:
            # numbers replaced so that one kind of error is counted once
            text = re.sub(r"[-+]?\d[\d.eE+-]*", "#", str(exc).split(";")[0])
            msg = f"{type(exc).__name__}: {text[:200]}"
            errors[msg] = errors.get(msg, 0) + 1
            continue
        ok[b] = bool(sol.success[0])
        if ok[b]:
            X[b] = sol.X[0]
            cost[b] = sol.cost[0]
    return X, cost, ok


def percentile(x: np.ndarray, q: float) -> float:
    """Percentile that tolerates infinite values (failed solves): no inf - inf = nan."""
    x = np.asarray(x, dtype=np.float64)
    big = np.finfo(np.float64).max
    v = float(np.percentile(np.where(np.isinf(x), big, x), q, method="linear"))
    return math.inf if v >= big / 2 else v


def median(x: np.ndarray) -> float:
    return percentile(x, 50.0)


# ---------------------------------------------------------------------------- outputs
def progress(total: int, desc: str, enabled: bool = True):
    """The run's progress bar (:func:`simcalib.progress.progress`) counting solves."""
    from simcalib.progress import progress as bar
    return bar(total=total, desc=desc, enabled=enabled, unit="solve", unit_scale=True)


def fmt(x, digits: int = 3) -> str:
    """Compact number for tables: 3 significant digits, scientific for tiny/huge values."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    x = float(x)
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == 0:
        return "0"
    ax = abs(x)
    if ax < 1e-3 or ax >= 1e5:
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}" if ax < 1000 else f"{x:.0f}"


def write_csv(path: Path, rows: list[dict], columns: list[str]) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({c: _csv_value(r.get(c)) for c in columns})
    return path


def _csv_value(v):
    if v is None:
        return ""
    if isinstance(v, (float, np.floating)):
        return "" if math.isnan(v) else repr(float(v))
    if isinstance(v, np.integer):
        return int(v)
    return v


def markdown_table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(str(c) for c in r) + " |")
    return "\n".join(lines) + "\n"


def output_dir(path) -> Path:
    p = Path(os.fspath(path))
    if p.exists() and not p.is_dir():
        raise ValueError(f"output must be a directory; {str(p)!r} is a file")
    from simcalib.config.files import output_folder
    output_folder(p)
    return p


# ---------------------------------------------------------------------- parallel tasks
def _worker_init() -> None:
    """Worker processes: one thread per library (the processes are the parallelism; BLAS:
    :func:`simcalib.parallel.one_blas_thread`, set by the pool). ``NUMBA_NUM_THREADS`` is
    read when numba loads, which is later (:mod:`simcalib.solvers.kernels.jit`)."""
    for var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS"):
        os.environ[var] = "1"
    try:
        import cv2
        cv2.setNumThreads(1)
        # OpenCV logs every failed calibrateHandEye on stderr; failures are counted and
        # reported by the experiments instead
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    except (ImportError, AttributeError):  # pragma: no cover - cv2 is a dependency
        pass


def check_workers(workers) -> int:
    """``workers`` >= 0; 0 means one per CPU (at most 8)."""
    check_positive_int("workers", workers, 0)
    return min(8, os.cpu_count() or 1) if workers == 0 else int(workers)


def run_tasks(fn, tasks: list, workers: int, bar=None, weights=None, priority=None) -> list:
    """``[fn(*t) for t in tasks]``, in ``workers`` spawned processes when ``workers > 1``
    (results in task order). ``fn`` must be a module-level function; ``bar`` is advanced by
    ``weights[i]`` when task i finishes; tasks with the highest ``priority`` (expected
    run time) start first."""
    weights = weights or [1] * len(tasks)
    priority = priority or weights
    if workers <= 1 or len(tasks) <= 1:
        out = []
        for t, w in zip(tasks, weights):
            out.append(fn(*t))
            if bar is not None:
                bar.update(w)
        return out
    from concurrent.futures import FIRST_COMPLETED, wait

    from simcalib.parallel import deferred_interrupt, worker_pool
    results = [None] * len(tasks)
    # longest first for balance
    order = sorted(range(len(tasks)), key=lambda i: -priority[i])
    # workers ignore Ctrl-C (no worker tracebacks); the parent raises it between tasks
    with deferred_interrupt() as intr, worker_pool(workers, _worker_init) as ex:
        futs = {ex.submit(fn, *tasks[i]): i for i in order}
        pending = set(futs)
        while pending:
            done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            for f in done:
                i = futs[f]
                results[i] = f.result()
                if bar is not None:
                    bar.update(weights[i])
            intr.check()
    return results
