"""The clock offset refined by the calibration cost, and how far the data vouch for it.

:class:`OffsetCost` is the mean dqopt cost per motion of one fixed set of motions as a
function of the offset ``t_b - t_a``; ``_refine`` minimises it around a candidate
(a grid, then bounded Brent) and gives the curvature; ``_decide`` compares the best
candidate with offset 0; :func:`split_check` re-estimates the offset on contiguous parts of
the overlap and raises the curvature's sigma to the parts' spread where that spread is
beyond chance (the residuals of real recordings are neither white nor independent, and
the curvature alone treats them as if they were). Used by
:func:`simcalib.estimation.alignment.estimate_time_offset`.

Why motions of >= :data:`OFFSET_STEP_S`: a clock offset shifts both ends of a motion, so it
shows only through the CHANGE of the rig's velocity over the motion; over short motions
that change is small against the pose noise (a vehicle driving at a near-constant speed:
0.2 s motions left 8-10 ms of offset error on the planar benchmark recordings, 1 s motions
0.4 ms), and a direction the motion leaves free (a planar rig's vertical) absorbs more of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.errors import DataError
from simcalib.estimation.interpolation import interpolation_valid, max_hole_s, smooth_poses
from simcalib.estimation.speeds import NOISE_GAIN, above_noise
from simcalib.geometry import invert_transform, quat_from_matrix, rotation_angle_rad

__all__ = ["OffsetCost", "StillReference", "split_check", "SplitCheck", "EVIDENCE_MIN",
           "RESIDUALS_PER_MOTION", "OFFSET_STEP_S", "SPLIT_PARTS", "SPLIT_LEVEL", "MIN_TURNING",
           "MAX_SLIDES", "CLEAR_SIGMA_S", "NOISE_GAIN", "THIN_MIN", "THIN_MAX", "in_doubt",
           "both_translate", "clearer"]

#: ``n_eff ln(cost at 0 / cost at the estimate)`` above which an estimated offset is used
#: instead of 0 (the log-likelihood-ratio statistic of Gaussian residuals, ~chi2(1) when
#: there is no offset: 9 is a 3-sigma decision)
EVIDENCE_MIN = 9.0
#: independent residual components per motion in the cost (the screw residual of one
#: motion: 3 of rotation, 3 of translation): the cost's degrees of freedom are this many
#: per independent motion
RESIDUALS_PER_MOTION = 6
#: the motions of the offset cost span at least this long (s)
OFFSET_STEP_S = 1.0
#: at most this many contiguous parts of the overlap re-estimate the offset (split check)
SPLIT_PARTS = 4
#: the parts' spread raises the sigma when it exceeds this quantile of what chance gives
SPLIT_LEVEL = 0.95


#: the offset cost needs this many motions that turn (>= 1 deg) in the reference stream
MIN_TURNING = 8
#: bounds of :meth:`OffsetCost.thin_at`: the shared poses' noise at most doubles the
#: offset's variance (two motions a pose, fully adding up); the offset is not claimed
#: better known than from independent motions (the cancellation a smooth path gives the
#: pose noise is real, but stamp jitter and stretches that barely move do not cancel)
THIN_MIN = 1.0
THIN_MAX = 2.0
#: the step of the offset (s) over which the residuals' derivative is taken
SLOPE_STEP_S = 1e-4


class StillReference(DataError):
    """The reference stream does not turn between its samples (it moves only across its
    gaps): no offset can be told from the cost."""


class OffsetCost:
    """The mean dqopt cost per motion of ONE fixed set of motions as a function of the
    clock offset ``t_b - t_a``, for offsets in ``bracket`` (s).

    The motions span ``step_s`` between stamps of the slower ("reference") stream inside
    the overlap that every offset of the bracket keeps (and never across a gap of the other
    stream at any offset of the bracket), so the set does not change with the offset. Both
    streams are kernel-smoothed over ``smooth_s`` (:func:`smooth_poses`). Used are the
    motions that turn by >= 1 deg in the reference stream and, with ``robust``, the RANSAC
    inliers at the bracket's centre. ``part``: 0 / 1 keeps the first / second half of the
    reference stamps (the drift estimate), ``(k, K)`` the k-th of K equal parts (the split
    check). Raises DataError when the overlap is too short.
    """

    def __init__(self, ta, Ta, tb, Tb, bracket, *, step_s, alpha, smooth_s, robust=True,
                 part=None, n_grid=13, turning=True, jumps=None):
        self.alpha, self.step_s, self.smooth_s = alpha, step_s, smooth_s
        pa, pb = float(np.median(np.diff(ta))), float(np.median(np.diff(tb)))
        self.reference = "a" if pa >= pb else "b"
        slow = max(pa, pb)
        lo_o, hi_o = bracket
        margin = 5 * smooth_s + slow
        if self.reference == "a":
            own, T_own, self.t_other, self.T_other, gap = ta, Ta, tb, Tb, max_hole_s(tb)
            lo = max(ta[0], tb[0] - lo_o) + margin
            hi = min(ta[-1], tb[-1] - hi_o) - margin
        else:
            own, T_own, self.t_other, self.T_other, gap = tb, Tb, ta, Ta, max_hole_s(ta)
            lo = max(tb[0], ta[0] + hi_o) + margin
            hi = min(tb[-1], ta[-1] + lo_o) - margin
        if hi - lo < 4 * step_s:
            raise DataError(f"the streams overlap for only {max(hi - lo, 0):.3f} s at offsets "
                            f"{lo_o:.3f}..{hi_o:.3f} s; too short to refine the offset")
        keep = (own >= lo) & (own <= hi)
        if part is not None:
            k, parts = (part, 2) if isinstance(part, (int, np.integer)) else part
            edges = np.linspace(lo, hi, parts + 1)
            keep &= (own >= edges[k]) & ((own < edges[k + 1]) if k < parts - 1 else True)
        self.t_ref = own[keep]
        self.window = (float(self.t_ref[0]), float(self.t_ref[-1])) if keep.any() else (lo, hi)
        self.T_ref = smooth_poses(own, T_own, self.t_ref, smooth_s)
        self.q_other = quat_from_matrix(self.T_other[:, :3, :3])
        from simcalib.estimation.motions import span_pairs
        self.i, self.j = span_pairs(self.t_ref, step_s)
        grid = np.linspace(lo_o, hi_o, n_grid)
        valid = np.ones(self.t_ref.size, dtype=bool)
        for o in grid:
            valid &= interpolation_valid(self.t_other, self._query(o), gap)
        ok = valid[self.i] & valid[self.j]
        if jumps is not None:
            ok &= self._one_world(jumps, grid)
        moves, what, moved = self._moving(turning)
        self.mask = ok & moves
        centre, at_centre = 0.5 * (lo_o + hi_o), None
        if part is None:
            at_centre = self._refuse_still(moved, what, step_s,
                                           "rotation" if turning else "translation", centre)
        if self.mask.sum() < MIN_TURNING:
            self.mask, at_centre = ok, None
        if robust and self.mask.sum() >= 8:
            self._keep_inliers(centre, at_centre)
        self.n = int(self.mask.sum())
        self._thin: dict = {}

    def _moving(self, turning: bool) -> tuple[np.ndarray, str, np.ndarray]:
        """``(mask, words, moved)``: the motions that move in the reference stream: turn by
        >= 1 deg (``turning``), or, for the translation speeds, translate by at least a
        tenth of the recording's typical motion (its median; the offset shows through the
        change of velocity, which a standing stream does not have) and rise above the
        stream's pose-to-pose noise (:func:`~simcalib.estimation.speeds.above_noise`: a
        camera seen only while the rig stands still moves by its noise alone over any
        span within a stop); ``moved``: every motion's angle (rad) or distance."""
        T, i, j = self.T_ref, self.i, self.j
        if turning:
            R = T[:, :3, :3]
            turn = rotation_angle_rad(np.swapaxes(R[i], 1, 2) @ R[j])
            return turn >= math.radians(1.0), "turns by >= 1 deg", turn
        from simcalib.estimation.stillness import translates
        d = np.linalg.norm(T[j, :3, 3] - T[i, :3, 3], axis=1)
        return (translates(d) & above_noise(d, T, "translation"),
                f"translates by a tenth of its median motion and {NOISE_GAIN:g}x its median "
                "pose-to-pose step or more", d)

    def _refuse_still(self, moved, what: str, step_s: float, signal: str, centre: float):
        """:class:`StillReference` where the cost cannot tell an offset: fewer than
        :data:`MIN_TURNING` of its motions move (``what``), or most of them (the median
        angle or distance, ``moved`` in the reference stream, the other stream's at the
        bracket's ``centre``) do not rise above either stream's pose-to-pose noise
        (:func:`~simcalib.estimation.speeds.above_noise`). The evidence rule tests an
        offset against chance, not against bias: where the motions are mostly noise, the
        cost's minimum follows the noise sampled at each offset (a barely moving rig with
        1 deg pose noise: offsets of seconds beat 0 with evidence 20-45), not the clocks.
        Returns the motions ``(C, H)`` at ``centre`` it formed."""
        n = int(self.mask.sum())
        if n < MIN_TURNING:
            raise StillReference(
                f"stream {self.reference} {what} over {step_s:g} s in only {n} motion(s) "
                f"(< {MIN_TURNING}): it moves too little, or only across its gaps "
                "(stop-and-go, seen only while still), so the cost cannot tell an offset")
        C, H = self.motions(centre)
        other = H if self.reference == "a" else C
        moved_other = (rotation_angle_rad(other[:, :3, :3]) if signal == "rotation"
                       else np.linalg.norm(other[:, :3, 3], axis=1))
        for name, m, T in ((self.reference, moved[self.mask], self.T_ref),
                           ("b" if self.reference == "a" else "a", moved_other,
                            self.T_other)):
            med = float(np.median(m))
            if not above_noise(med, T, signal):
                unit, f = (("deg", math.degrees(med)) if signal == "rotation"
                           else ("mm", 1e3 * med))
                raise StillReference(
                    f"the cost's {n} moving motions over {step_s:g} s move stream {name} by "
                    f"{f:.3g} {unit} (median), within {NOISE_GAIN:g}x its median pose-to-pose "
                    "motion: mostly pose noise, whose cost would pick an offset by chance, "
                    "so the cost cannot tell an offset")
        return C, H

    def thin_at(self, offset) -> float:
        """The offset's variance over the white-noise one of the cost's curvature (which
        treats the motions' residuals as independent), at ``offset``. Motions share poses:
        each reference pose ends one motion and starts the next (after a gap or a dropped
        frame several end on one), and its noise, and the other stream's at the same
        query, enters both. With ``s_i`` the slope of motion i's squared residual along the
        offset (its residual times the residual's derivative, X held at its optimum), the
        slope of the cost varies as ``sum_p (sum_{i touches p} s_i)^2 - sum_i s_i^2`` over
        the reference poses p, against ``sum_i s_i^2`` for independent motions: their ratio.
        Along a smooth path a shared pose's noise enters its two motions with opposite
        signs and nearly cancels (ratio below 1, held to :data:`THIN_MIN`); where the path
        reverses within a step it adds up (up to :data:`THIN_MAX`, the factor once used
        for every recording). Cached per offset."""
        key = float(offset)
        if key not in self._thin:
            self._thin[key] = self._chain_ratio(key)
        return self._thin[key]

    def _chain_ratio(self, offset) -> float:
        from simcalib.solvers.api import solve
        from simcalib.solvers.diagnostics.observability import _residuals
        if self.n < 3:
            return THIN_MAX
        C, H = self.motions(offset)
        X = solve(C, H, method="dqopt", alpha=self.alpha).X
        d = SLOPE_STEP_S
        g = (_residuals(*self.motions(offset + d), X, self.alpha)
             - _residuals(*self.motions(offset - d), X, self.alpha)) / (2.0 * d)
        s = np.sum(g * _residuals(C, H, X, self.alpha), axis=1)
        white = float(np.sum(s * s))
        if not (math.isfinite(white) and white > 0.0):
            return THIN_MAX
        m = self.t_ref.size
        per_pose = (np.bincount(self.i[self.mask], s, minlength=m)
                    + np.bincount(self.j[self.mask], s, minlength=m))
        return float(np.clip(float(np.sum(per_pose ** 2)) / white - 1.0, THIN_MIN, THIN_MAX))

    def _one_world(self, jumps, grid) -> np.ndarray:
        """The motions whose two ends lie in one stretch of each stream's world at every
        offset of ``grid``, away from a jump by more than the smoothing's reach (``jumps``:
        a's and b's ``world_jumps_s``, :mod:`simcalib.estimation.world_jumps`)."""
        j_own, j_other = (jumps if self.reference == "a" else jumps[::-1])
        reach = 5.0 * self.smooth_s
        ok = np.ones(self.i.shape, dtype=bool)
        for J, times in ((j_own, [self.t_ref]), (j_other, [self._query(o) for o in grid])):
            J = np.asarray(J, dtype=np.float64)
            if J.size == 0:
                continue
            for t in times:
                w = np.searchsorted(J, t, side="right")
                near = np.min(np.abs(t[:, None] - J[None]), axis=1) <= reach
                ok &= (w[self.i] == w[self.j]) & ~near[self.i] & ~near[self.j]
        return ok

    def _query(self, offset):
        return self.t_ref + offset if self.reference == "a" else self.t_ref - offset

    def motions(self, offset):
        """``(C, H)`` of the used motions at ``offset``."""
        T_o = smooth_poses(self.t_other, self.T_other, self._query(offset), self.smooth_s,
                           self.q_other)
        T_a, T_b = (self.T_ref, T_o) if self.reference == "a" else (T_o, self.T_ref)
        i, j = self.i[self.mask], self.j[self.mask]
        return invert_transform(T_a[i]) @ T_a[j], invert_transform(T_b[i]) @ T_b[j]

    def _keep_inliers(self, offset, motions=None):
        """Drop the motions RANSAC rejects at ``offset`` (``motions``: their ``(C, H)``
        there, when already formed with the current mask)."""
        from simcalib.solvers.robust import ransac
        self.n = int(self.mask.sum())
        C, H = self.motions(offset) if motions is None else motions
        try:
            inl = ransac(C, H, alpha=self.alpha, rng=np.random.default_rng(0),
                         max_iterations=256).inlier_mask
        except (ValueError, RuntimeError):     # too few motions / no consensus: keep all
            return
        idx = np.flatnonzero(self.mask)
        self.mask[idx[~inl]] = False

    def __call__(self, offset) -> float:
        if self.n < 3:
            return math.inf
        from simcalib.solvers.api import solve
        C, H = self.motions(offset)
        return float(solve(C, H, method="dqopt", alpha=self.alpha).cost) / self.n


