"""Sweep throughput: ``python -m simcalib.studies.sweep.bench [noise vision ...] [--workers N]
[--limit N] [--markdown]``.

Runs shipped sweeps (all cells, or the first ``--limit`` cells) with the local executor
into a temporary directory and prints, per sweep: cells, wall time, mean cell time,
the scheduling + writing overhead (share of the workers' time not spent inside the cells'
runs) and cells per hour per core — the numbers docs/sweep.md and the README quote, so a
user can size a cluster. ``--markdown`` prints the table for the docs.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path


def _limited(spec, limit: int | None):
    if not limit:
        return spec
    from simcalib.studies.sweep.spec import expand
    n = len(expand(spec))
    if n <= limit:
        return spec
    # keep the axes, fewer seeds first, then the leading cells (order is deterministic)
    per_seed = n // spec.seeds
    seeds = max(1, limit // max(1, per_seed))
    return dataclasses.replace(spec, seeds=seeds)


def bench(names, workers: int | None, limit: int | None) -> list[dict]:
    from simcalib.studies.sweep import load_sweep, run_sweep
    rows = []
    for name in names:
        spec = _limited(load_sweep(name), limit)
        with tempfile.TemporaryDirectory(prefix=f"sweep-bench-{name}-") as tmp:
            s = run_sweep(spec, Path(tmp) / name, workers=workers, progress=False,
                          report=False)
        mean = s.cell_s_total / s.ran if s.ran else float("nan")
        rows.append({"sweep": name, "cells": s.ran, "failed": s.failed, "wall_s": s.wall_s,
                     "cell_s": mean, "overhead": s.overhead_fraction,
                     "cells_per_hour_core": 3600.0 / mean if s.ran else float("nan"),
                     "workers": s.workers})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m simcalib.studies.sweep.bench",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("sweeps", nargs="*", default=["noise", "vision"])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--limit", type=int, default=None,
                    help="run at most about this many cells per sweep (fewer seeds)")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    from simcalib.parallel import default_workers
    workers = args.workers or default_workers()
    rows = bench(args.sweeps, workers, args.limit)
    if args.markdown:
        print(f"| sweep | cells | failed | wall [s] ({workers} workers) | mean cell [s] | "
              f"overhead | cells / hour / core |")
        print("|---|---|---|---|---|---|---|")
        for r in rows:
            over = "–" if r["overhead"] is None else f"{r['overhead']:.1%}"
            print(f"| `{r['sweep']}` | {r['cells']} | {r['failed']} | {r['wall_s']:.0f} | "
                  f"{r['cell_s']:.2f} | {over} | {r['cells_per_hour_core']:.0f} |")
    else:
        for r in rows:
            print(r)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
