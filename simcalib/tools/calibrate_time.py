"""Wall time of the ``calibrate`` command as a user meets it (the README's calibrate row).

    python -m simcalib.tools.calibrate_time                      # every shared set <= 1000 poses
    python -m simcalib.tools.calibrate_time --sets rwhecalib_kuka_1 tabb_rwhe_dataset1 --repeats 7
    python -m simcalib.tools.calibrate_time --cold               # an empty numba cache each run

Runs ``python -m simcalib calibrate a=A b=B output=TMP overwrite=true`` (outputs and the
recording included) ``--repeats`` times on each set of ``../shared/data/real`` (or
``SIMCALIB_REAL_DIR``; :func:`simcalib.studies.experiments.real_sets.real_dir`) whose
stream a holds at most ``--max-poses`` poses, and prints per set the pose count, the exit
status and the median / min / max wall time, then the median over the sets and the
machine's load average before and after (a loaded machine stretches every number).
``--cold``: each run with a fresh, empty ``NUMBA_CACHE_DIR`` (the first run after an
installation: interpreted kernels while a child fills the cache). The runs write and use
Python's bytecode cache as an installation has it (``PYTHONDONTWRITEBYTECODE`` is not
passed on: compiling every module from source adds ~0.4 s a run).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

def _poses(path: Path) -> int:
    with open(path) as f:
        return sum(1 for line in f if line.strip() and not line.lstrip().startswith("#"))


def _sets(root: Path, names, max_poses: int) -> list[tuple[str, Path, Path, int]]:
    out = []
    for d in sorted(p for p in root.iterdir() if (p / "a.txt").is_file()):
        if names and d.name not in names:
            continue
        n = _poses(d / "a.txt")
        if names or n <= max_poses:
            out.append((d.name, d / "a.txt", d / "b.txt", n))
    return out


def run_env(numba_cache: str | None = None) -> dict:
    """The environment of a timed run: this one, with bytecode caching on (as an
    installation has it), MUJOCO_GL defaulting to egl and ``numba_cache`` as the kernels'
    cache folder when given."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.setdefault("MUJOCO_GL", "egl")
    if numba_cache is not None:
        env["NUMBA_CACHE_DIR"] = numba_cache
    return env


def _time_once(a: Path, b: Path, out: Path, cold: bool) -> tuple[float, int]:
    cache = tempfile.TemporaryDirectory(prefix="simcalib-numba-") if cold else None
    env = run_env(None if cache is None else cache.name)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "simcalib", "calibrate", f"a={a}", f"b={b}",
                           f"output={out}", "overwrite=true"], env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    if cache is not None:
        cache.cleanup()
    if proc.returncode not in (0, 6):
        raise RuntimeError(f"calibrate {a.parent.name} exited {proc.returncode}: "
                           f"{proc.stderr.strip()[-500:]}")
    return wall, proc.returncode


def main(argv=None) -> int:
    from simcalib.studies.experiments.real_sets import real_dir
    ap = argparse.ArgumentParser(prog="python -m simcalib.tools.calibrate_time",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=real_dir(), help=f"default {real_dir()}")
    ap.add_argument("--sets", nargs="*", default=(), help="set names (default: all small)")
    ap.add_argument("--max-poses", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cold", action="store_true")
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        print(f"no data folder {args.data}", file=sys.stderr)
        return 2
    sets = _sets(args.data, set(args.sets), args.max_poses)
    if not sets:
        print(f"no set in {args.data} matches {list(args.sets) or '<= max-poses'}",
              file=sys.stderr)
        return 2
    load0 = os.getloadavg()[0]
    medians = []
    print(f"{'set':<24} {'poses':>6} {'exit':>4}  median / min / max wall (s), "
          f"{args.repeats} runs{' (cold cache)' if args.cold else ''}")
    with tempfile.TemporaryDirectory(prefix="simcalib-calibrate-time-") as tmp:
        for name, a, b, n in sets:
            runs = [_time_once(a, b, Path(tmp) / name, args.cold) for _ in range(args.repeats)]
            walls = [w for w, _ in runs]
            medians.append(statistics.median(walls))
            print(f"{name:<24} {n:>6} {runs[-1][1]:>4}  {medians[-1]:.2f} / {min(walls):.2f} "
                  f"/ {max(walls):.2f}")
    print(f"median over {len(sets)} sets: {statistics.median(medians):.2f} s; largest set "
          f"median {max(medians):.2f} s; load average {load0:.1f} -> {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
