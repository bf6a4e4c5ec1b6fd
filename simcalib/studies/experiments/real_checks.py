"""What the real-data table checks on each set: the calibration with the ``calibrate``
defaults (:func:`run_set`) with OpenCV PARK / TSAI beside it, its error and NEES against the
reference (:func:`nees`: pseudo-inverse on the axes whose reported variance is finite,
restricted to the components the reference pins), the tolerance and flag checks, the
agreement of sets sharing a mount, and the summary.
"""

from __future__ import annotations

import functools
import math
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.studies.experiments.real_sets import (AGREEMENT_SIGMA, ALL_AXES, CROSS_SET_PAIRS,
                                                    LOOPS, OPENCV_MAX_POSES, RealSet, Reference,
                                                    RequiredFlag, STATED_AGREEMENT, load_reference,
                                                    reference_tolerance, set_by_name, set_paths)
from simcalib.studies.experiments.real_sets import _opencv

__all__ = ["Nees", "chi2_bound_95", "nees", "FlaggedDirection", "MethodResult", "SetResult",
           "subsample_indices", "opencv_estimates", "run_set", "reference_accuracy",
           "tolerance_check", "method_within_tolerance", "flag_check", "Agreement",
           "agreement", "loop_agreement", "propagate_covariance", "Summary", "summarise"]


# ------------------------------------------------------------------------------- NEES
@dataclass(frozen=True)
class Nees:
    """``value = e^T S^+ e`` over ``axes`` (the components used), ``dof`` the rank of ``S``
    there, ``bound_95`` the chi-square(dof) 95 % quantile."""
    value: float
    dof: int
    bound_95: float
    axes: tuple

    @property
    def within(self) -> bool:
        return self.dof > 0 and self.value <= self.bound_95


@functools.lru_cache(maxsize=None)
def chi2_bound_95(dof: int) -> float:
    """The chi-square(dof) 95 % quantile (12.59 for 6); NaN for 0 dof."""
    from scipy.special import chdtri
    return float(chdtri(dof, 0.05)) if dof > 0 else float("nan")


def _as_covariance(cov) -> np.ndarray:
    a = np.array([[np.inf if x is None else float(x) for x in row] for row in cov],
                 dtype=np.float64)
    if a.shape != (6, 6):
        raise ValueError(f"covariance must be 6x6; received shape {a.shape}")
    return a


def nees(error, covariance, axes=ALL_AXES, extra_covariance=None,
         rel_tol: float = 1e-12) -> Nees | None:
    """NEES of the 6-vector ``error`` (order of :func:`pose_error`) against ``covariance``
    (6x6; None / inf / nan entries mark undetermined axes): only the axes whose variance is
    finite and that ``axes`` selects are used; on them ``S`` (+ ``extra_covariance``, e.g.
    the reference's own) is pseudo-inverted (eigenvalues below ``rel_tol`` times the largest
    dropped) and ``dof`` is its rank. None when no covariance."""
    if covariance is None:
        return None
    e = np.asarray(error, dtype=np.float64).reshape(6)
    S = _as_covariance(covariance)
    use = np.isfinite(np.diag(S)) & np.asarray(axes, dtype=bool)
    idx = np.flatnonzero(use)
    if idx.size == 0:
        return Nees(float("nan"), 0, float("nan"), ())
    Ss = S[np.ix_(idx, idx)]
    if not np.isfinite(Ss).all():
        raise ValueError("covariance has non-finite entries between axes of finite variance")
    if extra_covariance is not None:
        Ss = Ss + np.asarray(extra_covariance, dtype=np.float64)[np.ix_(idx, idx)]
    lam, V = np.linalg.eigh(0.5 * (Ss + Ss.T))
    keep = lam > rel_tol * max(lam[-1], 0.0)
    if not keep.any():
        return Nees(float("nan"), 0, float("nan"), tuple(int(i) for i in idx))
    c = V[:, keep].T @ e[idx]
    value = float(np.sum(c * c / lam[keep]))
    dof = int(keep.sum())
    return Nees(value, dof, chi2_bound_95(dof), tuple(int(i) for i in idx))


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class FlaggedDirection:
    reason: str
    kind: str
    rotation_axis_a: tuple
    translation_dir_a: tuple
    description: str


