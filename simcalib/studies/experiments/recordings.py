"""Benchmark recordings of many kinds (recordings `calibrate` has
never seen), and the comparison of the ``calibrate`` defaults with a classic solver on them.

    from simcalib.studies.experiments.recording_kinds import KINDS, generate, write_tum
    rec = generate("outliers", seed=3)            # a Recording: both streams + the truth
    write_tum(rec, "out/rec")                     # a.txt, b.txt, truth.json
    python -m simcalib.studies.experiments.recordings --kinds stations offset --seeds 5 \\
        --output docs/recordings.md
    python -m simcalib experiment recordings kinds=[stations,offset] seeds=5

Every recording is a rigid pair of sensors: ``a`` a robot hand (``T_base_hand``) or a
vehicle (``T_odom_vehicle``), ``b`` a camera in its own world (``T_target_cam`` or a SLAM
world), ``X = T_a_b``, so ``T_wa_a X = Y T_wb_b`` with a fixed ``Y = T_wa_wb`` and
``C X = X H`` for every motion. The streams are given in the FILE's form: possibly
inverted (``T_sensor_world``) or with the quaternion written scalar-first; the
:class:`Recording` says which reading is correct, the true clock offset ``t_b - t_a`` (and
drift), and which poses are outliers. Every random draw comes from
``np.random.default_rng`` children of ``np.random.SeedSequence(seed)``: the same kind and
seed give the same arrays.

The comparison (:func:`evaluate`, :func:`main`): the ``calibrate`` COMMAND with its
defaults on the TUM files (offset estimated, reading detected, RANSAC), against OpenCV's
Park solver (``cv2.calibrateHandEye(..., CALIB_HAND_EYE_PARK)``) given the TRUE offset and
the TRUE reading on the synchronised poses (continuous kinds: b interpolated at a's
shifted stamps, subsampled to at most :data:`PARK_MAX_POSES` poses; all i<j pairs).
Park gets no outlier rejection.

The parts: :mod:`~simcalib.studies.experiments.recording_models` (what a recording holds,
the rig, clocks and motion models), :mod:`~simcalib.studies.experiments.recording_kinds`
(the kinds, :func:`generate`, the TUM files); this module holds the comparison and the
table.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from simcalib.geometry import (invert_transform, rotation_error_rad,
                               transform_from_rotation_translation)
from simcalib.studies.experiments import experiment
from simcalib.studies.experiments.recording_kinds import (KINDS, generate, true_streams,
                                                          write_tum)
from simcalib.studies.experiments.recording_models import Recording
from simcalib.studies.experiments.recording_outcomes import (  # noqa: F401 (re-exported)
    MIN_PRECISION, MIN_RECALL, OFFSET_TOL_MS, PARK_FACTOR, ROT_FLOOR_DEG, STEP_TOL_S,
    TRANS_FLOOR_MM, Outcome, acceptance_failures, mount_failures, no_worse, offset_checked,
    step_failures)

__all__ = ["PARK_MAX_POSES", "PARK_FACTOR", "ROT_FLOOR_DEG", "TRANS_FLOOR_MM", "OFFSET_TOL_MS",
           "MIN_PRECISION", "MIN_RECALL", "synchronised_truth", "park_baseline",
           "translation_error_determined", "undetermined_covered", "offset_checked",
           "no_worse",
           "motion_outliers", "Outcome", "evaluate", "acceptance_failures", "mount_failures",
           "step_failures", "summarise", "markdown", "run_all", "RecordingsConfig", "run",
           "main"]



PARK_MAX_POSES = 60
#: hand orientation looking straight down (camera towards the table): Rx(pi)


# -------------------------------------------------------------------------- baseline
def synchronised_truth(rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True-reading poses ``(T_a, T_b, clean)`` of a and b at common instants: station
    kinds pair row by row (the same stations, also on two clocks); continuous kinds
    interpolate b at a's stamps shifted by the TRUE offset (:func:`simcalib.estimation.
    interpolation.interpolate_poses`, not across gaps). ``clean``: the instant uses no
    outlier pose."""
    from simcalib.estimation.interpolation import interpolate_poses
    sa, sb = true_streams(rec)
    ta, Ta, tb, Tb = sa.timestamps_s, sa.T_world_sensor, sb.timestamps_s, sb.T_world_sensor
    if ta.shape == tb.shape and (np.array_equal(ta, tb) or not rec.offset_determined):
        return Ta, Tb, ~(rec.outliers_a | rec.outliers_b)
    gap = 2.5 * float(np.median(np.diff(tb)))
    tq = ta + rec.offset_at(ta)
    Tb_at_a, valid = interpolate_poses(tb, Tb, tq, gap)
    clean = ~(rec.outliers_a | _contaminated(tq, tb, rec.outliers_b))
    return Ta[valid], Tb_at_a[valid], clean[valid]