def _refine(cost: OffsetCost, centre: float, half: float, n_grid: int = 13):
    """``(best, cost at best, curvature, grid offsets, grid costs)``: ``cost`` on a grid over
    ``centre +- half``, then bounded Brent between the grid neighbours of the minimum.

    Brent runs on the distance from the grid minimum, not on the offset itself: its
    tolerance has a part relative to its variable (1.5e-8 of it), which for an offset of
    a clock in Unix time against one counted from the recording's start (~1.8e9 s) is
    ~26 s, so that the search would stop at once, anywhere between the grid neighbours."""
    from scipy.optimize import minimize_scalar
    offs = np.linspace(centre - half, centre + half, n_grid)
    costs = np.array([cost(o) for o in offs])
    if not np.isfinite(costs).any():
        raise DataError("calibration cost undefined for every offset near the coarse "
                        "estimate (too few motions)")
    k = int(np.nanargmin(costs))
    h = offs[1] - offs[0]
    lo, hi = offs[max(k - 1, 0)], offs[min(k + 1, n_grid - 1)]
    res = minimize_scalar(lambda u: cost(offs[k] + u), bounds=(lo - offs[k], hi - offs[k]),
                          method="bounded", options={"xatol": 1e-6 * max(1.0, h / 1e-3)})
    best = float(offs[k] + res.x)
    j0 = cost(best)
    d = max(h / 4, 1e-4)
    curv = (cost(best + d) - 2 * j0 + cost(best - d)) / (d * d)
    return best, j0, curv, offs, costs