@dataclass(frozen=True, eq=False)
class MethodResult:
    """An OpenCV estimate on the calibration's synchronised poses (``X`` None: failed)."""
    method: str
    X: np.ndarray | None
    rotation_error_deg: float | None
    translation_error_mm: float | None
    poses_used: int
    message: str = ""
    rotation_diff_deg: float | None = None       # vs simcalib's X (all sets)
    translation_diff_mm: float | None = None


@dataclass(frozen=True, eq=False)
class SetResult:
    """One set calibrated with the defaults. ``exit_code``: the command's status (0, 6;
    3 / 5 / 1 when it raised, ``error`` then holds the message). ``covariance``: the
    reported 6x6 (inf on undetermined axes). Errors vs the reference: ``pose_error``
    (rotation norm; translation norm over the reference's valid axes)."""
    name: str
    exit_code: int
    status: str
    error: str
    wall_time_s: float
    X: np.ndarray | None = None
    covariance: np.ndarray | None = None
    std_rot_deg: tuple | None = None
    std_trans_mm: tuple | None = None
    verdict: str = ""
    flagged: tuple = ()
    offset_s: float | None = None
    offset_sigma_s: float | None = None
    n_inliers: int | None = None
    n_motions: int | None = None
    reference: Reference | None = None
    error_vector: np.ndarray | None = None
    rotation_error_deg: float | None = None
    translation_error_mm: float | None = None
    nees: Nees | None = None
    nees_with_reference: Nees | None = None
    park: MethodResult | None = None
    tsai: MethodResult | None = None
    #: the reference-free split-half check (X of the recording's first half against its
    #: second, :class:`simcalib.estimation.consistency.SplitCheck`) as a :class:`Nees`
    split: "Nees | None" = None
    #: b's length scale against a's from the motions' screw pitch (1 in equal units;
    #: :func:`simcalib.estimation.units.pitch_scale`)
    length_scale: float | None = None

    @property
    def ran(self) -> bool:
        return self.exit_code in (0, 6)

    @property
    def nees_target(self) -> Nees | None:
        """The NEES the 80 % target uses: with the reference's own accuracy added
        (:func:`reference_accuracy`) where it has one."""
        return self.nees_with_reference if self.nees_with_reference is not None else self.nees


def _reference_errors(ref: Reference, X, entry: RealSet):
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    e = pose_error(ref.T_a_b, X)
    axes = entry.tolerance.translation_axes if entry.tolerance is not None else (True,) * 3
    trans = e[3:][np.asarray(axes, dtype=bool)]
    return e, math.degrees(float(np.linalg.norm(e[:3]))), 1e3 * float(np.linalg.norm(trans))



def subsample_indices(n: int, max_poses: int = OPENCV_MAX_POSES) -> np.ndarray:
    """At most ``max_poses`` indices of ``n``, evenly spread (deterministic)."""
    if n <= max_poses:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_poses).round().astype(int))


def opencv_estimates(T_a, T_b, ref: Reference | None, entry: RealSet,
                     X_estimate=None) -> tuple:
    """PARK and TSAI on the synchronised poses (at most :data:`OPENCV_MAX_POSES`, evenly
    spread: OpenCV pairs all i<j), their errors vs ``ref`` and their differences from
    ``X_estimate`` (simcalib's X)."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    k = subsample_indices(T_a.shape[0])
    out = []
    for name, const in (("PARK", "CALIB_HAND_EYE_PARK"), ("TSAI", "CALIB_HAND_EYE_TSAI")):
        X = _opencv(T_a[k], T_b[k], const) if k.size >= 3 else None
        rot = trans = d_rot = d_trans = None
        if X is not None and ref is not None:
            _, rot, trans = _reference_errors(ref, X, entry)
        if X is not None and X_estimate is not None:
            d = pose_error(X, X_estimate)
            d_rot = math.degrees(float(np.linalg.norm(d[:3])))
            d_trans = 1e3 * float(np.linalg.norm(d[3:]))
        out.append(MethodResult(name, X, rot, trans, int(k.size),
                                "" if X is not None else "cv2.calibrateHandEye failed",
                                d_rot, d_trans))
    return tuple(out)


def _flagged(solution, assessment=None) -> tuple:
    """The verdict's flagged directions (the assessment's; without one, the solver's)."""
    dirs = getattr(assessment, "directions", None)
    if dirs is None:
        unc = None if solution is None else solution.uncertainty
        dirs = () if unc is None else unc.directions
    return tuple(FlaggedDirection(d.reason, d.kind, tuple(map(float, d.rotation_axis_a)),
                                  tuple(map(float, d.translation_dir_a)), d.description)
                 for d in dirs)