def park_baseline(rec: Recording, oracle_inliers: bool = False) -> np.ndarray:
    """OpenCV PARK (``cv2.calibrateHandEye``) given the true offset and reading, on at most
    :data:`PARK_MAX_POSES` synchronised poses (evenly subsampled; all i<j pairs). No outlier
    rejection, unless ``oracle_inliers``: then only the instants that use no outlier pose
    (the TRUE masks; for reference only). Where no pair of those poses rotates beyond
    the noise (pure translation), Park's rotation step has nothing to use and the classic
    answer is the Kabsch / Arun fit of the translations (:func:`_translation_baseline`).
    Returns ``X = T_a_b``."""
    import cv2
    if not hasattr(cv2, "calibrateHandEye"):
        raise RuntimeError(f"OpenCV {cv2.__version__} has no calibrateHandEye; install "
                           "opencv-python-headless>=4.10,<5")
    Ta, Tb, clean = synchronised_truth(rec)
    if rec.change_row is not None:      # given the true change: the stretch X_true holds on
        Ta, Tb, clean = Ta[rec.change_row:], Tb[rec.change_row:], clean[rec.change_row:]
    if oracle_inliers:
        Ta, Tb = Ta[clean], Tb[clean]
    if Ta.shape[0] < 3:
        raise ValueError(f"only {Ta.shape[0]} synchronised poses for Park")
    idx = np.unique(np.round(np.linspace(0, Ta.shape[0] - 1,
                                         min(PARK_MAX_POSES, Ta.shape[0]))).astype(int))
    if _no_rotation(Ta[idx], Tb[idx]):
        return _translation_baseline(Ta[idx], Tb[idx])
    Ta, Tb_inv = Ta[idx], invert_transform(Tb[idx])     # gripper2base, target2cam
    R, t = cv2.calibrateHandEye(list(Ta[:, :3, :3]), list(Ta[:, :3, 3:]),
                                list(Tb_inv[:, :3, :3]), list(Tb_inv[:, :3, 3:]),
                                method=cv2.CALIB_HAND_EYE_PARK)
    return transform_from_rotation_translation(np.asarray(R), np.asarray(t).reshape(3))


def _pair_motions(Ta, Tb) -> tuple[np.ndarray, np.ndarray]:
    i, j = np.triu_indices(Ta.shape[0], k=1)
    return invert_transform(Ta[i]) @ Ta[j], invert_transform(Tb[i]) @ Tb[j]


def _no_rotation(Ta, Tb) -> bool:
    """No pair of the poses rotates beyond the noise (:func:`simcalib.solvers.problem.
    rotation_shortfall`): Park's rotation step has nothing to use."""
    from simcalib.solvers.problem import rotation_shortfall
    return rotation_shortfall(*_pair_motions(Ta, Tb)) is not None


def _translation_baseline(Ta, Tb) -> np.ndarray:
    """The classic answer for pure translation: the rotation that best maps the pairs'
    translations of b onto a's (``t_C = R_X t_H``; Kabsch / Arun, SVD of ``sum t_C
    t_H^T``); X's translation is undetermined (left 0)."""
    C, H = _pair_motions(Ta, Tb)
    U, _, Vt = np.linalg.svd(C[:, :3, 3].T @ H[:, :3, 3])
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return transform_from_rotation_translation(U @ D @ Vt, np.zeros(3))