@dataclass(frozen=True)
class _Refined:
    centre: float
    best: float
    cost_best: float
    curvature: float
    offsets: np.ndarray
    costs: np.ndarray
    cost: OffsetCost
    #: the cost built around the candidate itself (before any slide; None: ``cost``): the
    #: one whose motions hold at offsets near the candidate, offset 0 for the zero one
    origin: OffsetCost | None = None
    #: the cost still fell to the edge of the last bracket: the slides ran out or left the
    #: allowed window, so no minimum is bracketed (no curvature sigma)
    unbounded: bool = False


#: a candidate whose cost falls to an edge of its bracket is refined again around that
#: edge, at most this many times (each a bracket's half width further); beyond, the data
#: do not bound an offset there
MAX_SLIDES = 6


def _refine_one(ta, Ta, tb, Tb, c, half, kw, window=None) -> _Refined:
    """:class:`_Refined` of candidate ``c``: the cost minimised over ``c +- half``; while
    its grid minimum lies on an edge, the bracket slides to that edge (inside ``window``,
    at most :data:`MAX_SLIDES` times). Raises DataError when no cost can be built at
    ``c``."""
    lo_w, hi_w = window if window is not None else (-math.inf, math.inf)
    centre, origin, last = c, None, None
    for _ in range(MAX_SLIDES + 1):
        try:
            cost = OffsetCost(ta, Ta, tb, Tb, (centre - half, centre + half), **kw)
        except DataError:
            if last is None:
                raise
            break                     # the overlap ends past the edge: keep the last
        origin = origin or cost
        last = (_refine(cost, centre, half), cost)
        offs, costs = last[0][3], last[0][4]
        k = int(np.nanargmin(costs))
        edge = k in (0, costs.size - 1)
        if not edge or not lo_w <= offs[k] <= hi_w:
            break
        centre = float(offs[k])
    return _Refined(c, *last[0], last[1], origin=origin, unbounded=edge)


