"""Real-data regression table (recordings `calibrate` has never seen).

Every public recording of ``../shared/data/real`` (18 folders, TUM ``a.txt`` / ``b.txt``)
and of ``../shared/data/eth`` (5 zips of ETH hand_eye_calibration CSV files) is one entry of
:data:`SETS`: its files, its reference ``X = T_a_b`` (or none), the tolerance its README
calls "correct", the directions a correct verdict must flag, and the reference's own spread
where one is stated. :func:`run_set` calibrates one set with the ``calibrate`` DEFAULTS
through the library (``a``, ``b``, ``output`` in a temporary folder, ``recording=false``,
nothing else) and returns a :class:`SetResult`; :func:`main` writes the markdown table
(``docs/real-data.md``)::

    python -m simcalib.studies.experiments.real_data [--output docs/real-data.md] [--sets NAME ...]
    python -m simcalib experiment real_data [sets=[NAME,...]] [output=DIR]

Data folders: ``$SIMCALIB_REAL_DIR`` / ``$SIMCALIB_ETH_DIR``, default
``<repo>/../shared/data/real`` and ``.../eth``. The ETH zips are unpacked into a cache
folder (default ``<tmp>/simcalib_eth_cache``), never into the repository.

Error convention: :func:`simcalib.solvers.diagnostics.uncertainty.pose_error`
``(X_ref, X_est)`` (rotation vector of ``R_ref R_est^T``, ``t_ref - t_est``, frame a),
the convention the reported covariance refers to. NEES: :func:`nees` (pseudo-inverse on the
axes whose reported variance is finite, restricted to the components the reference pins).

The parts: :mod:`~simcalib.studies.experiments.real_sets` (the sets, their files and
references), :mod:`~simcalib.studies.experiments.real_checks` (each set's calibration, its
errors, NEES and checks, the cross-set agreement, the summary),
:mod:`~simcalib.studies.experiments.real_data_doc` (the page); this module runs them.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from simcalib.errors import DataError
from simcalib.studies.experiments import experiment
from simcalib.studies.experiments.real_checks import run_set, summarise
from simcalib.studies.experiments.real_data_doc import markdown
from simcalib.studies.experiments.real_sets import (ETH_ENV, REAL_ENV, SETS, eth_dir, real_dir,
                                                    set_available, set_by_name)

__all__ = ["run_sets", "write_document", "RealDataConfig", "run", "main"]


# ----------------------------------------------------------------------------- running
def run_sets(names=None, *, cache_dir=None, progress=None) -> dict:
    """``{name: SetResult}`` for ``names`` (default: every available set, table order)."""
    entries = [set_by_name(n) for n in names] if names else list(SETS)
    out = {}
    for e in entries:
        ok, why = set_available(e)
        if not ok:
            if names:
                raise DataError(f"data set {e.name}: {why}")
            continue
        out[e.name] = run_set(e, cache_dir=cache_dir)
        if progress is not None:
            r = out[e.name]
            progress(f"{e.name}: exit {r.exit_code} {r.verdict} {r.wall_time_s:.1f} s"
                     + (f" ({r.error[:120]})" if r.error else ""))
    if not out:
        raise DataError(f"no data set found under {real_dir()} or {eth_dir()} (set "
                        f"{REAL_ENV} / {ETH_ENV})")
    return out


def write_document(path, names=None, *, command: str) -> tuple[Path, dict]:
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="simcalib_eth_") as cache:
        results = run_sets(names, cache_dir=cache,
                           progress=lambda m: print(m, file=sys.stderr, flush=True))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(markdown(results, command=command,
                             total_time_s=time.perf_counter() - t0))
    return path, results


@dataclass(frozen=True)
class RealDataConfig:
    """``python -m simcalib experiment real_data``: ``sets`` (empty: all available),
    ``output`` folder (writes ``real-data.md``)."""
    sets: tuple[str, ...] = ()
    output: str = "results/real_data"

    def __post_init__(self):
        for n in self.sets:
            set_by_name(n)


@experiment('real_data', config=RealDataConfig,
            description='the regression table on the public real recordings')
def run(cfg: RealDataConfig):
    from simcalib.studies.experiments.common import ExperimentResult, output_dir
    t0 = time.perf_counter()
    out = output_dir(cfg.output)
    cmd = "python -m simcalib experiment real_data" + (
        f" sets=[{','.join(cfg.sets)}]" if cfg.sets else "") + f" output={cfg.output}"
    path, results = write_document(out / "real-data.md", cfg.sets or None, command=cmd)
    s = summarise(results)
    notes = (f"{s.n_ran}/{s.n_sets} exit 0 or 6, {s.n_within_reference}/{s.n_referenced} "
             f"within reference, NEES {s.n_nees_within}/{s.n_nees_sets}",)
    return ExperimentResult("real_data", out, {"md": path}, [], time.perf_counter() - t0,
                            notes, {"results": results})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.real_data",
                                description="Calibrate every public recording with the "
                                "defaults and write the markdown table.")
    p.add_argument("--output", default="docs/real-data.md", help="markdown file to write")
    p.add_argument("--sets", nargs="*", default=None, metavar="NAME",
                   help="only these sets: " + ", ".join(s.name for s in SETS))
    args = p.parse_args(argv)
    cmd = "python -m simcalib.studies.experiments.real_data --output " + args.output + (
        " --sets " + " ".join(args.sets) if args.sets else "")
    from simcalib.errors import ConfigError
    try:
        path, results = write_document(args.output, args.sets or None, command=cmd)
    except (ConfigError, DataError) as exc:
        print(f"simcalib: error: {exc}", file=sys.stderr)
        return exc.exit_code
    s = summarise(results)
    print(f"wrote {path}: {s.n_ran}/{s.n_sets} exit 0 or 6; {s.n_within_reference}/"
          f"{s.n_referenced} within reference; NEES within bound {s.n_nees_within}/"
          f"{s.n_nees_sets}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