# -------------------------------------------------------------------------- evaluate
def _undetermined_basis(U) -> np.ndarray:
    """Orthonormal rows spanning the directions ``U`` (``(k, 3)`` or ``(3,)``)."""
    _, sv, Vt = np.linalg.svd(np.atleast_2d(U), full_matrices=False)
    return Vt[sv > 1e-9 * sv[0]]


def translation_error_determined(X, rec: Recording) -> float:
    """Translation error (m), without its components along ``rec.undetermined_a``; NaN when
    those span every direction (pure translation: no translation of X is determined)."""
    d = np.asarray(X)[:3, 3] - rec.X_true[:3, 3]
    if rec.undetermined_a is not None:
        B = _undetermined_basis(rec.undetermined_a)
        if B.shape[0] == 3:
            return math.nan
        d = d - B.T @ (B @ d)
    return float(np.linalg.norm(d))


def undetermined_covered(dirs, U) -> bool:
    """Every true undetermined direction (rows of ``U``) lies within ~25 deg of the span of
    the reported directions ``dirs`` (its projection on them is > 0.9)."""
    if U is None or not len(dirs):
        return False
    B = _undetermined_basis(np.asarray(dirs, dtype=np.float64))
    return all(float(np.linalg.norm(B @ u)) > 0.9 for u in np.atleast_2d(U))


def _contaminated(t_query, t_stream, bad) -> np.ndarray:
    """Instants whose pose of a stream uses an outlier sample (the sample itself, or one
    of the two that bracket the instant when it is interpolated)."""
    if not bad.any():
        return np.zeros(t_query.shape, dtype=bool)
    k = np.clip(np.searchsorted(t_stream, t_query), 0, t_stream.size - 1)
    exact = np.abs(t_stream[k] - t_query) < 1e-6
    prev = np.clip(k - 1, 0, t_stream.size - 1)
    exact_prev = np.abs(t_stream[prev] - t_query) < 1e-6
    return np.where(exact, bad[k], np.where(exact_prev, bad[prev], bad[k] | bad[prev]))


def motion_outliers(rec: Recording, synced_time_s, index_start, index_end, offset_s,
                    drift=0.0, t_ref_s=0.0) -> np.ndarray:
    """Bool per motion: the motion (synchronised instants ``index_start`` -> ``index_end``
    at clock-a times ``synced_time_s``, synchronised with the given offset model) touches
    an outlier pose of either stream."""
    t = np.asarray(synced_time_s, dtype=np.float64)
    tb = t + offset_s + drift * (t - t_ref_s)
    sa, sb = true_streams(rec)                              # stamps in seconds
    bad = (_contaminated(t, sa.timestamps_s, rec.outliers_a)
           | _contaminated(tb, sb.timestamps_s, rec.outliers_b))
    return bad[np.asarray(index_start)] | bad[np.asarray(index_end)]


def _run_cli(paths: dict, out: Path) -> tuple[int, str]:
    from simcalib.cli import main as cli_main
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = cli_main(["calibrate", f"a={paths['a']}", f"b={paths['b']}",
                         f"output={out}", "recording=false", "overwrite=true"])
    lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error:" in ln] or lines
    return int(code), (errors[-1].replace(str(out.parent), "<dir>") if errors else "")


def _inlier_scores(rec, report, motions) -> tuple[float, float]:
    off = report["time_offset"]
    bad = motion_outliers(rec, motions["synced_time_s"], motions["index_start"],
                          motions["index_end"], off["offset_s"], off["drift"] or 0.0,
                          off["t_ref_s"] or 0.0)
    inl = np.asarray(motions["inlier"], dtype=bool)
    good = ~bad
    precision = float((inl & good).sum() / inl.sum()) if inl.any() else math.nan
    recall = float((inl & good).sum() / good.sum()) if good.any() else math.nan
    return precision, recall