def _refine_candidates(ta, Ta, tb, Tb, cands, half, kw, still=None, window=None) -> list:
    """The :class:`_Refined` of every candidate whose cost could be built
    (:func:`_refine_one`); the messages of the candidates refused because the reference
    stream stands still go to ``still``."""
    out = []
    for c in cands:
        try:
            out.append(_refine_one(ta, Ta, tb, Tb, c, half, kw, window))
        except StillReference as exc:
            if still is not None:
                still.append(str(exc))
        except DataError:
            continue
    return out


def _decide(tried, half):
    """``(chosen _Refined, decision, evidence, cost at 0)``: the candidate of lowest cost
    is used when it beats offset 0 by :data:`EVIDENCE_MIN`, else 0 (the data do not tell
    an offset); a recording where offset 0 leaves no overlap has only the estimate."""
    chosen = min(tried, key=lambda x: x.cost_best)
    zero = [x for x in tried if abs(x.centre) <= half]
    if not zero:
        return chosen, "estimated", float("nan"), float("nan")
    z = zero[0]
    j_zero = (z.origin or z.cost)(0.0)
    n_eff = RESIDUALS_PER_MOTION * chosen.cost.n / chosen.cost.thin_at(chosen.best)
    if not (math.isfinite(j_zero) and chosen.cost_best > 0):
        return chosen, "estimated", float("nan"), j_zero
    evidence = n_eff * math.log(j_zero / chosen.cost_best)
    return chosen, ("estimated" if evidence > EVIDENCE_MIN else "zero"), evidence, j_zero


