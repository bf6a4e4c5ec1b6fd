"""Solver benchmark: a Table-1-like timing table and the solve_batch throughput.

Run ``python -m simcalib bench`` (or ``python -m simcalib.bench``); ``--help`` lists the
options. Every method solves the same noisy random problems (paper appendix D.2 style:
uniform random relative motions, eq. 38 noise); the time per solve is
``Solution.runtime_s`` — from the ``(N, 4, 4)`` arrays to ``X`` (validation, conversion,
solver), the quantity of the paper's Table 1 — and the wall time of the whole
``simcalib.solve`` call (which also evaluates the cost) is shown as well.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

__all__ = ["main", "make_problems", "time_methods", "batch_throughput"]


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
    import simcalib
    rows = {}
    from simcalib.solvers import get
    for m in methods:
        stochastic = get(m).stochastic
        simcalib.solve(C[0], H[0], method=m, alpha=alpha, rng=np.random.default_rng(seed))
        rt, wall, cost, fails = [], [], [], 0
        start = time.perf_counter()
        for b in range(C.shape[0]):
            rng = np.random.default_rng(seed + b) if stochastic else None
            t0 = time.perf_counter()
            sol = simcalib.solve(C[b], H[b], method=m, alpha=alpha, rng=rng)
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
    import simcalib
    C, H, _ = make_problems(np.random.default_rng(seed + 1), batch_size, n, sigma_r, sigma_t)
    alphas = np.full(batch_size, alpha)
    out = {}
    for m in methods:
        simcalib.solve_batch(C[:4], H[:4], method=m, alpha=alphas[:4])
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            simcalib.solve_batch(C, H, method=m, alpha=alphas)
            best = min(best, time.perf_counter() - t0)
        out[m] = batch_size / best
    return out


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
        ratio = f"{us.mean() / (ref_mean * 1e6):.2f}" if ref_mean else "-"
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
    from simcalib.solvers import available, get
    parser = argparse.ArgumentParser(
        prog="simcalib bench",
        description="Time every registered solver on the same noisy random problems "
                    "(Table-1-like: mean/std/min/max microseconds per solve, from the "
                    "(N,4,4) arrays to X) and measure solve_batch throughput.")
    parser.add_argument("--n-motions", type=int, default=100, help="motions per problem (100)")
    parser.add_argument("--problems", type=int, default=300,
                        help="problems timed per method (300; slow methods stop early)")
    parser.add_argument("--max-seconds", type=float, default=4.0,
                        help="time budget per method for the table (4 s)")
    parser.add_argument("--methods", default="all",
                        help="comma-separated method names, or 'all' (default)")
    parser.add_argument("--alpha", type=float, default=1.0, help="weighting factor (1/m)")
    parser.add_argument("--sigma-r-deg", type=float, default=0.57,
                        help="rotation noise (deg, paper D.2: 0.57)")
    parser.add_argument("--sigma-t", type=float, default=0.01, help="translation noise (m)")
    parser.add_argument("--batch-size", type=int, default=20000,
                        help="problems per solve_batch call for the throughput (20000; 0 = skip)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="also write the numbers to this file")
    args = parser.parse_args(argv)
    if args.n_motions < 2:
        parser.error(f"--n-motions must be >= 2; received {args.n_motions}")
    if args.problems < 1:
        parser.error(f"--problems must be >= 1; received {args.problems}")
    if not (np.isfinite(args.alpha) and args.alpha > 0):
        parser.error(f"--alpha must be finite and > 0; received {args.alpha}")
    names = available()
    if args.methods == "all":
        methods = names
    else:
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
        unknown = [m for m in methods if m not in names]
        if unknown:
            parser.error(f"unknown method(s) {', '.join(unknown)}; available: "
                         f"{', '.join(names)}")
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
              "table": {m: {"count": int(len(r["runtime_s"])),
                            "mean_us": float(r["runtime_s"].mean() * 1e6),
                            "std_us": float(r["runtime_s"].std() * 1e6),
                            "min_us": float(r["runtime_s"].min() * 1e6),
                            "max_us": float(r["runtime_s"].max() * 1e6),
                            "median_us": float(np.median(r["runtime_s"]) * 1e6),
                            "solve_median_us": float(np.median(r["wall_s"]) * 1e6),
                            "failures": int(r["failures"])} for m, r in rows.items()}}
    if args.batch_size > 0:
        bmethods = [m for m in methods if get(m).batch_fn is not None]
        if bmethods:
            tp = batch_throughput(bmethods, args.n_motions, args.batch_size, args.alpha,
                                  sigma_r, args.sigma_t, args.seed)
            print(f"\nsolve_batch throughput (B = {args.batch_size}, N = {args.n_motions}):")
            for m, v in tp.items():
                print(f"  {m:<18}{v:>12,.0f} problems/s  ({1e6 / v:.2f} us per problem)")
            result["batch_problems_per_s"] = tp
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