def _calibrate(entry: RealSet, pa: Path, pb: Path, out: Path):
    from simcalib.pipeline.calibrate import calibrate, parse_options
    from simcalib.report.calibration import report_dict
    opts = parse_options([f"a={pa}", f"b={pb}", f"output={out}", "recording=false"])
    r, a = calibrate(opts)
    return r, a, report_dict(opts, r, a)


def _failed(entry, code, msg, wall, ref) -> SetResult:
    return SetResult(entry.name, code, "error", msg, wall, reference=ref)


def run_set(entry: RealSet, *, cache_dir=None) -> SetResult:
    """Calibrate ``entry`` with the ``calibrate`` defaults (library, outputs in a temporary
    folder, ``recording=false``) and evaluate it (:class:`SetResult`). An error of the
    calibration is recorded (its exit code and message), not raised; missing data raise
    :class:`DataError`."""
    from simcalib.errors import exit_code
    pa, pb = set_paths(entry, cache_dir)
    ref = load_reference(entry, (pa, pb))
    with tempfile.TemporaryDirectory(prefix=f"simcalib_real_{entry.name}_") as tmp:
        t0 = time.perf_counter()
        try:
            r, a, rep = _calibrate(entry, pa, pb, Path(tmp) / "out")
        except Exception as exc:  # noqa: BLE001 - recorded: refusals and crashes are results
            wall = time.perf_counter() - t0
            return _failed(entry, exit_code(exc), f"{type(exc).__name__}: {exc}", wall, ref)
        wall = time.perf_counter() - t0
    return _evaluate(entry, r, a, rep, ref, wall)


def _mm(v):
    return None if v is None else tuple(None if x is None else 1e3 * x for x in v)


def reference_accuracy(entry: RealSet, ref: Reference | None) -> np.ndarray | None:
    """The reference's own error as a 6x6 covariance (order of :func:`pose_error`): its
    stated spread where it states one (crwhe); otherwise the README's "correct" tolerance
    read as the 95 % bound of the reference's error norm (per-axis sigma = tolerance /
    sqrt(chi2_3(0.95)) = tolerance / 2.80); an axis without a tolerance gets none (it is
    not compared). None without a reference or a tolerance."""
    if ref is None:
        return None
    if ref.covariance is not None:
        return ref.covariance
    tol = entry.tolerance
    if tol is None or (tol.rotation_deg is None and tol.translation_m is None):
        return None
    k = math.sqrt(chi2_bound_95(3))
    var_r = 0.0 if tol.rotation_deg is None else (math.radians(tol.rotation_deg) / k) ** 2
    var_t = 0.0 if tol.translation_m is None else (tol.translation_m / k) ** 2
    return np.diag([var_r] * 3 + [var_t] * 3)