#: an offset told from the angular speeds with a sigma above this (s) is in doubt: the
#: translation speeds are consulted as well (a third of the 3 ms the path aims at)
CLEAR_SIGMA_S = 1e-3


def in_doubt(off) -> bool:
    """The :class:`~simcalib.estimation.alignment.TimeOffset` ``off`` does not bound the
    offset clearly: its sigma is above :data:`CLEAR_SIGMA_S` or unknown (the cost could not
    be built). An offset not told from 0 within such a sigma (``zero``, 0.08 +- 0.22 ms on
    a continuous recording without offset) is no doubt: 0 is bounded as tightly."""
    return not off.uncertainty_s <= CLEAR_SIGMA_S


def both_translate(Ta, Tb) -> bool:
    """Both streams translate (90 % of the positions beyond
    :data:`~simcalib.estimation.stillness.STILL_M` of their median): the translation
    speeds carry a signal."""
    from simcalib.estimation.stillness import STILL_M, translation_extent_m
    return min(translation_extent_m((None, Ta)), translation_extent_m((None, Tb))) >= STILL_M


def clearer(first, second):
    """Of two offsets of one recording told from different signals (``TimeOffset.signal``),
    the one that tells it: of those that beat offset 0 by the evidence ("estimated"), the
    one of smaller sigma (the cost is the same calibration cost; only its candidates and
    moving motions differ); of none, ``first`` unless its sigma is unknown. The message
    names both."""
    import dataclasses
    ok = [o for o in (first, second) if o.decision == "estimated"
          and math.isfinite(o.uncertainty_s)]
    if ok:
        best = min(ok, key=lambda o: o.uncertainty_s)
    else:
        best = first if math.isfinite(first.uncertainty_s) else second
    other = second if best is first else first
    speeds = {"rotation": "angular", "translation": "translation"}
    told = (f"{other.offset_s * 1e3:.2f} ms used" if other.decision != "zero" else
            "0 used") + (f", sigma {other.uncertainty_s * 1e3:.2f} ms"
                         if math.isfinite(other.uncertainty_s) else
                         f": {other.why_zero or 'no sigma'}")
    note = (f" [from the {speeds[best.signal]} speeds: "
            + ("the more precise of the two that tell it" if ok else "neither tells it")
            + f"; the {speeds[other.signal]} speeds: {told}]")
    return dataclasses.replace(best, message=best.message + note)


