"""Solver benchmark: a Table-1-like timing table and the solve_batch throughput.

Run ``python -m simcalib bench`` (or ``python -m simcalib.studies.bench.solvers``); ``--help`` lists the
options. Every method solves the same noisy random problems (paper appendix D.2 style:
uniform random relative motions, eq. 38 noise); the time per solve is
``Solution.runtime_s`` — from the ``(N, 4, 4)`` arrays to ``X`` (validation, conversion,
solver), the quantity of the paper's Table 1 — and the wall time of the whole
``simcalib.solve`` call is shown as well.

``--hot-path`` compares the wall time of a whole ``simcalib.solve`` call (N = 100) with
:func:`reference_solve` and measures the ``solve_batch`` throughput (the two README rows).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

__all__ = ["main", "make_problems", "time_methods", "batch_throughput", "repeated_throughput",
           "throughput_overhead", "startup_times", "markdown_tables", "reference_solve",
           "hot_path"]


def make_problems(rng: np.random.Generator, count: int, n: int, sigma_r: float,
                  sigma_t: float):
    """``count`` noisy random problems ``(C, H)`` of ``n`` motions each, and the true X."""
    from simcalib import geometry as g
    C = g.transform_from_rotation_translation(g.random_rotation_matrices(rng, (count, n)),
                                              rng.normal(size=(count, n, 3)))
    X = g.transform_from_rotation_translation(g.random_rotation_matrices(rng, count),
                                              rng.normal(scale=0.3, size=(count, 3)))
    H = g.invert_transform(X)[:, None] @ C @ X[:, None]
    if sigma_r > 0 or sigma_t > 0:
        H = g.perturb_transforms(H, sigma_r, sigma_t, rng)
    return C, H, X


def time_methods(methods, C, H, alpha: float, max_seconds: float, seed: int):
    """Per method: runtime_s and wall time (s) of each solve, and the mean cost."""
    from simcalib.solvers.api import solve
    rows = {}
    from simcalib.solvers import get
    for m in methods:
        stochastic = get(m).stochastic
        solve(C[0], H[0], method=m, alpha=alpha, rng=np.random.default_rng(seed))
        rt, wall, cost, fails = [], [], [], 0
        start = time.perf_counter()
        for b in range(C.shape[0]):
            rng = np.random.default_rng(seed + b) if stochastic else None
            t0 = time.perf_counter()
            sol = solve(C[b], H[b], method=m, alpha=alpha, rng=rng)
            wall.append(time.perf_counter() - t0)
            rt.append(sol.runtime_s)
            cost.append(sol.cost)
            fails += not sol.success
            if time.perf_counter() - start > max_seconds and b >= 4:
                break
        rows[m] = {"runtime_s": np.array(rt), "wall_s": np.array(wall),
                   "cost": np.array(cost), "failures": fails}
    return rows


def batch_throughput(methods, n: int, batch_size: int, alpha: float, sigma_r: float,
                     sigma_t: float, seed: int, repeats: int = 3):
    """problems/s of ``solve_batch`` per method (best of ``repeats``)."""
    from simcalib.solvers.api import solve_batch
    C, H, _ = make_problems(np.random.default_rng(seed + 1), batch_size, n, sigma_r, sigma_t)
    alphas = np.full(batch_size, alpha)
    out = {}
    for m in methods:
        solve_batch(C[:4], H[:4], method=m, alpha=alphas[:4])
        best = np.inf
        best_cpu = np.inf
        for _ in range(repeats):
            c0 = time.process_time()
            t0 = time.perf_counter()
            solve_batch(C, H, method=m, alpha=alphas)
            best = min(best, time.perf_counter() - t0)
            best_cpu = min(best_cpu, time.process_time() - c0)
        out[m] = {"problems_per_s": batch_size / best,
                  "cpu_us_per_problem": best_cpu / batch_size * 1e6}
    return out


def repeated_throughput(method: str, n: int, batch_size: int, repeats: int, alpha: float,
                        sigma_r: float, sigma_t: float, seed: int,
                        cpu_s: list | None = None) -> np.ndarray:
    """problems/s of ``repeats`` consecutive ``solve_batch`` calls (B = batch_size); the
    process CPU seconds of each call are appended to ``cpu_s`` when given."""
    from simcalib.solvers.api import solve_batch
    C, H, _ = make_problems(np.random.default_rng(seed + 2), batch_size, n, sigma_r, sigma_t)
    solve_batch(C[:4], H[:4], method=method, alpha=alpha)   # compile / load
    rates = []
    for _ in range(repeats):
        c0 = time.process_time()
        t0 = time.perf_counter()
        solve_batch(C, H, method=method, alpha=alpha)
        rates.append(batch_size / (time.perf_counter() - t0))
        if cpu_s is not None:
            cpu_s.append(time.process_time() - c0)
    return np.array(rates)


def throughput_overhead(t: dict) -> dict:
    """From a ``--throughput`` result: the CPU per problem (process, all threads; µs) and
    per call the wall time beyond CPU / threads (ms): what the call spends outside the
    kernels' per-problem work (thread start, chunk dispatch, input checks, output) plus
    the time its threads waited for cores that other processes held."""
    wall = t["batch_size"] / np.asarray(t["problems_per_s"], dtype=float)
    cpu = np.asarray(t["cpu_s"], dtype=float)
    return {"cpu_us_per_problem": cpu / t["batch_size"] * 1e6,
            "overhead_ms": (wall - cpu / t["threads"]) * 1e3}


def reference_solve(C, H, alpha: float = 1.0) -> np.ndarray:
    """The reference single solve: the paper-equivalent minimal dqopt pipeline, written
    plainly — ``(N, 4, 4)`` arrays -> dual quaternions (numpy, eq. 2) with the paper's
    scalar-part sign rule -> the compiled dqopt kernel on those motions -> X. No input
    checks, no re-alignment near 180 deg, no cost, no diagnostics. (Neither the code, its
    history nor docs/solvers.md defined a reference solve; this is the one ``--hot-path``
    measures ``simcalib.solve`` against.)"""
    from simcalib.geometry import dual_quat_from_transform
    from simcalib.solvers.kernels.batch import run_batch
    from simcalib.solvers.kernels.dqcore import DQOPT
    q_C, q_C_dual = dual_quat_from_transform(C)
    q_H, q_H_dual = dual_quat_from_transform(H)
    sign = np.where(q_C[:, 3] * q_H[:, 3] < 0.0, -1.0, 1.0)[:, None]
    Q = np.concatenate([q_C.T, (q_H * sign).T, q_C_dual.T, (q_H_dual * sign).T])
    return run_batch(DQOPT, np.array([float(alpha)]), Q=Q[None], align=False)["X"][0]


def hot_path(n: int, problems: int, repeats: int, alpha: float, sigma_r: float,
             sigma_t: float, seed: int, batch_size: int) -> dict:
    """Wall time of whole ``simcalib.solve(C, H, method="dqopt", alpha=alpha)`` calls against
    :func:`reference_solve` on the same ``problems`` problems of ``n`` motions, and
    ``repeats`` ``solve_batch`` calls of ``batch_size`` problems (problems/s).

    Each round times every problem with both, in alternating order, back to back (a shared
    machine's speed drifts less within a pair); per round: the median of each and their
    ratio. Returns the per-round lists (seconds; ratio solve / reference), the median
    ``runtime_s``, how many X agree with the reference's to 1e-9 (the reference has no
    re-alignment near 180 deg), and the batch rates."""
    from simcalib.solvers.api import solve
    C, H, _ = make_problems(np.random.default_rng(seed), problems, n, sigma_r, sigma_t)
    solve(C[0], H[0], method="dqopt", alpha=alpha)   # compile / load
    reference_solve(C[0], H[0], alpha)
    solve_s, ref_s, ratio, runtime = [], [], [], []
    for r in range(repeats):
        ws, wr = np.empty(problems), np.empty(problems)
        for b in range(problems):
            for first in ((0, 1) if (b + r) % 2 == 0 else (1, 0)):
                t0 = time.perf_counter()
                if first == 0:
                    sol = solve(C[b], H[b], method="dqopt", alpha=alpha)
                    ws[b] = time.perf_counter() - t0
                else:
                    reference_solve(C[b], H[b], alpha)
                    wr[b] = time.perf_counter() - t0
            runtime.append(sol.runtime_s)
        solve_s.append(float(np.median(ws)))
        ref_s.append(float(np.median(wr)))
        ratio.append(solve_s[-1] / ref_s[-1])
    agree = sum(bool(np.abs(solve(C[b], H[b], alpha=alpha).X
                            - reference_solve(C[b], H[b], alpha)).max() <= 1e-9)
                for b in range(problems))
    rates = repeated_throughput("dqopt", n, batch_size, repeats, alpha, sigma_r, sigma_t, seed)
    return {"n_motions": n, "problems": problems, "repeats": repeats, "alpha": alpha,
            "solve_wall_s": solve_s, "reference_wall_s": ref_s, "ratio": ratio,
            "runtime_s_median": float(np.median(runtime)), "x_agree": agree,
            "batch_size": batch_size, "batch_problems_per_s": rates.tolist()}


def _spread(values, fmt: str, scale: float = 1.0) -> str:
    v = np.asarray(values, dtype=float) * scale
    return (f"median {format(float(np.median(v)), fmt)} (min {format(float(v.min()), fmt)}, "
            f"max {format(float(v.max()), fmt)})")


def hot_path_lines(h: dict) -> list[str]:
    """The ``--hot-path`` numbers as text."""
    return [f"simcalib.solve, dqopt, N = {h['n_motions']}, {h['problems']} problems x "
            f"{h['repeats']} rounds (per round: median wall of the whole call):",
            f"  solve() wall       {_spread(h['solve_wall_s'], '.1f', 1e6)} us",
            f"  reference wall     {_spread(h['reference_wall_s'], '.1f', 1e6)} us  "
            "(bench.reference_solve: numpy dual quaternions + the dqopt kernel, no checks)",
            f"  ratio              {_spread(h['ratio'], '.3f')} x the reference  "
            "(target <= 0.5)",
            f"  runtime_s          median {h['runtime_s_median'] * 1e6:.1f} us  (arrays to X, "
            f"inside solve); X agrees with the reference's on {h['x_agree']} of "
            f"{h['problems']} (the rest: re-aligned near 180 deg)",
            f"solve_batch, dqopt, B = {h['batch_size']}, N = {h['n_motions']}, "
            f"{len(h['batch_problems_per_s'])} calls:",
            f"  problems/s         {_spread(h['batch_problems_per_s'], ',.0f')}  "
            "(target >= 100,000)"]


def _batch_threads() -> int:
    """The threads a batch runs on (numba's thread count, at most the CPU count)."""
    from simcalib.solvers.kernels.batch import _threads
    return max(1, min(_threads(), os.cpu_count() or 1))


def _load_note() -> str:
    try:
        load = os.getloadavg()
    except OSError:  # pragma: no cover
        return ""
    return (f"load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} on "
            f"{os.cpu_count()} CPUs")


_STARTUP_CODE = """
import resource, time
t0 = time.perf_counter()
import numpy as np, simcalib
from simcalib import geometry as g
rng = np.random.default_rng(0)
C = g.transform_from_rotation_translation(g.random_rotation_matrices(rng, 30), rng.normal(size=(30, 3)))
H = C.copy()
t1 = time.perf_counter()
sol = simcalib.solve(C, H, method="dqopt")
t2 = time.perf_counter()
sol.message
t3 = time.perf_counter()
{batch}
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, sol.runtime_s, sol.diagnostics["compile_s"], t3 - t2, t4 - t3,
      resource.getrusage(resource.RUSAGE_SELF).ru_utime)
"""


def startup_times(batch: bool = True) -> dict:
    """Start-up cost measured in fresh interpreters: ``cold`` with an empty numba cache
    (first use after installation), then ``warm`` (cache filled). Seconds: import,
    first ``solve`` (wall), its ``runtime_s``, its ``compile_s``, certificate/observability
    (``message``), first ``solve_batch`` (the same kernel on threads: nothing more to compile), process CPU."""
    import subprocess
    import tempfile
    code = _STARTUP_CODE.format(batch="simcalib.solve_batch(C[None].repeat(2, 0), "
                                      "H[None].repeat(2, 0))" if batch else "")
    keys = ("import_s", "first_solve_s", "runtime_s", "compile_s", "diagnostics_s",
            "first_batch_s", "cpu_s")
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold", "warm"):
            t0 = time.perf_counter()
            res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                                 text=True, check=True)
            vals = [float(v) for v in res.stdout.split()]
            out[label] = dict(zip(keys, vals), process_wall_s=time.perf_counter() - t0)
    return out