def _evaluate(entry, r, a, rep, ref, wall) -> SetResult:
    from simcalib.estimation.world_jumps import largest_world
    X = np.asarray(rep["X"]["T_a_b"], dtype=np.float64)
    cov = None if a.covariance is None else _as_covariance(a.covariance)
    e = rot = trans = n0 = n1 = None
    if ref is not None:
        e, rot, trans = _reference_errors(ref, X, entry)
        n0 = nees(e, cov, entry.nees_axes)
        acc = reference_accuracy(entry, ref)
        if acc is not None:
            n1 = nees(e, cov, entry.nees_axes, extra_covariance=acc)
    one = largest_world(r.synced)           # OpenCV pairs all poses: one world's
    park, tsai = opencv_estimates(np.asarray(r.synced.T_a)[one], np.asarray(r.synced.T_b)[one],
                                  ref, entry, X)
    off, inl = rep["time_offset"], rep["inliers"]
    sc = getattr(r.consistency, "split", None)
    split = None if sc is None else Nees(sc.nees, sc.dof, sc.bound, ())
    return SetResult(
        entry.name, int(rep["exit_code"]), rep["status"], "", wall, X, cov, a.std_rot_deg,
        _mm(a.std_trans_m), a.verdict, _flagged(r.robust.solution, a), off["offset_s"],
        off["uncertainty_s"], inl["n_inliers"], inl["n_motions"], ref, e, rot, trans, n0, n1,
        park, tsai, split, length_scale=r.summary["length_scale"])


# ----------------------------------------------------------------------------- checks
def tolerance_check(entry: RealSet, res: SetResult) -> tuple[bool, str]:
    """``(ok, why)``: X within the README's tolerance of the reference, or consistent with
    it within both uncertainties (the NEES with the reference's own accuracy within its
    95 % bound: the reported sigma covers the difference); and the offset within its
    tolerance where one is expected. ``ok`` is True when nothing is to check."""
    if not res.ran:
        return False, f"exit {res.exit_code}: {res.error}"
    why = []
    rot_tol, trans_tol = reference_tolerance(entry, res.reference)
    if res.reference is not None:
        if rot_tol is not None and res.rotation_error_deg > rot_tol:
            why.append(f"rotation error {res.rotation_error_deg:.3f} deg > {rot_tol:g} deg")
        waived = entry.tolerance.waive_translation_if_flagged and any(
            f.kind in ("translation", "coupled") for f in res.flagged)
        if trans_tol is not None and not waived and res.translation_error_mm > 1e3 * trans_tol:
            why.append(f"translation error {res.translation_error_mm:.1f} mm > "
                       f"{1e3 * trans_tol:g} mm")
    consistent = (res.nees_with_reference is not None and res.nees_with_reference.within)
    if why and consistent:      # not within the tolerance, but the sigma covers the gap
        why = []
    tol = entry.tolerance
    if tol is not None and tol.offset_s is not None:
        if abs(res.offset_s - tol.offset_s) > tol.offset_tolerance_s:
            why.append(f"offset {1e3 * res.offset_s:.1f} ms, expected {1e3 * tol.offset_s:.0f}"
                       f" +- {1e3 * tol.offset_tolerance_s:.0f} ms")
    return not why, "; ".join(why)


def method_within_tolerance(entry: RealSet, res: SetResult, method: str) -> bool:
    """OpenCV ``method`` (``park`` / ``tsai``) on the same synchronised poses within the
    README's X tolerance (a baseline: no flags, no offset)."""
    m = getattr(res, method)
    if m is None or m.rotation_error_deg is None:
        return False
    rot_tol, trans_tol = reference_tolerance(entry, res.reference)
    return ((rot_tol is None or m.rotation_error_deg <= rot_tol)
            and (trans_tol is None or m.translation_error_mm <= 1e3 * trans_tol))


def _matches(req: RequiredFlag, f: FlaggedDirection) -> bool:
    if f.reason not in req.reasons:
        return False
    v = np.asarray(f.translation_dir_a if req.kind == "translation" else f.rotation_axis_a)
    return abs(float(v @ np.asarray(req.axis_a))) >= req.min_cos


def flag_check(entry: RealSet, res: SetResult) -> tuple[bool, str]:
    """``(ok, why)``: every required direction is among the flagged ones."""
    if not res.ran:
        return False, f"exit {res.exit_code}: {res.error}"
    missing = [q.text for q in entry.required_flags
               if not any(_matches(q, f) for f in res.flagged)]
    got = "; ".join(f"{f.reason}: {f.description}" for f in res.flagged) or "none"
    return not missing, ("" if not missing else
                         f"not flagged: {', '.join(missing)} (flagged: {got}; verdict "
                         f"{res.verdict})")