def _offset_and_sigma(r: _Refined, worst_case: bool = False) -> tuple[float, float]:
    """The refined offset and its 1-sigma from the cost's curvature: ``2 J / (m J'')`` for
    ``m`` independent residual components (:data:`RESIDUALS_PER_MOTION` per motion), times
    the motions' sharing of poses (:meth:`OffsetCost.thin_at`; ``worst_case``: the most it
    can be, :data:`THIN_MAX`)."""
    if r.curvature > 0 and r.cost.n > 0 and not r.unbounded:
        thin = THIN_MAX if worst_case else r.cost.thin_at(r.best)
        return r.best, math.sqrt(2.0 * r.cost_best * thin
                                 / (RESIDUALS_PER_MOTION * r.cost.n * r.curvature))
    return r.best, float("nan")


@dataclass(frozen=True)
class SplitCheck:
    """The offset re-estimated on ``parts`` contiguous parts of the overlap:
    ``offsets_s`` and ``sigmas_s`` (each part's curvature sigma), ``ratio`` the
    dispersion of the parts about their weighted mean, ``Q / (n - 1)`` with ``Q = sum
    (o_k - o)^2 / sigma_k^2`` (about 1 when the curvature's sigmas hold; NaN without a
    check), ``sigma_s`` the sigma of that weighted mean scaled by the dispersion
    (``sqrt(ratio / sum sigma_k^-2)``), ``raised``: ``Q`` beyond the :data:`SPLIT_LEVEL`
    quantile of chi-square on ``n - 1`` dof, so the reported sigma is at least
    ``sigma_s`` (unless a clock drift explains it: :mod:`simcalib.estimation.drift`);
    ``times_s``: the middle of each part's reference stamps; ``flat_times_s``: the same of
    the parts left out because their cost does not curve within the bracket (no finite
    sigma: a stretch the offset misses by far more than the bracket, as after a clock
    step of seconds, :mod:`simcalib.estimation.clock_step`)."""
    offsets_s: tuple
    sigmas_s: tuple
    ratio: float
    sigma_s: float
    raised: bool
    times_s: tuple = ()
    flat_times_s: tuple = ()

    def to_dict(self) -> dict:
        fin = lambda x: x if math.isfinite(x) else None  # noqa: E731
        return {"offsets_s": list(self.offsets_s), "sigmas_s": list(self.sigmas_s),
                "dispersion": fin(self.ratio), "sigma_s": fin(self.sigma_s),
                "raised": self.raised, "times_s": list(self.times_s)}


