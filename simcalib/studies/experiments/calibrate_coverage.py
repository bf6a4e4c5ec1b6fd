"""Is the sigma that ``calibrate`` reports honest? Its coverage on generated recordings.

Every kind of :mod:`simcalib.studies.experiments.recordings` (stations, continuous, outliers, robot
error, ...) is generated for many seeds and calibrated in-process by the one estimation
path (:func:`simcalib.estimation.path.calibrate_streams`, the ``calibrate`` defaults). Per
run, the error ``e = pose_error(X_true, X)`` (frame a) is compared with the REPORTED
covariance on the directions the motions determine (``Uncertainty.determined_basis``):

    NEES = e_B^T S_B^-1 e_B,   e_B = B^T e,   S_B = B^T Sigma_reported B,

and the 95 % coverage of a kind is the share of its runs with NEES at most the chi-square
95 % quantile of ``rank(B)`` degrees of freedom (target: 0.92-0.98 on every kind). The same
is given for the solver's model covariance alone (before the data's own checks) for
comparison. Regenerate::

    python -m simcalib.studies.experiments.calibrate_coverage --seeds 100 --workers 2 \\
        --output results/calibrate_coverage.md
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from simcalib.studies.experiments.recording_kinds import KINDS

__all__ = ["COVERAGE_KINDS", "trial", "coverage_rows", "markdown", "main"]

#: the kinds with an estimate (a bad-input kind is refused: nothing to cover)
COVERAGE_KINDS = tuple(k for k, v in KINDS.items() if v.expect != "data_error")


def _nees(e, B, S) -> float:
    c = B.T @ e
    Sb = B.T @ S @ B
    return float(c @ np.linalg.lstsq(0.5 * (Sb + Sb.T), c, rcond=None)[0])


def trial(kind: str, seed: int) -> dict:
    """One calibration of ``generate(kind, seed)``: ``nees`` (reported covariance),
    ``nees_model`` (the solver's model alone), ``dof``, ``error_deg`` / ``error_mm``,
    ``sigma_deg`` / ``sigma_mm`` (largest reported 1-sigma over the determined axes),
    ``time_s``, ``verdict``; ``error`` (a string) instead when the path refused."""
    from simcalib.errors import SimcalibError
    from simcalib.estimation.path import calibrate_streams
    from simcalib.studies.experiments.recording_kinds import generate
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    rec = generate(kind, seed)
    t0 = time.perf_counter()
    try:
        r = calibrate_streams(rec.stream_a, rec.stream_b)
    except SimcalibError as exc:
        return {"kind": kind, "seed": seed, "error": str(exc).splitlines()[0]}
    dt = time.perf_counter() - t0
    unc = r.robust.solution.uncertainty
    basis = getattr(r.consistency, "basis", None)
    B = np.asarray(unc.determined_basis if basis is None else basis)
    e = pose_error(rec.X_true, r.X)
    eb = B @ (B.T @ e)
    s = np.sqrt(np.diag(r.covariance_determined))
    fin = np.isfinite(np.diag(r.covariance))
    e_ws = None if rec.X_workspace is None else pose_error(rec.X_workspace, r.X)
    stated = None if rec.accuracy_a is None or not B.shape[1] else _nees(
        e, B, _stated(rec).covariance_determined)
    return {"kind": kind, "seed": seed, "dof": int(B.shape[1]), "nees_stated": stated,
            "nees": _nees(e, B, r.covariance_determined) if B.shape[1] else 0.0,
            "nees_workspace": None if e_ws is None or not B.shape[1]
            else _nees(e_ws, B, r.covariance_determined),
            "nees_model": _nees(e, B, unc.covariance_determined) if B.shape[1] else 0.0,
            "error_deg": float(np.degrees(np.linalg.norm(eb[:3]))),
            "error_mm": float(1e3 * np.linalg.norm(eb[3:])),
            "sigma_deg": float(np.degrees(np.max(np.where(fin[:3], s[:3], 0.0)))),
            "sigma_mm": float(1e3 * np.max(np.where(fin[3:], s[3:], 0.0))),
            "time_s": dt, "verdict": r.robust.solution.verdict if r.consistency is None
            else _verdict(r), "n_poses": int(r.synced.n)}


def _stated(rec):
    """The calibration of ``rec`` with its robot's accuracy stated
    (``common_error.rotation_a_deg`` / ``translation_a_m``: the rms of its error field)."""
    from simcalib.estimation.common_error import CommonError
    from simcalib.estimation.path import calibrate_streams
    deg, m = rec.accuracy_a
    return calibrate_streams(rec.stream_a, rec.stream_b, common_error=CommonError(
        rotation_a_deg=deg, translation_a_m=m))


def _verdict(r) -> str:
    from simcalib.estimation.verdict import judge
    v = judge(r.robust.solution, r.covariance, r.covariance_determined, r.consistency,
              r.weighting)
    return v.verdict + (" (unverified)" if v.unverified else "")


def _trial_args(args):
    return trial(*args)


def run_trials(kinds, seeds: int, workers: int = 1, log=None) -> list[dict]:
    """:func:`trial` for every kind x seed ``0..seeds-1`` (``workers`` processes)."""
    tasks = [(k, s) for k in kinds for s in range(seeds)]
    if workers <= 1:
        out = []
        for t in tasks:
            out.append(trial(*t))
            if log:
                log(out[-1])
        return out
    import multiprocessing as mp
    with mp.get_context("fork").Pool(workers) as pool:
        out = []
        for res in pool.imap(_trial_args, tasks, chunksize=2):
            out.append(res)
            if log:
                log(res)
    return out


def coverage_rows(trials: list[dict], level: float = 0.95) -> list[dict]:
    """Per kind: runs, refusals, coverage of the reported and of the model's covariance,
    median NEES / dof, median error and reported sigma, median time."""
    from scipy.special import chdtri
    rows = []
    for kind in dict.fromkeys(t["kind"] for t in trials):
        ts = [t for t in trials if t["kind"] == kind]
        ok = [t for t in ts if "error" not in t and t["dof"] > 0]
        if not ok:
            rows.append({"kind": kind, "runs": len(ts), "solved": 0})
            continue
        q = np.array([chdtri(t["dof"], 1.0 - level) for t in ok])
        nees = np.array([t["nees"] for t in ok])
        model = np.array([t["nees_model"] for t in ok])
        dof = np.array([t["dof"] for t in ok])
        ws = [t.get("nees_workspace") for t in ok]
        st = [t.get("nees_stated") for t in ok]
        rows.append({
            "kind": kind, "runs": len(ts), "solved": len(ok),
            "coverage": float(np.mean(nees <= q)), "coverage_model": float(np.mean(model <= q)),
            "coverage_workspace": None if any(w is None for w in ws)
            else float(np.mean(np.array(ws) <= q)),
            "coverage_stated": None if any(x is None for x in st)
            else float(np.mean(np.array(st) <= q)),
            "nees_per_dof_median": float(np.median(nees / dof)),
            "error_deg_median": float(np.median([t["error_deg"] for t in ok])),
            "error_mm_median": float(np.median([t["error_mm"] for t in ok])),
            "sigma_deg_median": float(np.median([t["sigma_deg"] for t in ok])),
            "sigma_mm_median": float(np.median([t["sigma_mm"] for t in ok])),
            "time_s_median": float(np.median([t["time_s"] for t in ok])),
            "time_s_max": float(np.max([t["time_s"] for t in ok])),
            "unverified": int(sum("unverified" in t["verdict"] for t in ok))})
    return rows


def _f(x, d=3):
    return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else \
        f"{x:.{d}g}"


def markdown(rows: list[dict], command: str) -> str:
    L = ["# Coverage of calibrate's sigma on generated recordings", "",
         f"Generated by `{command}` (simcalib/studies/experiments/calibrate_coverage.py). Each run: "
         "`calibrate_streams` with its defaults on `recording_kinds.generate(kind, seed)`; NEES of "
         "the error against the true X over the directions the motions determine, with the "
         "reported covariance (and with the solver's model alone); coverage = share of runs "
         "with NEES within the chi-square 95 % bound. Target 0.92-0.98 on every kind. "
         "`vs workspace X` (kinds with systematic error): the same NEES against the X that "
         "the errors imply over the whole workspace (`Recording.X_workspace`), which differs "
         "from the true X by the errors' part common to every pose. `robot accuracy "
         "stated` (kinds with a robot error field): the coverage against the true X when the "
         "robot's accuracy (the rms of its error field) is given as `common_error.*`.", "",
         "| kind | runs (solved) | coverage | vs workspace X | robot accuracy stated | model "
         "alone | median NEES/dof | median err deg / mm | median sigma deg / mm | unverified "
         "| time med / max (s) |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if not r.get("solved"):
            L.append(f"| {r['kind']} | {r['runs']} (0) | n/a | n/a | n/a | n/a | n/a | n/a | "
                     "n/a | n/a | n/a |")
            continue
        cw, cs = r["coverage_workspace"], r["coverage_stated"]
        L.append(f"| {r['kind']} | {r['runs']} ({r['solved']}) | {r['coverage']:.2f} | "
                 f"{'—' if cw is None else f'{cw:.2f}'} | {'—' if cs is None else f'{cs:.2f}'} | "
                 f"{r['coverage_model']:.2f} | {_f(r['nees_per_dof_median'])} | "
                 f"{_f(r['error_deg_median'])} / {_f(r['error_mm_median'])} | "
                 f"{_f(r['sigma_deg_median'])} / {_f(r['sigma_mm_median'])} | "
                 f"{r['unverified']} | {_f(r['time_s_median'], 2)} / {_f(r['time_s_max'], 2)} |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.calibrate_coverage",
                                description=__doc__.splitlines()[0])
    p.add_argument("--kinds", nargs="+", default=list(COVERAGE_KINDS),
                   choices=list(COVERAGE_KINDS))
    p.add_argument("--seeds", type=int, default=100)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--output", default=None, help="markdown file (default: stdout only)")
    p.add_argument("--quiet", action="store_true")
    a = p.parse_args(argv)
    log = None if a.quiet else (lambda t: print(
        t["kind"], t["seed"], t.get("error") or f"nees {t['nees']:.2f} ({t['dof']}) model "
        f"{t['nees_model']:.2f} t {t['time_s']:.2f}s {t['verdict']}", flush=True))
    rows = coverage_rows(run_trials(a.kinds, a.seeds, a.workers, log))
    cmd = "python -m simcalib.studies.experiments.calibrate_coverage " + " ".join(
        (argv if argv is not None else sys.argv[1:]))
    md = markdown(rows, cmd.strip())
    print(md)
    if a.output:
        from pathlib import Path
        Path(a.output).parent.mkdir(parents=True, exist_ok=True)
        Path(a.output).write_text(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