def _reported_directions(report) -> tuple:
    unc = (report.get("solution") or {}).get("uncertainty") or {}
    return tuple(tuple(d["translation_dir_a"]) for d in unc.get("directions", [])
                 if any(abs(x) > 0 for x in d["translation_dir_a"]))


def _park_errors(rec: Recording, oracle_inliers: bool) -> tuple[float, float]:
    """(rotation deg, translation mm) errors of :func:`park_baseline`; NaN for bad-input
    kinds or when OpenCV fails."""
    if rec.expect == "data_error":
        return math.nan, math.nan
    try:
        X = park_baseline(rec, oracle_inliers)
    except Exception:       # noqa: BLE001 - a failed baseline is reported as NaN
        return math.nan, math.nan
    return (math.degrees(float(rotation_error_rad(X, rec.X_true))),
            1e3 * translation_error_determined(X, rec))


def _true_change_s(rec: Recording) -> tuple:
    """The stamps (clock a) of the rows either side of the true change of X, or ()."""
    if rec.change_row is None:
        return ()
    t = rec.stream_a.timestamps_s
    return float(t[rec.change_row - 1]), float(t[rec.change_row])


def _true_step(rec: Recording) -> tuple:
    """``(at_a_s, size_s)`` of the true clock step of b (``at_a_s``: the instant, clock a,
    of b's first pose after it), or ()."""
    return () if rec.step_at_s is None else (rec.step_at_s, rec.step_s)


def evaluate(rec: Recording, workdir) -> Outcome:
    """Write ``rec`` as TUM files into ``workdir``, calibrate them with the ``calibrate``
    COMMAND (its defaults; ``recording=false``) and compare with the truth and with
    :func:`park_baseline`."""
    work = Path(workdir)
    paths = write_tum(rec, work)
    park_err = _park_errors(rec, False)
    oracle = (_park_errors(rec, True) if rec.outliers_a.any() or rec.outliers_b.any()
              else (math.nan, math.nan))
    t0 = time.perf_counter()
    code, message = _run_cli(paths, work / "out")
    runtime = time.perf_counter() - t0
    base = Outcome(rec.kind, rec.seed, code, runtime, park_rot_error_deg=park_err[0],
                   park_trans_error_mm=park_err[1], park_oracle_rot_error_deg=oracle[0],
                   park_oracle_trans_error_mm=oracle[1], message=message,
                   true_change_s=_true_change_s(rec), true_step=_true_step(rec))
    cal = work / "out" / "calibration.json"
    if code not in (0, 5, 6) or not cal.is_file():
        return base
    report = json.loads(cal.read_text())
    with np.load(work / "out" / "motions.npz") as z:
        motions = {k: z[k] for k in z.files}
    X = np.asarray(report["X"]["T_a_b"])
    conv, off = report["conventions"], report["time_offset"]
    reading_ok = (conv["invert_a"] == rec.invert_a and conv["invert_b"] == rec.invert_b
                  and conv["swap_scalar_a"] == rec.scalar_first_a
                  and conv["swap_scalar_b"] == rec.scalar_first_b)
    off_err = math.nan
    if offset_checked(KINDS[rec.kind]):
        est = off["offset_s"] + (off["drift"] or 0.0) * (rec.t_ref_s - (off["t_ref_s"] or 0.0))
        off_err = 1e3 * (est - float(rec.offset_at(rec.t_ref_s)))
    precision, recall = _inlier_scores(rec, report, motions)
    dirs = _reported_directions(report)
    return replace(base, rot_error_deg=math.degrees(float(rotation_error_rad(X, rec.X_true))),
                   trans_error_mm=1e3 * translation_error_determined(X, rec),
                   offset_error_ms=off_err, reading_ok=bool(reading_ok),
                   precision=precision, recall=recall, undetermined_dirs_a=dirs,
                   undetermined_flagged=undetermined_covered(dirs, rec.undetermined_a),
                   mount_change_s=tuple((report.get("mount_change") or {}).get("between_s",
                                                                                ())),
                   steps=tuple((st["at_a_s"], st["size_s"]) for st in off.get("steps") or ()))