def split_check(ta, Ta, tb, Tb, best, half, kw, window) -> SplitCheck:
    """The offset refined on up to :data:`SPLIT_PARTS` contiguous parts of the overlap
    (each long enough for 4 motions of the cost's step) around ``best``; ``window`` the
    reference stamps the full estimate used. The parts see the same clocks but different
    stretches of the recording, so errors that are not white (a tracker's drift, a
    target's systematic error, interpolation) move their estimates apart beyond what
    their curvatures predict: that dispersion then scales the sigma of their combination
    (quasi-likelihood), and the reported sigma is at least that. Each part's sigma takes
    the most the motions' sharing of poses can give (:data:`THIN_MAX`): the check is for
    errors that are not white, and a part's own estimate of the sharing (a quarter of the
    motions, some parts barely moving) is not one to test the others against. A part whose
    cost does not curve within the bracket (no finite sigma) is left out and its middle
    kept in ``flat_times_s``."""
    from scipy.special import chdtri
    parts = int(min(SPLIT_PARTS, (window[1] - window[0]) // (4 * kw["step_s"])))
    offs, sigs, times, flat = [], [], [], []
    for k in range(parts if parts >= 2 else 0):
        try:
            c = OffsetCost(ta, Ta, tb, Tb, (best - half, best + half), part=(k, parts), **kw)
        except DataError:
            continue
        if c.n < 8:
            continue
        o, sg = _offset_and_sigma(_Refined(best, *_refine(c, best, half), c),
                                  worst_case=True)
        if math.isfinite(sg) and sg > 0:
            offs.append(o)
            sigs.append(sg)
            times.append(0.5 * (c.window[0] + c.window[1]))
        else:
            flat.append(0.5 * (c.window[0] + c.window[1]))
    n = len(offs)
    if n < 2:
        return SplitCheck(tuple(offs), tuple(sigs), float("nan"), float("nan"), False,
                          tuple(times), tuple(flat))
    o, w = np.asarray(offs), 1.0 / np.asarray(sigs) ** 2
    q = float(np.sum(w * (o - np.sum(w * o) / np.sum(w)) ** 2))
    bound = float(chdtri(n - 1, 1.0 - SPLIT_LEVEL))
    ratio = q / (n - 1)
    return SplitCheck(tuple(map(float, offs)), tuple(map(float, sigs)), ratio,
                      math.sqrt(ratio / float(np.sum(w))), bool(q > bound), tuple(times),
                      tuple(flat))