def markdown_tables(result: dict) -> str:
    """The numbers of a bench run as markdown tables (for docs/solvers.md)."""
    lines = []
    if "table" in result:
        lines += [f"Time per solve (µs, `Solution.runtime_s`, N = {result['n_motions']}, "
                  f"alpha = {result['alpha']:g}):", "",
                  "| method | runs | mean | std | min | median | max | failed |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|"]
        for m, r in result["table"].items():
            lines.append(f"| {m} | {r['count']} | {r['mean_us']:.1f} | {r['std_us']:.1f} | "
                         f"{r['min_us']:.1f} | {r['median_us']:.1f} | {r['max_us']:.1f} | "
                         f"{r['failures']} |")
        lines.append("")
    if "batch_problems_per_s" in result:
        lines += ["`solve_batch` throughput (best of 3):", "",
                  "| method | problems/s (wall) | CPU µs / problem |", "|---|---:|---:|"]
        for m, v in result["batch_problems_per_s"].items():
            lines.append(f"| {m} | {v['problems_per_s']:,.0f} | {v['cpu_us_per_problem']:.2f} |")
        lines.append("")
    if "throughput" in result:
        t = result["throughput"]
        r = np.array(t["problems_per_s"])
        lines += [f"`solve_batch(method={t['method']!r})` at B = {t['batch_size']}, "
                  f"N = {t['n_motions']}, {len(r)} consecutive calls: problems/s",
                  "", "| min | median | max |", "|---:|---:|---:|",
                  f"| {r.min():,.0f} | {np.median(r):,.0f} | {r.max():,.0f} |", ""]
        if "cpu_s" in t:
            o = throughput_overhead(t)
            lines += [f"CPU per problem (process, {t['threads']} threads): median "
                      f"{np.median(o['cpu_us_per_problem']):.2f} µs; wall beyond CPU / "
                      f"threads per call: median {np.median(o['overhead_ms']):.2f} ms (min "
                      f"{o['overhead_ms'].min():.2f}): thread start, chunk dispatch, checks, "
                      "output, and waits for cores other processes hold", ""]
    if "hot_path" in result:
        h = result["hot_path"]
        lines += [f"Hot path (N = {h['n_motions']}, {h['problems']} problems x {h['repeats']} "
                  f"rounds; {h.get('load', '')}):", "",
                  "| what | median | min | max |", "|---|---:|---:|---:|"]
        for label, key, fmt, scale in (("`solve` wall (µs)", "solve_wall_s", ".1f", 1e6),
                                       ("reference wall (µs)", "reference_wall_s", ".1f", 1e6),
                                       ("ratio solve / reference", "ratio", ".3f", 1.0),
                                       (f"`solve_batch` B = {h['batch_size']} (problems/s)",
                                        "batch_problems_per_s", ",.0f", 1.0)):
            v = np.asarray(h[key], dtype=float) * scale
            lines.append(f"| {label} | {format(float(np.median(v)), fmt)} | "
                         f"{format(float(v.min()), fmt)} | {format(float(v.max()), fmt)} |")
        lines.append("")
    if "startup" in result:
        lines += ["Start-up (fresh interpreters; cold = empty numba cache, i.e. first use "
                  "after installation; seconds):", "",
                  "| | import | first solve (wall) | its runtime_s | its compile_s | "
                  "certificate + observability | first solve_batch | process CPU | "
                  "process wall |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for label, v in result["startup"].items():
            lines.append(f"| {label} | {v['import_s']:.2f} | {v['first_solve_s']:.2f} | "
                         f"{v['runtime_s']:.5f} | {v['compile_s']:.2f} | "
                         f"{v['diagnostics_s']:.2f} | {v['first_batch_s']:.2f} | "
                         f"{v['cpu_s']:.1f} | {v['process_wall_s']:.1f} |")
        lines.append("")
    return "\n".join(lines)


def _fmt_table(rows, ref: str | None) -> str:
    ref_mean = rows[ref]["runtime_s"].mean() if ref in rows else None
    head = (f"{'method':<18}{'n':>5}{'mean us':>10}{'std':>9}{'min':>9}{'max':>10}"
            f"{'median':>9}{'solve() med':>13}{'x ' + (ref or 'ref'):>22}{'rel. cost':>12}")
    lines = [head, "-" * len(head)]
    best_cost = None
    if "dqopt" in rows:
        best_cost = rows["dqopt"]["cost"]
    for m, r in rows.items():
        us = r["runtime_s"] * 1e6
        ratio = f"{us.mean() / (ref_mean * 1e6):.3g}" if ref_mean else "-"   # 0.00123, not 0.00
        if best_cost is not None and len(best_cost) >= len(r["cost"]):
            c = r["cost"]
            rel = np.mean((c - best_cost[:len(c)]) / (c + best_cost[:len(c)]))
            relc = f"{rel:.1e}"
        else:
            relc = "-"
        fail = f"  ({r['failures']} failed)" if r["failures"] else ""
        lines.append(f"{m:<18}{len(us):>5}{us.mean():>10.1f}{us.std():>9.1f}{us.min():>9.1f}"
                     f"{us.max():>10.1f}{np.median(us):>9.1f}"
                     f"{np.median(r['wall_s']) * 1e6:>13.1f}{ratio:>22}{relc:>12}{fail}")
    return "\n".join(lines)


def main(argv=None) -> int:
    """``simcalib bench``: timing table per method + solve_batch throughput."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.n_motions < 2:
        parser.error(f"--n-motions must be >= 2; received {args.n_motions}")
    if args.problems < 1:
        parser.error(f"--problems must be >= 1; received {args.problems}")
    if not (np.isfinite(args.alpha) and args.alpha > 0):
        parser.error(f"--alpha must be finite and > 0; received {args.alpha}")
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1; received {args.repeats}")
    if args.hot_path:
        if args.throughput_batch < 1:
            parser.error(f"--throughput-batch must be >= 1; received {args.throughput_batch}")
        result = _hot_path_result(args)
    elif args.startup or args.throughput:
        result = _startup_throughput_result(args)
    else:
        result = _table_result(args, parser)
    _write_outputs(result, args)
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="simcalib bench",
        description="Time every registered solver on the same noisy random problems "
                    "(Table-1-like: mean/std/min/max microseconds per solve, from the "
                    "(N,4,4) arrays to X) and measure solve_batch throughput.")
    add = parser.add_argument
    add("--n-motions", type=int, default=100, help="motions per problem (100)")
    add("--problems", type=int, default=300,
        help="problems timed per method (300; slow methods stop early)")
    add("--max-seconds", type=float, default=4.0,
        help="time budget per method for the table (4 s)")
    add("--methods", default="all", help="comma-separated method names, or 'all' (default)")
    add("--alpha", type=float, default=1.0, help="weighting factor (1/m)")
    add("--sigma-r-deg", type=float, default=0.57, help="rotation noise (deg, paper D.2: 0.57)")
    add("--sigma-t", type=float, default=0.01, help="translation noise (m)")
    add("--batch-size", type=int, default=20000,
        help="problems per solve_batch call for the throughput (20000; 0 = skip)")
    add("--seed", type=int, default=0)
    add("--json", default=None, help="also write the numbers to this file")
    add("--markdown", default=None, metavar="FILE",
        help="also write the numbers as markdown tables ('-' = stdout); docs/solvers.md's "
             "tables come from this")
    add("--throughput", action="store_true",
        help="only measure solve_batch throughput of --throughput-method at "
             "B = --throughput-batch, N = --n-motions, --repeats times")
    add("--throughput-method", default="dqopt")
    add("--throughput-batch", type=int, default=1000)
    add("--repeats", type=int, default=10)
    add("--hot-path", action="store_true",
        help="only compare the wall time of whole simcalib.solve calls (dqopt, "
             "N = --n-motions) with the reference single solve (bench.reference_solve) "
             "over --repeats rounds of --problems problems, and measure solve_batch "
             "throughput at B = --throughput-batch (--repeats calls): the README rows")
    add("--startup", action="store_true",
        help="only measure start-up (compile) cost in fresh interpreters, cold (empty "
             "numba cache) and warm")
    return parser


def _hot_path_result(args) -> dict:
    """``--hot-path``: the README rows, printed with the load before and after."""
    load_before = _load_note()
    h = hot_path(args.n_motions, args.problems, args.repeats, args.alpha,
                 np.radians(args.sigma_r_deg), args.sigma_t, args.seed, args.throughput_batch)
    h["load"] = f"{load_before} before, {_load_note().split(' on ')[0]} after"
    if args.markdown != "-":
        print("\n".join(hot_path_lines(h)))
        print(f"({h['load']})")
    return {"hot_path": h}


def _startup_throughput_result(args) -> dict:
    """``--startup`` and / or ``--throughput``, printed as markdown tables."""
    from simcalib.solvers import get
    result = {}
    if args.startup:
        result["startup"] = startup_times()
    if args.throughput:
        get(args.throughput_method)
        cpu = []
        rates = repeated_throughput(args.throughput_method, args.n_motions,
                                    args.throughput_batch, args.repeats, args.alpha,
                                    np.radians(args.sigma_r_deg), args.sigma_t, args.seed,
                                    cpu_s=cpu)
        result["throughput"] = {"method": args.throughput_method,
                                "batch_size": args.throughput_batch,
                                "n_motions": args.n_motions, "problems_per_s": rates.tolist(),
                                "cpu_s": cpu, "threads": _batch_threads()}
    if args.markdown != "-":   # with --markdown - the tables are printed once, below
        print(markdown_tables(result))
    return result


def _table_result(args, parser) -> dict:
    """The timing table of every chosen method, then the batch throughput of those with a
    batch kernel."""
    from simcalib.solvers import available
    names = available()
    methods = names if args.methods == "all" else [
        m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in names]
    if unknown:
        parser.error(f"unknown method(s) {', '.join(unknown)}; available: {', '.join(names)}")
    sigma_r = np.radians(args.sigma_r_deg)
    C, H, _ = make_problems(np.random.default_rng(args.seed), args.problems, args.n_motions,
                            sigma_r, args.sigma_t)
    try:
        import numba
        threads = numba.get_num_threads()
    except ImportError:  # pragma: no cover
        threads = 1
    print(f"simcalib bench: N = {args.n_motions} motions, {args.problems} problems, "
          f"alpha = {args.alpha:g}, noise {args.sigma_r_deg:g} deg / {args.sigma_t:g} m, "
          f"{os.cpu_count()} CPUs, {threads} numba threads")
    rows = time_methods(methods, C, H, args.alpha, args.max_seconds, args.seed)
    ref = "opencv_daniilidis" if "opencv_daniilidis" in rows else None
    print()
    print(_fmt_table(rows, ref))
    print("\n(us = microseconds per solve from the (N,4,4) arrays to X; 'solve() med' = wall "
          "time of the full simcalib.solve call; 'rel. cost' = mean (cost - dqopt)/(cost + dqopt))")
    result = {"n_motions": args.n_motions, "alpha": args.alpha,
              "table": {m: _table_row(r) for m, r in rows.items()}}
    if args.batch_size > 0:
        tp = _batch_rows(methods, args, sigma_r, threads)
        if tp:
            result["batch_problems_per_s"] = tp
    return result


def _table_row(r: dict) -> dict:
    us = r["runtime_s"] * 1e6
    return {"count": int(len(us)), "mean_us": float(us.mean()), "std_us": float(us.std()),
            "min_us": float(us.min()), "max_us": float(us.max()),
            "median_us": float(np.median(us)),
            "solve_median_us": float(np.median(r["wall_s"]) * 1e6),
            "failures": int(r["failures"])}


def _batch_rows(methods, args, sigma_r: float, threads: int) -> dict:
    """solve_batch throughput of the methods with a batch kernel, printed."""
    from simcalib.solvers import get
    bmethods = [m for m in methods if get(m).batch_fn is not None]
    if not bmethods:
        return {}
    tp = batch_throughput(bmethods, args.n_motions, args.batch_size, args.alpha, sigma_r,
                          args.sigma_t, args.seed)
    ncpu = min(threads, os.cpu_count() or 1)
    print(f"\nsolve_batch throughput (B = {args.batch_size}, N = {args.n_motions}; "
          f"'idle-machine' = {ncpu} cores / CPU time per problem, i.e. without other "
          "load on the cores):")
    for m, v in tp.items():
        v["idle_machine_problems_per_s"] = ncpu * 1e6 / v["cpu_us_per_problem"]
        print(f"  {m:<18}{v['problems_per_s']:>12,.0f} problems/s wall   "
              f"{v['cpu_us_per_problem']:7.2f} us CPU per problem   "
              f"{v['idle_machine_problems_per_s']:>10,.0f} problems/s idle-machine")
    return tp


def _write_outputs(result: dict, args) -> None:
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
    if args.markdown:
        md = markdown_tables(result)
        if args.markdown == "-":
            print(md)
        else:
            with open(args.markdown, "w") as fh:
                fh.write(md + "\n")


if __name__ == "__main__":
    sys.exit(main())