@dataclass(frozen=True, eq=False)
class Agreement:
    """Difference ``pose_error(X_1, X_2)`` (or of a loop) against the combined reported
    covariance: ``ratio`` = |difference| / combined sigma per axis (–: undetermined),
    ``ok``: every finite ratio within :data:`AGREEMENT_SIGMA`; ``nees`` over the finite axes."""
    names: tuple
    difference: np.ndarray | None
    ratio: np.ndarray | None
    nees: Nees | None
    ok: bool
    message: str


def _combined(covs) -> np.ndarray | None:
    if any(c is None for c in covs):
        return None
    return np.sum([np.where(np.isfinite(c), c, np.inf) for c in covs], axis=0)


def _agreement_from(names, d, S) -> Agreement:
    if S is None:
        return Agreement(names, d, None, None, False, "no covariance")
    sig = np.sqrt(np.diag(S))
    ratio = np.where(np.isfinite(sig), np.abs(d) / sig, np.nan)
    fin = np.isfinite(ratio)
    ok = bool(fin.any() and np.all(ratio[fin] <= AGREEMENT_SIGMA))
    return Agreement(names, d, ratio, nees(d, S), ok,
                     f"max |diff| / sigma {np.nanmax(ratio) if fin.any() else float('nan'):.2f}"
                     f" over {int(fin.sum())} axes")


def agreement(r1: SetResult, r2: SetResult) -> Agreement:
    """The two X of sets sharing a mount, against their combined covariance plus how well
    the READMEs say the mounts agree (:data:`STATED_AGREEMENT`)."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    names = (r1.name, r2.name)
    if not (r1.ran and r2.ran):
        return Agreement(names, None, None, None, False,
                         f"{r1.name} exit {r1.exit_code}, {r2.name} exit {r2.exit_code}")
    covs = [r1.covariance, r2.covariance]
    stated = STATED_AGREEMENT.get(names)
    if stated is not None:          # the mounts are known to agree only this well
        k = math.sqrt(chi2_bound_95(3))
        covs.append(np.diag([(math.radians(stated[0]) / k) ** 2] * 3
                            + [(stated[1] / k) ** 2] * 3))
    return _agreement_from(names, pose_error(r1.X, r2.X), _combined(covs))


def loop_agreement(r_ab: SetResult, r_bc: SetResult, r_ac: SetResult) -> Agreement:
    """``X_ac`` vs ``X_ab X_bc`` against the first-order covariance of the product plus
    ``Sigma_ac``. In :func:`pose_error`'s convention (rotation left-perturbed, translation
    added, frame a) an error ``(w1, v1)`` of ``X_ab`` moves the product by ``(w1, v1 -
    [R_ab t_bc]x w1)`` and an error ``(w2, v2)`` of ``X_bc`` (frame b) by ``(R_ab w2,
    R_ab v2)``."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    names = (r_ab.name, r_bc.name, r_ac.name)
    if not (r_ab.ran and r_bc.ran and r_ac.ran):
        return Agreement(names, None, None, None, False, "a set of the loop did not run")
    d = pose_error(r_ac.X, r_ab.X @ r_bc.X)
    if any(r.covariance is None for r in (r_ab, r_bc, r_ac)):
        return Agreement(names, d, None, None, False, "no covariance")
    from simcalib.geometry import skew_matrix
    R_ab, t_bc = r_ab.X[:3, :3], r_bc.X[:3, 3]
    J_ab = np.eye(6)
    J_ab[3:, :3] = -skew_matrix(R_ab @ t_bc)
    J_bc = np.zeros((6, 6))
    J_bc[:3, :3] = J_bc[3:, 3:] = R_ab
    S = (propagate_covariance(J_ab, r_ab.covariance) + propagate_covariance(J_bc, r_bc.covariance)
         + r_ac.covariance)
    return _agreement_from(names, d, S)


