"""A sensor moved on its mount half-way through a recording (a camera bumped, a loose
bracket that slipped): X itself changes at one instant, so each stretch of the recording
has its own X.

A world jump (:mod:`simcalib.estimation.world_jumps`) keeps one X on both sides of it;
this does not: without this check the station split took a bumped camera for a world jump
and RANSAC quietly kept one group's motions (``inliers per stretch: 0, 102``), and on a
continuous recording nothing named it (the consistency checks widened sigma, and the
reading was no longer told).

:func:`find_mount_change` looks for one instant that splits the synchronised poses into
two stretches, each of :data:`MIN_POSES` poses and :data:`MIN_MOTIONS` motions or more
(fewer: the data cannot tell, nothing is said). A split is a change of X when

* it explains the misfit: each stretch's own X (least squares on its motions, motions
  across the split left out, once more without those beyond 3x the median residual: bad
  poses) fits the motions :data:`MISFIT_GAIN` times better (median
  screw residual) than one X fitted to both stretches the same way, at the split or at
  the best split of the grid (:func:`_best_split`), and
* the two stretches' X's (RANSAC and dqopt on each stretch's motions) differ beyond
  their sigma: the NEES of their difference on the directions both determine is above
  the :data:`NEES_LEVEL` quantile of chi-square.

The splits tried: :data:`_GRID` even ones (every pose where there are fewer). Where the
best passes 0.9 of the gain, each side's X is fitted there and the split moved to the
instant (any: the misfit ratio is a poor locator) that puts the fewest motions on the
side whose X fits them worse (a motion across the split counts half). The path
(:func:`simcalib.estimation.path.calibrate_streams`) then marks the split as a jump of
both streams' worlds (motions only within a stretch: the reading, the offset and the
motions are formed again), reports the X of the stretch with more synchronised poses (the
better determined; a tie: the later, the mount as it is now) and the other stretch's X in
``calibration.json`` (``mount_change``), with one warning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["MountChange", "find_mount_change", "describe_split", "split_misfit",
           "on_world_edge", "mark_change", "kept_motions", "MIN_POSES", "MIN_MOTIONS",
           "MISFIT_GAIN", "NEES_LEVEL"]

#: each stretch of a split has at least this many synchronised poses ...
MIN_POSES = 8
#: ... and this many motions within it
MIN_MOTIONS = 12
#: the stretches' own X's fit this many times better (median screw residual) than one X
MISFIT_GAIN = 1.35
#: the two X's differ beyond this quantile of chi-square (their NEES)
NEES_LEVEL = 0.999
#: splits tried in the first round; motions per side fit; motions the misfit looks at
_GRID, _MAX_FIT, _MAX_RES = 20, 400, 3000
#: the best split of the grid is refined where its misfit ratio is this share of the gain
_REFINE = 0.9
#: the fits of the misfit ratio leave out motions this many times the median residual
_TRIM = 3.0


@dataclass(frozen=True, eq=False)
class MountChange:
    """A change of X at one instant (module doc). ``index``: the first synchronised
    instant of the second stretch; ``t_before_s`` / ``t_after_s``: the instants (clock a)
    either side; ``cut_s``: midway; ``misfit_ratio``; ``X`` (first, second stretch),
    ``covariances`` (6x6 each, the solver's model), ``nees`` / ``dof`` / ``bound`` of
    their difference; ``poses`` / ``motions`` per stretch; ``kept``: 0 or 1, the stretch
    whose X is reported."""
    index: int
    t_before_s: float
    t_after_s: float
    misfit_ratio: float
    X: tuple = field(repr=False)
    covariances: tuple = field(repr=False)
    nees: float = math.nan
    dof: int = 0
    bound: float = math.nan
    poses: tuple = (0, 0)
    motions: tuple = (0, 0)
    spans_s: tuple = ()

    @property
    def cut_s(self) -> float:
        return 0.5 * (self.t_before_s + self.t_after_s)

    @property
    def kept(self) -> int:
        return 0 if self.poses[0] > self.poses[1] else 1

    @property
    def apart(self) -> tuple[float, float]:
        """``(deg, mm)`` between the two stretches' X's."""
        from simcalib.geometry import rotation_error_rad
        X0, X1 = self.X
        return (math.degrees(float(rotation_error_rad(X0, X1))),
                1e3 * float(np.linalg.norm(X0[:3, 3] - X1[:3, 3])))

    @property
    def significant(self) -> bool:
        return self.misfit_ratio >= MISFIT_GAIN and self.nees > self.bound

    def to_dict(self) -> dict:
        from simcalib.geometry import quat_from_matrix, rotvec_from_matrix
        other = 1 - self.kept
        Xo, cov = self.X[other], self.covariances[other]
        std = np.full(6, np.nan) if cov is None else np.sqrt(np.clip(np.diag(cov), 0, None))
        deg, mm = self.apart
        return {"between_s": [self.t_before_s, self.t_after_s],
                "kept": ("first", "second")[self.kept],
                "poses": list(self.poses), "motions": list(self.motions),
                "stretches_s": [list(s) for s in self.spans_s],
                "apart_deg": deg, "apart_mm": mm, "misfit_ratio": self.misfit_ratio,
                "nees": self.nees, "dof": self.dof, "bound": self.bound,
                "X_other": {"t_m": Xo[:3, 3].tolist(),
                            "q_xyzw": quat_from_matrix(Xo[:3, :3]).tolist(),
                            "rotvec_deg": np.degrees(rotvec_from_matrix(Xo[:3, :3])).tolist(),
                            "std_rot_deg": _finite(np.degrees(std[:3])),
                            "std_trans_mm": _finite(1e3 * std[3:])}}

    def sentence(self, offset_s: float = 0.0) -> str:
        """The warning: when, how far apart, which X is reported and why, and how to
        calibrate the other (``offset_s``: b's clock minus a's)."""
        deg, mm = self.apart
        which = ("first", "second")[self.kept]
        other = 1 - self.kept
        (a0, a1) = self.spans_s[other]
        why = ("as many as the other's: the later, the mount as it is now"
               if self.poses[0] == self.poses[1] else "the better determined")
        return (f"X changes between the poses at t = {self.t_before_s:.3f} and "
                f"{self.t_after_s:.3f} s (a sensor moved on its mount, e.g. a bumped camera):"
                f" the two stretches' own X's are {deg:.2f} deg / {mm:.1f} mm apart (NEES "
                f"{self.nees:.3g} on {self.dof} dof, bound {self.bound:.3g}; one X fits "
                f"the motions {self.misfit_ratio:.2f}x worse than two, median screw "
                f"residual); X is the "
                f"{which} stretch's ({self.poses[self.kept]} of {sum(self.poses)} poses, "
                f"{why}), the other's is in "
                f"calibration.json mount_change.X_other; to calibrate the other stretch, "
                f"give only its poses: a's stamps {a0:.3f}..{a1:.3f} s, b's "
                f"{a0 + offset_s:.3f}..{a1 + offset_s:.3f} s (no motion across the change "
                "is used)")


def _finite(v) -> list:
    return [float(x) if math.isfinite(x) else None for x in v]


def _sub(idx: np.ndarray, m: int) -> np.ndarray:
    """At most ``m`` of ``idx``, evenly spread."""
    if idx.size <= m:
        return idx
    return idx[np.linspace(0, idx.size - 1, m).round().astype(np.int64)]


def _take(terms: tuple, idx: np.ndarray) -> tuple:
    return tuple(t[idx] for t in terms)


def _ls(C, H, alpha: float) -> np.ndarray:
    """X by least squares (dqopt) on all the motions ``C``, ``H``."""
    from simcalib.solvers.single import solve_single
    return solve_single(C, H, method="dqopt", alpha=alpha).X


def _fit(C, H, terms, idx: np.ndarray, m: int, alpha: float) -> np.ndarray:
    """X by least squares on at most ``m`` of the motions ``idx``, fitted once more
    without those whose screw residual is beyond :data:`_TRIM` times the median (bad
    poses would otherwise pull it: the misfit ratio reached 1.65 with no change on
    generated recordings with 5-20 % outlier poses). ``terms``: the motions'
    :func:`~simcalib.solvers.robust.screw_terms`."""
    from simcalib.solvers.robust import residuals_of_terms
    s = _sub(idx, m)
    X = _ls(C[s], H[s], alpha)
    r = residuals_of_terms(_take(terms, s), X, alpha)
    keep = s[r <= _TRIM * float(np.median(r))]
    return _ls(C[keep], H[keep], alpha) if keep.size >= 3 else X


def split_misfit(C, H, i, j, k: int, alpha: float, terms=None) -> float:
    """The median screw residual of the motions that do not cross instant ``k`` (motion
    from instant ``i`` to ``j``) under one X fitted to them all, over that under each
    side's own X (:func:`_fit`); NaN where a side has too few motions. ``terms``: the
    motions' :func:`~simcalib.solvers.robust.screw_terms` (computed when not given)."""
    from simcalib.solvers.robust import residuals_of_terms, screw_terms
    before, after = j < k, i >= k
    if int(before.sum()) < MIN_MOTIONS or int(after.sum()) < MIN_MOTIONS:
        return math.nan
    terms = screw_terms(C, H) if terms is None else terms
    use = np.flatnonzero(before | after)
    fits = [_fit(C, H, terms, use, 2 * _MAX_FIT, alpha)] + list(
        _side_fits(C, H, terms, i, j, k, alpha))
    look = _sub(use, _MAX_RES)
    at = _take(terms, look)
    one = residuals_of_terms(at, fits[0], alpha)
    own = np.where(before[look], residuals_of_terms(at, fits[1], alpha),
                   residuals_of_terms(at, fits[2], alpha))
    return float(np.median(one) / max(float(np.median(own)), 1e-12))


def _side_fits(C, H, terms, i, j, k: int, alpha: float) -> tuple:
    """Each side's own X at split ``k`` (:func:`_fit` on its motions)."""
    return tuple(_fit(C, H, terms, np.flatnonzero(side), _MAX_FIT, alpha)
                 for side in (j < k, i >= k))


def _refined(C, H, terms, i, j, k0: int, lo: int, hi: int, alpha: float) -> int:
    """The split in ``lo..hi`` that puts the fewest motions on the side whose X (each
    side's own at ``k0``) fits them worse, a motion across the split counting half (it fits
    neither: which X fits it less badly is a coin's toss); looked for on at most
    ``10 * _GRID`` even splits, then on every split between the best one's neighbours."""
    from simcalib.solvers.robust import residuals_of_terms
    X0, X1 = _side_fits(C, H, terms, i, j, k0, alpha)
    look = _sub(np.arange(C.shape[0]), 4 * _MAX_RES)
    at = _take(terms, look)
    second = residuals_of_terms(at, X1, alpha) < residuals_of_terms(at, X0, alpha)

    def best(ks):
        before = j[look][None, :] < ks[:, None]
        after = i[look][None, :] >= ks[:, None]
        cost = ((before & second).sum(1) + (after & ~second).sum(1)
                + 0.5 * (~(before | after)).sum(1))
        return int(np.argmin(cost))

    ks = np.unique(np.linspace(lo, hi, min(hi - lo + 1, 10 * _GRID)).round().astype(np.int64))
    at_k = best(ks)
    ks = np.arange(ks[max(at_k - 1, 0)], ks[min(at_k + 1, ks.size - 1)] + 1)
    return int(ks[best(ks)])


def _best_split(C, H, i, j, n: int, alpha: float) -> tuple[int, float] | None:
    """``(k, ratio)``: the split of the ``n`` instants with the largest
    :func:`split_misfit` on a grid, moved to the instant that parts the motions best
    (:func:`_refined`; only where the best passes 0.9 of the gain); ``ratio`` the larger
    of the grid's best and the ratio at ``k``. (At the instant itself the ratio can be
    small: where the stretches' own motions are all there is, e.g. stations split by a
    world jump, the shorter stretch holds a fifth of the motions and barely moves the
    median, while a split that mixes its poses with the other's shows the misfit.)"""
    lo, hi = MIN_POSES, n - MIN_POSES
    if hi < lo:
        return None
    from simcalib.solvers.robust import screw_terms
    terms = screw_terms(C, H)      # converted once for every fit and residual below
    grid = np.unique(np.linspace(lo, hi, min(_GRID, hi - lo + 1)).round().astype(np.int64))
    score = np.array([split_misfit(C, H, i, j, int(k), alpha, terms) for k in grid])
    if np.isnan(score).all():
        return None
    at = int(np.nanargmax(score))
    if score[at] < _REFINE * MISFIT_GAIN:
        return int(grid[at]), float(score[at])
    k = _refined(C, H, terms, i, j, int(grid[at]), lo, hi, alpha)
    ratio = split_misfit(C, H, i, j, k, alpha, terms)
    return k, float(np.nanmax([ratio, score[at]]))


def _stretch_fit(C, H, seed: int, alpha: float, method: str):
    """``(X, covariance_determined, basis)`` of one stretch's motions: RANSAC and
    ``method`` on its inliers (as the path's own fit)."""
    from simcalib.estimation.outliers import robust_fit
    rob, _ = robust_fit(C, H, "auto", alpha=alpha, method=method, seed=seed, options=None)
    u = rob.solution.uncertainty if rob.solution is not None else None
    if u is None:
        return rob.X, None, None
    return rob.X, np.asarray(u.covariance_determined), np.asarray(u.determined_basis)


def describe_split(synced, motions, k: int, ratio: float, *, alpha: float, method: str,
                   seed: int) -> MountChange | None:
    """The two stretches either side of instant ``k`` of ``synced`` (motions ``motions``:
    each stretch's own; ``ratio``: :func:`split_misfit`): their X's, the NEES of the
    difference on the directions both determine (the sum of their model covariances);
    None where a stretch has too few poses or motions."""
    from scipy.special import chdtri    # not scipy.stats: ~1 s of import per process
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    t = np.asarray(synced.time_s)
    sides = (motions.j < k, motions.i >= k)
    if not MIN_POSES <= k <= t.size - MIN_POSES or min(map(int, map(np.sum, sides))) < \
            MIN_MOTIONS:
        return None
    fits = [_stretch_fit(motions.C[s], motions.H[s], seed, alpha, method) for s in sides]
    nees, dof = math.nan, 0
    if all(f[1] is not None for f in fits):
        U, sv, _ = np.linalg.svd(fits[0][2] @ (fits[0][2].T @ fits[1][2]), full_matrices=False)
        B = U[:, sv > 0.5]
        d = pose_error(fits[0][0], fits[1][0])
        S = B.T @ (fits[0][1] + fits[1][1]) @ B
        c = B.T @ d
        nees = float(c @ np.linalg.lstsq(0.5 * (S + S.T), c, rcond=None)[0])
        dof = int(B.shape[1])
    return MountChange(int(k), float(t[k - 1]), float(t[k]), float(ratio),
                       (fits[0][0], fits[1][0]), (fits[0][1], fits[1][1]), nees, dof,
                       float(chdtri(max(dof, 1), 1.0 - NEES_LEVEL)), (int(k), int(t.size - k)),
                       tuple(int(s.sum()) for s in sides),
                       ((float(t[0]), float(t[k - 1])), (float(t[k]), float(t[-1]))))


def find_mount_change(synced, motions, *, alpha: float, method: str = "dqopt",
                      seed: int = 0) -> MountChange | None:
    """The change of X at one instant of the synchronised poses ``synced``
    (:class:`~simcalib.estimation.alignment.SyncedPoses`) told by their ``motions``
    (:class:`~simcalib.estimation.motions.MotionSet`), or None (module doc)."""
    if motions is None or motions.n < 2 * MIN_MOTIONS:
        return None
    best = _best_split(motions.C, motions.H, motions.i, motions.j, synced.n, alpha)
    if best is None or best[1] < MISFIT_GAIN:
        return None
    change = describe_split(synced, motions, best[0], best[1], alpha=alpha, method=method,
                            seed=seed)
    return change if change is not None and change.significant else None


def on_world_edge(synced, k: int) -> bool:
    """Instants ``k - 1`` and ``k`` of ``synced`` lie in different stretches of the worlds
    already (a world jump or a station split marked there)."""
    world = getattr(synced, "world", None)
    return world is not None and bool(world[k - 1] != world[k])


def mark_change(sa, sb, cut_s: float, shift_s: float):
    """Both streams with the change of X at ``cut_s`` (clock a; b's clock ``shift_s``
    later) marked as a jump of their worlds (``world_jumps_s``: motions only within a
    stretch)."""
    from dataclasses import replace
    out = []
    for s, shift in ((sa, 0.0), (sb, shift_s)):
        marks = tuple(sorted(set(s.world_jumps_s) | {float(cut_s + shift)}))
        out.append(replace(s, world_jumps_s=marks, repairs=dict(
            s.repairs, world_jumps=len(marks), world_stretches=len(marks) + 1)))
    return out[0], out[1]


def kept_motions(motions, change: MountChange) -> np.ndarray:
    """``(n,)`` bool: the motions within the stretch whose X is reported."""
    return motions.i >= change.index if change.kept else motions.j < change.index