# ----------------------------------------------------------------------------- table
def _failure_counts(outcomes) -> str:
    counts: dict = {}
    for o in outcomes:
        for f in acceptance_failures(o):
            counts[f] = counts.get(f, 0) + 1
    return ", ".join(f"{k} {v}/{len(outcomes)}" for k, v in counts.items()) or "pass"


def _stat(values, how) -> float:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    return float(how(v)) if v.size else math.nan


def _fmt(x, digits=3) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def summarise(outcomes: list[Outcome]) -> list[dict]:
    """One row per kind: median / max errors of the calibration and of Park, offset
    error, share of seeds read right, mean inlier precision / recall, exit codes, time."""
    rows = []
    for kind in dict.fromkeys(o.kind for o in outcomes):
        os_ = [o for o in outcomes if o.kind == kind]
        codes = {}
        for o in os_:
            codes[o.exit_code] = codes.get(o.exit_code, 0) + 1
        read = [o.reading_ok for o in os_ if o.reading_ok is not None]
        rows.append({
            "kind": kind, "runs": len(os_),
            "exit_codes": ", ".join(f"{c}:{n}" for c, n in sorted(codes.items())),
            "rot_med_deg": _stat([o.rot_error_deg for o in os_], np.median),
            "rot_max_deg": _stat([o.rot_error_deg for o in os_], np.max),
            "trans_med_mm": _stat([o.trans_error_mm for o in os_], np.median),
            "trans_max_mm": _stat([o.trans_error_mm for o in os_], np.max),
            "park_rot_med_deg": _stat([o.park_rot_error_deg for o in os_], np.median),
            "park_rot_max_deg": _stat([o.park_rot_error_deg for o in os_], np.max),
            "park_trans_med_mm": _stat([o.park_trans_error_mm for o in os_], np.median),
            "park_trans_max_mm": _stat([o.park_trans_error_mm for o in os_], np.max),
            "oracle_rot_med_deg": _stat([o.park_oracle_rot_error_deg for o in os_],
                                        np.median),
            "oracle_trans_med_mm": _stat([o.park_oracle_trans_error_mm for o in os_],
                                         np.median),
            "offset_med_ms": _stat([abs(o.offset_error_ms) for o in os_], np.median),
            "offset_max_ms": _stat([abs(o.offset_error_ms) for o in os_], np.max),
            "reading_ok": ("n/a" if KINDS[kind].expect == "data_error"
                           else f"{sum(read)}/{len(os_)}"),
            "precision": _stat([o.precision for o in os_], np.mean),
            "recall": _stat([o.recall for o in os_], np.mean),
            "time_med_s": _stat([o.runtime_s for o in os_], np.median),
            "acceptance": _failure_counts(os_),
        })
    return rows


def _own_tolerances() -> str:
    """`` (kind: N ms, ...)`` for the kinds with their own offset tolerance."""
    own = [f"{k}: {v.offset_tol_ms:g} ms" for k, v in KINDS.items()
           if v.offset_tol_ms is not None]
    return f" ({', '.join(own)})" if own else ""


def _acceptance_text() -> str:
    """The table's acceptance paragraph (the checks of :func:`acceptance_failures`)."""
    return (
        "Acceptance (tests/test_studies_experiments_recordings.py): errors <= "
        f"max({PARK_FACTOR:g} x Park's, {ROT_FLOOR_DEG:g} deg / {TRANS_FLOOR_MM:g} mm) "
        "(kinds with outliers: also vs Park on the inlier poses), |offset error| <= "
        f"{OFFSET_TOL_MS:g} ms{_own_tolerances()}, the right reading, exit 0 or 6 (6 and "
        "the undetermined direction flagged for planar / scara; exit 3 for no_motion_b), "
        f"inlier precision >= {MIN_PRECISION:g} and recall >= {MIN_RECALL:g} for "
        "outliers, a change of X (bumped_camera) told between the two stations either "
        "side of it and none where X never changed, a clock step of b (clock_step) told "
        f"as one step of its size within {OFFSET_TOL_MS:g} ms at b's first pose after it "
        f"(within {1e3 * STEP_TOL_S:g} ms) and none where the clock never steps. With "
        "rotations about one axis only (scara, planar) Park's rotation step is "
        "rank-deficient and its translation solve ill-conditioned, so the Park bar is "
        "loose there.")


