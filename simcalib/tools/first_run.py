"""The first run after an installation, measured as a new user meets it.

    python -m simcalib.tools.first_run                   # this checkout, scenario planar
    python -m simcalib.tools.first_run --scenario 3d --wait 90 --keep /tmp/fr

Clones the checkout (``git clone``, so only committed files), creates a fresh virtual
environment, ``pip install .`` (a regular, non-editable install: numba's cache starts
empty), then from a directory outside the tree times ``python -m simcalib run
scenario=S`` twice: the first run (cold cache: interpreted kernels, and the idle-priority
child that fills the cache starts), then, after ``--wait`` seconds (the child's ~25 s of
CPU), the second run. Prints the wall times, ``solver_kernels`` of each run and whether the
cache stamp was written (docs/solvers.md, "Start-up"; the README's first-run row).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _clean_env(venv: Path) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("VIRTUAL_ENV", "PYTHONPATH", "SIMCALIB_KERNELS", "NUMBA_CACHE_DIR")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env.setdefault("MUJOCO_GL", "egl")
    return env


def _timed_run(python: Path, scenario: str, out: Path, cwd: Path, env: dict) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.run([str(python), "-m", "simcalib", "run", f"scenario={scenario}",
                           f"output={out}"], cwd=cwd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"run failed ({proc.returncode}): {proc.stderr[-2000:]}")
    res = json.loads((out / "results.json").read_text())
    return {"wall_s": wall, "solver_kernels": res.get("solver_kernels"),
            "timing_s": res.get("timing_s", {})}


def measure(scenario: str = "planar", wait_s: float = 60.0, root: Path = REPO,
            keep: Path | None = None) -> dict:
    base = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="simcalib-first-run-"))
    if keep and base.exists():
        shutil.rmtree(base)
    base.mkdir(parents=True, exist_ok=True)
    src, venv, cwd = base / "src", base / "venv", base / "cwd"
    cwd.mkdir()
    subprocess.run(["git", "clone", "-q", str(root), str(src)], check=True)
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    env = _clean_env(venv)
    python = venv / "bin" / "python"
    t0 = time.perf_counter()
    subprocess.run([str(python), "-m", "pip", "install", "-q", "."], cwd=src, env=env,
                   check=True)
    install_s = time.perf_counter() - t0
    first = _timed_run(python, scenario, cwd / "run1", cwd, env)
    time.sleep(wait_s)
    stamp = subprocess.run([str(python), "-c", "from simcalib.solvers.kernels import jit; "
                            "print(jit.kernels_cached())"], cwd=cwd, env=env,
                           capture_output=True, text=True).stdout.strip() == "True"
    second = _timed_run(python, scenario, cwd / "run2", cwd, env)
    if not keep:
        shutil.rmtree(base, ignore_errors=True)
    return {"scenario": scenario, "install_s": install_s, "first": first,
            "stamp_after_wait": stamp, "wait_s": wait_s, "second": second}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m simcalib.tools.first_run",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="planar")
    ap.add_argument("--wait", type=float, default=60.0,
                    help="seconds between the two runs (the cache fill's time)")
    ap.add_argument("--root", type=Path, default=REPO, help="checkout to clone")
    ap.add_argument("--keep", type=Path, default=None, help="work folder to keep")
    args = ap.parse_args(argv)
    r = measure(args.scenario, args.wait, args.root, args.keep)
    load = ", ".join(f"{v:.2f}" for v in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
    print(f"scenario {r['scenario']}: pip install . {r['install_s']:.0f} s; load average "
          f"{load} (after the runs)")
    print(f"first run  {r['first']['wall_s']:.1f} s (solver_kernels "
          f"{r['first']['solver_kernels']}, streams {r['first']['timing_s'].get('streams', 0):.1f} s, "
          f"solvers {r['first']['timing_s'].get('solvers', 0):.1f} s)")
    print(f"cache stamp written within {r['wait_s']:.0f} s: {r['stamp_after_wait']}")
    print(f"second run {r['second']['wall_s']:.1f} s (solver_kernels "
          f"{r['second']['solver_kernels']}, solvers "
          f"{r['second']['timing_s'].get('solvers', 0):.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