def propagate_covariance(J, S) -> np.ndarray:
    """``J S J^T`` where ``S`` may hold inf on undetermined axes: those axes' images
    (the rows of ``J`` that touch them) become inf, the rest is propagated normally."""
    S = np.asarray(S, dtype=np.float64)
    bad = ~np.isfinite(np.diag(S))
    out = J @ np.where(np.isfinite(S), S, 0.0) @ J.T
    if bad.any():
        touched = np.abs(J[:, bad]).sum(axis=1) > 1e-12
        out[touched, :] = 0.0
        out[:, touched] = 0.0
        out[touched, touched] = np.inf
    return out


# ---------------------------------------------------------------------------- summary
@dataclass(frozen=True)
class Summary:
    n_sets: int
    n_ran: int
    n_exit0: int
    n_exit6: int
    n_referenced: int
    n_within_reference: int
    n_nees_sets: int
    n_nees_within: int
    n_flags_required: int
    n_flags_ok: int
    n_offsets: int
    n_offsets_ok: int
    n_park_within: int
    n_tsai_within: int
    agreements: tuple
    loops: tuple
    n_strictly_within: int = 0      # within the tolerance itself (not only consistent)
    n_nees_plain_within: int = 0    # NEES with the estimate's covariance alone
    n_split_sets: int = 0           # sets whose two halves could be compared
    n_split_within: int = 0         # ... within the 95 % bound of their predicted difference
    length_scales: tuple = ()       # (min, max, count) of SetResult.length_scale, sets run

    @property
    def nees_share(self) -> float:
        return self.n_nees_within / self.n_nees_sets if self.n_nees_sets else float("nan")


def _pairs(results: dict, pairs) -> tuple:
    return tuple(agreement(results[a], results[b]) for a, b in pairs
                 if a in results and b in results)


def summarise(results: dict) -> Summary:
    """Counts over ``{name: SetResult}``."""
    ents = {n: set_by_name(n) for n in results}
    ran = [r for r in results.values() if r.ran]
    refd = [n for n, e in ents.items() if e.reference is not None]
    within = [n for n in refd if tolerance_check(ents[n], results[n])[0]]
    nsets = [n for n in refd if ents[n].independent_reference]
    nin = [n for n in nsets if results[n].nees_target is not None
           and results[n].nees_target.within]
    flg = [n for n, e in ents.items() if e.required_flags]
    offs = [n for n, e in ents.items() if e.tolerance is not None
            and e.tolerance.offset_s is not None]
    offs_ok = [n for n in offs if results[n].ran and abs(
        results[n].offset_s - ents[n].tolerance.offset_s) <= ents[n].tolerance.offset_tolerance_s]
    loops = tuple(loop_agreement(*(results[n] for n in lp)) for lp in LOOPS
                  if all(n in results for n in lp))
    return Summary(len(results), len(ran), sum(r.exit_code == 0 for r in ran),
                   sum(r.exit_code == 6 for r in ran), len(refd), len(within), len(nsets),
                   len(nin), len(flg), sum(flag_check(ents[n], results[n])[0] for n in flg),
                   len(offs), len(offs_ok),
                   sum(method_within_tolerance(ents[n], results[n], "park") for n in refd),
                   sum(method_within_tolerance(ents[n], results[n], "tsai") for n in refd),
                   _pairs(results, CROSS_SET_PAIRS), loops,
                   sum(_strictly_within(ents[n], results[n]) for n in refd),
                   sum(results[n].nees is not None and results[n].nees.within for n in nsets),
                   sum(r.split is not None for r in ran),
                   sum(r.split is not None and r.split.within for r in ran),
                   length_scales=_scale_range(ran))


def _scale_range(ran) -> tuple:
    s = [r.length_scale for r in ran if r.length_scale is not None
         and math.isfinite(r.length_scale)]
    return (min(s), max(s), len(s)) if s else ()


def _strictly_within(entry: RealSet, res: SetResult) -> bool:
    """X within the README's tolerance itself (rotation and the valid translation)."""
    if not res.ran or res.reference is None:
        return False
    rot_tol, trans_tol = reference_tolerance(entry, res.reference)
    return ((rot_tol is None or res.rotation_error_deg <= rot_tol)
            and (trans_tol is None or res.translation_error_mm <= 1e3 * trans_tol))