def markdown(rows: list[dict], outcomes: list[Outcome], command: str) -> str:
    """The markdown report: the per-kind table, then the failed runs' messages."""
    head = ["kind", "runs", "exit codes (code:count)", "rot med / max (deg)",
            "trans med / max (mm)", "Park rot med / max (deg)", "Park trans med / max (mm)",
            "Park on inlier poses rot / trans med (deg / mm)",
            "|offset err| med / max (ms)", "reading right (seeds)", "inlier precision",
            "inlier recall", "time med (s)", "acceptance fails (seeds)"]
    lines = [
        "# Benchmark recordings: calibrate defaults vs OpenCV Park",
        "",
        f"Generated by `{command}` (simcalib/studies/experiments/recordings.py). "
        "Every kind x seed is written as TUM files and calibrated by the `calibrate` "
        "command with its defaults (offset estimated, reading detected, RANSAC). Park is "
        "OpenCV's `calibrateHandEye(..., CALIB_HAND_EYE_PARK)` given the TRUE clock offset "
        "and the TRUE reading on the synchronised poses (continuous kinds: b interpolated at "
        f"a's shifted stamps, subsampled to <= {PARK_MAX_POSES} poses, all i<j pairs); Park "
        "gets NO outlier rejection. 'Park on inlier poses' is Park on the instants that use "
        "no outlier pose, by the TRUE masks: Park without rejection is no bar for the "
        "outlier kinds, so they are also held to this one. Errors are against the true X; "
        "for planar / scara the translation error leaves out the undetermined direction. "
        "Offset error where the data determine the offset (continuous kinds) or the kind "
        "states a tolerance. Inlier precision / recall (means over seeds): inlier motions vs "
        "the motions that touch no outlier pose. Exit codes: 0 determined, 6 degenerate, "
        "3 data error, 5 solver failed, 1 crash; errors are over the runs that gave an "
        "estimate.",
        "",
        _acceptance_text(),
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in rows:
        lines.append("| " + " | ".join([
            r["kind"], str(r["runs"]), r["exit_codes"],
            f"{_fmt(r['rot_med_deg'])} / {_fmt(r['rot_max_deg'])}",
            f"{_fmt(r['trans_med_mm'])} / {_fmt(r['trans_max_mm'])}",
            f"{_fmt(r['park_rot_med_deg'])} / {_fmt(r['park_rot_max_deg'])}",
            f"{_fmt(r['park_trans_med_mm'])} / {_fmt(r['park_trans_max_mm'])}",
            f"{_fmt(r['oracle_rot_med_deg'])} / {_fmt(r['oracle_trans_med_mm'])}",
            f"{_fmt(r['offset_med_ms'])} / {_fmt(r['offset_max_ms'])}",
            r["reading_ok"], _fmt(r["precision"]), _fmt(r["recall"]),
            _fmt(r["time_med_s"], 2), r["acceptance"]]) + " |")
    lines += ["", "Kinds:", ""]
    for name in dict.fromkeys(o.kind for o in outcomes):
        lines.append(f"* `{name}`: {KINDS[name].description} (expected: "
                     f"{KINDS[name].expect})")
    failed = [o for o in outcomes if o.exit_code not in (0, 6)]
    if failed:
        lines += ["", "Runs without an estimate (exit code: the command's error; `<dir>` is the "
                  "run's folder):", ""]
        lines += [f"* {o.kind} seed {o.seed}: exit {o.exit_code}: {o.message}" for o in failed]
    return "\n".join(lines) + "\n"


def run_all(kinds, seeds: int, workdir=None, log=None) -> list[Outcome]:
    """:func:`evaluate` for every kind x seed ``0..seeds-1`` (outputs in ``workdir`` or a
    temporary directory)."""
    outcomes = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(workdir) if workdir is not None else Path(tmp)
        for kind in kinds:
            for seed in range(seeds):
                o = evaluate(generate(kind, seed), root / kind / str(seed))
                if log is not None:
                    log(f"{kind} seed {seed}: exit {o.exit_code}, rot {_fmt(o.rot_error_deg)}"
                        f" deg, trans {_fmt(o.trans_error_mm)} mm (Park "
                        f"{_fmt(o.park_rot_error_deg)} / {_fmt(o.park_trans_error_mm)}), "
                        f"offset err {_fmt(o.offset_error_ms)} ms, {o.runtime_s:.1f} s"
                        + (f": {o.message}" if o.message else ""))
                outcomes.append(o)
    return outcomes


# -------------------------------------------------------------------- experiment API
@dataclass(frozen=True)
class RecordingsConfig:
    """``python -m simcalib experiment recordings kinds=[...] seeds=N output=DIR``."""
    kinds: tuple[str, ...] = tuple(KINDS)
    seeds: int = 3
    output: str = "results/recordings"

    def __post_init__(self):
        from simcalib.config.checks import check_int, check_names, set_fields
        set_fields(self, kinds=check_names("kinds", self.kinds, tuple(KINDS)),
                   seeds=check_int("seeds", self.seeds, lo=1))


@experiment('recordings', config=RecordingsConfig,
            description='benchmark recordings calibrate has never seen, defaults vs a classic solver')
def run(cfg: RecordingsConfig):
    """Run the comparison; writes ``recordings.md`` and ``recordings.csv`` into
    ``cfg.output``."""
    from simcalib.studies.experiments import common
    t0 = time.perf_counter()
    out = common.output_dir(cfg.output)
    outcomes = run_all(cfg.kinds, cfg.seeds, workdir=out / "runs")
    rows = summarise(outcomes)
    md = out / "recordings.md"
    md.write_text(markdown(rows, outcomes, "python -m simcalib experiment recordings "
                           f"kinds=[{','.join(cfg.kinds)}] seeds={cfg.seeds}"))
    csv = common.write_csv(out / "recordings.csv", rows, list(rows[0]))
    return common.ExperimentResult("recordings", out, {"md": md, "csv": csv}, rows,
                                   time.perf_counter() - t0)


def main(argv=None) -> int:
    """``python -m simcalib.studies.experiments.recordings [--kinds K ...] [--seeds N]
    [--output FILE.md]``: print (and write) the table. Returns 0, or 2 for bad arguments."""
    p = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.recordings",
                                description="calibrate defaults vs OpenCV Park on generated "
                                "recordings of many kinds")
    p.add_argument("--kinds", nargs="+", default=list(KINDS), metavar="KIND",
                   help="kinds to run (default: all): " + ", ".join(KINDS))
    p.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 per kind (default 3)")
    p.add_argument("--output", type=Path, default=None, help="also write the markdown here")
    p.add_argument("--workdir", type=Path, default=None,
                   help="keep the TUM files and outputs here (default: a temporary folder)")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    bad = [k for k in args.kinds if k not in KINDS]
    if bad or args.seeds < 1:
        print(f"error: unknown kind(s) {', '.join(bad)}; valid: {', '.join(KINDS)}" if bad
              else f"error: --seeds must be >= 1; received {args.seeds}", file=sys.stderr)
        return 2
    outcomes = run_all(args.kinds, args.seeds, args.workdir,
                       log=lambda s: print(s, file=sys.stderr, flush=True))
    argv_shown = " ".join(sys.argv[1:] if argv is None else list(argv))
    text = markdown(summarise(outcomes), outcomes,
                    f"python -m simcalib.studies.experiments.recordings {argv_shown}".strip())
    print(text)
    if args.output is not None:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
