"""What the run recording costs: each scenario run with and without ``recording.rrd``.

    python -m simcalib.tools.recording_cost                       # line, planar, 3d; 3 reps
    python -m simcalib.tools.recording_cost --scenario line --reps 5
    python -m simcalib.tools.recording_cost --variants worker,inprocess,off
    python -m simcalib.tools.recording_cost --root /tmp/old-checkout --variants as-is

Variants (interleaved per repetition, so a machine's changing load hits them alike):
``worker`` (the default: rerun imported and the file written by a worker process),
``inprocess`` (``recording.background=false``), ``off`` (``recording.enabled=false``),
``as-is`` (no recording override: for a checkout given by ``--root``, e.g. an older commit,
whose code is run instead of this one). Each run is ``python -m simcalib run scenario=S``
in a subprocess; printed per variant (medians): the command's wall time, the run's
``timing_s.total``, ``recording_s`` (the wall time the run spent recording, from
``recording_view.json``), its share of ``timing_s.total``, the file's size and, for the
worker, its own import and logging times (beside the run).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
VARIANTS = {"worker": [], "inprocess": ["recording.background=false"],
            "off": ["recording.enabled=false"], "as-is": []}


def run_once(scenario: str, variant: str, out: Path, root: Path = REPO, overrides=()) -> dict:
    """One run; its wall time and what its outputs say about the recording."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; valid: {', '.join(VARIANTS)}")
    env = dict(os.environ, PYTHONPATH=str(root))
    env.setdefault("MUJOCO_GL", "egl")
    cmd = [sys.executable, "-m", "simcalib", "run", f"scenario={scenario}", f"output={out}",
           "progress=false", "overwrite=true", *VARIANTS[variant], *overrides]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-800:]}")
    total = json.loads((out / "results.json").read_text())["timing_s"]["total"]
    view_p, rrd = out / "recording_view.json", out / "recording.rrd"
    view = json.loads(view_p.read_text()) if view_p.exists() else {}
    return {"wall_s": wall, "total_s": total, "recording_s": view.get("recording_s", 0.0),
            "size_mb": rrd.stat().st_size / 1e6 if rrd.exists() else 0.0,
            "worker": view.get("worker")}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m simcalib.tools.recording_cost",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append", help="repeatable; default line, planar, 3d")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--variants", default="worker,off",
                    help=f"comma-separated, of {', '.join(VARIANTS)} (default worker,off)")
    ap.add_argument("--root", default=str(REPO), help="checkout whose simcalib is run")
    ap.add_argument("--override", action="append", default=[], help="key=value for every run")
    ap.add_argument("--output", default="runs/recording_cost")
    args = ap.parse_args(argv)
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    bad = [v for v in variants if v not in VARIANTS]
    if bad or args.reps < 1:
        ap.error(f"unknown variant(s) {bad}; valid: {', '.join(VARIANTS)}" if bad
                 else "--reps must be >= 1")
    root = Path(args.root).resolve()
    for scenario in args.scenario or ("line", "planar", "3d"):
        rows: dict[str, list[dict]] = {v: [] for v in variants}
        for r in range(args.reps):
            for v in variants:
                out = Path(args.output).resolve() / f"{scenario}_{v}_{r}"
                rows[v].append(run_once(scenario, v, out, root, args.override))
        for v, rs in rows.items():
            def med(key, rs=rs):
                return statistics.median(x[key] for x in rs)
            line = (f"{scenario} {v}: wall {med('wall_s'):.2f} s, run {med('total_s'):.2f} s, "
                    f"recording {med('recording_s'):.2f} s "
                    f"({100 * med('recording_s') / med('total_s'):.1f} % of the run), "
                    f"{med('size_mb'):.1f} MB")
            ws = [x["worker"] for x in rs if x.get("worker")]
            if ws:
                line += (f"; worker beside the run: import "
                         f"{statistics.median(w['import_s'] for w in ws):.2f} s, logging "
                         f"{statistics.median(w['log_s'] for w in ws):.2f} s")
            print(line + f" (median of {len(rs)})", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
