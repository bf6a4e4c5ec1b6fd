"""Time alignment of two pose streams stamped by different clocks.

Convention: ``offset_s = t_b - t_a`` for the same physical instant (stream b's clock runs
``offset_s`` ahead of stream a's). With drift, ``offset(t_a) = offset_s + drift * (t_a - t_ref_s)``.

* :func:`estimate_time_offset` — coarse offset by cross-correlating the angular speeds of the
  two streams on a common grid (normalised cross-correlation, every lag via FFT), refined to
  sub-frame precision by minimising the calibration cost (dqopt, per motion) over the offset,
  with the poses of the faster stream interpolated (linear translation, SLERP rotation).
  A linear clock drift where the data tell it (:mod:`simcalib.estimation.drift`). Returns a
  :class:`TimeOffset`.
* :func:`synchronise` — pair the streams with an offset: the faster stream interpolated at
  the slower one's (shifted) stamps -> :class:`SyncedPoses`.
* :func:`make_motions` — relative motions ``C``, ``H`` over a time step, or between keyframes
  chosen by a rotation-angle threshold; small / huge motions filtered.

A stream is a :class:`simcalib.importers.PoseStreamData`, a ``simcalib.streams.PoseStream``
or a tuple ``(timestamps_s, T_world_sensor)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from simcalib.errors import DataError
from simcalib.estimation.drift import (check_drift, drift_applied, drift_from_halves,
                                       fitted_line)
from simcalib.estimation.interpolation import interpolate_poses, max_hole_s, smooth_poses
from simcalib.estimation.speeds import SPEEDS, as_time_poses, checked_signal, speed_steps
from simcalib.estimation.worlds import instant_worlds
from simcalib.estimation import presence
from simcalib.estimation.signals import despike
from simcalib.geometry import invert_transform, rotation_angle_rad

__all__ = ["TimeOffset", "SyncedPoses", "estimate_time_offset", "synchronise", "make_motions",
           "peak_z"]


# ------------------------------------------------------------------------- results
@dataclass(frozen=True)
class TimeOffset:
    """Estimated clock offset ``offset_s = t_b - t_a`` (at ``t_ref_s`` in clock a when a
    ``drift`` (s/s) is estimated).

    ``uncertainty_s``: 1-sigma from the curvature of the calibration cost (its residuals
    white, times the motions' sharing of poses: :meth:`~simcalib.estimation.offset_cost.
    OffsetCost.thin_at`), raised to the
    spread of the offsets of contiguous parts of the overlap where that spread is beyond
    chance (``split``: :class:`simcalib.estimation.offset_cost.SplitCheck`); when 0 is used
    because the data do not tell the offset apart from it (``decision`` "zero"), the root
    sum of squares of that sigma and the estimate (the error of using 0 instead).
    ``coarse_offset_s``: from the angular-speed cross-correlation; ``lags_s`` /
    ``correlation``: that curve (Pearson r per lag); ``peak_correlation``: its maximum;
    ``cost_offsets_s`` / ``cost``: the refinement curve (mean cost per motion).
    """
    offset_s: float
    uncertainty_s: float
    coarse_offset_s: float
    peak_correlation: float
    lags_s: np.ndarray = field(repr=False)
    correlation: np.ndarray = field(repr=False)
    drift: float = 0.0
    t_ref_s: float = 0.0
    refined: bool = True
    cost_offsets_s: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    cost: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    message: str = ""
    #: how the offset was decided: ``estimated`` (the data tell it), ``zero`` (the data do
    #: not tell it apart from 0, which is used), ``given``, ``shared_stamps`` (paired by
    #: stamp, shifted only by a constant stamp shift: ``Sampling.shift_s``)
    decision: str = "estimated"
    #: ``n_eff ln(cost at 0 / cost at the estimate)``: the evidence against 0 (~chi2(1)
    #: under no offset; > :data:`EVIDENCE_MIN` to use the estimate); NaN where not compared
    evidence: float = float("nan")
    #: the correlation peak's height over the spread of the correlation at other lags
    peak_z: float = float("nan")
    #: offsets the correlation allows (the plausibility window, s)
    window_s: tuple = (float("-inf"), float("inf"))
    #: the split check of the refined offset (None: not refined or too short to split)
    split: object = None
    #: the speeds whose correlation gave the candidates and whose moving motions the cost
    #: used: ``rotation`` (angular) or ``translation``
    signal: str = "rotation"
    #: why the cost could not be built, where it could not (0 used with no sigma)
    why_zero: str = ""
    #: the refined offset the cost put lowest, also where 0 is used instead (``zero``: its
    #: distance from 0 is in ``uncertainty_s``); NaN where none was refined
    best_s: float = float("nan")
    #: the 1-sigma of ``drift`` (0 where none is fitted, or drift from two halves)
    drift_sigma: float = 0.0
    #: clock steps told and removed from b's stamps before this offset was estimated
    #: (:class:`simcalib.estimation.clock_step.ClockStep`; the offset is the first stretch's)
    steps: tuple = ()
    #: put where b's clusters fall on a's stops (:mod:`~simcalib.estimation.presence`):
    #: within ``uncertainty_s`` b's samples stay where a stands still
    at_stops: bool = False

    def offset_at(self, t_a) -> np.ndarray:
        """Offset ``t_b - t_a`` at clock-a times ``t_a``."""
        return self.offset_s + self.drift * (np.asarray(t_a, dtype=np.float64) - self.t_ref_s)

    def b_from_a(self, t_a) -> np.ndarray:
        t_a = np.asarray(t_a, dtype=np.float64)
        return t_a + self.offset_at(t_a)

    def a_from_b(self, t_b) -> np.ndarray:
        t_b = np.asarray(t_b, dtype=np.float64)
        return (t_b - self.offset_s + self.drift * self.t_ref_s) / (1.0 + self.drift)


def _as_offset(offset) -> TimeOffset:
    if isinstance(offset, TimeOffset):
        return offset
    if isinstance(offset, bool) or not isinstance(offset, (int, float, np.integer, np.floating)):
        raise TypeError(f"offset must be seconds (a number) or a TimeOffset; received "
                        f"{type(offset).__name__}")
    if not math.isfinite(offset):
        raise ValueError(f"offset must be finite; received {offset}")
    return TimeOffset(float(offset), 0.0, float(offset), float("nan"), np.zeros(0),
                      np.zeros(0), refined=False, message="given", decision="given")


@dataclass(frozen=True)
class SyncedPoses:
    """Poses of both streams at common instants: ``time_s`` in clock a, ``T_a``, ``T_b``
    (N, 4, 4). ``reference``: the stream whose stamps were used (the slower one); the other
    was interpolated. ``counts``: reference stamps, outside the overlap, in gaps, kept.
    ``world``: per instant, the stretch of both streams' worlds it lies in (an int; instants
    of one value share both worlds: :mod:`simcalib.estimation.world_jumps`); None: one world
    each."""
    time_s: np.ndarray
    T_a: np.ndarray
    T_b: np.ndarray
    reference: str
    counts: dict
    world: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(self.time_s.shape[0])


def synchronise(stream_a, stream_b, offset=0.0, *, reference: str | None = None,
                max_gap_s: float | None = None, window_s: tuple | None = None,
                smooth_s: float | None = None) -> SyncedPoses:
    """Pair two streams: the faster stream (or the one not named by ``reference``, ``"a"``
    or ``"b"``) is interpolated at the other one's stamps, shifted by ``offset`` (seconds
    ``t_b - t_a`` or a :class:`TimeOffset`). ``max_gap_s`` (default :func:`max_hole_s` of
    the interpolated stream): interpolation across longer gaps is refused (counted).
    ``window_s`` (lo, hi): keep only reference stamps within it (in the reference stream's
    own clock, so the kept stamps do not change with the offset). ``smooth_s``: both
    streams' poses by Gaussian kernel regression with this bandwidth instead of plain
    interpolation (:func:`smooth_poses`; used by the offset refinement)."""
    ta, Ta = as_time_poses(stream_a, "stream_a")
    tb, Tb = as_time_poses(stream_b, "stream_b")
    off = _as_offset(offset)
    if reference is None:
        reference = "a" if np.median(np.diff(ta)) >= np.median(np.diff(tb)) else "b"
    if reference not in ("a", "b"):
        raise ValueError(f"reference must be 'a', 'b' or None; received {reference!r}")
    if reference == "a":
        t_ref = ta
        tq = off.b_from_a(ta)
        gap = max_gap_s if max_gap_s is not None else max_hole_s(tb)
        T_other, valid = interpolate_poses(tb, Tb, tq, gap)
        T_a_all, T_b_all = Ta, T_other
        inside = (tq >= tb[0]) & (tq <= tb[-1])
    else:
        tq = off.a_from_b(tb)
        t_ref = tq
        gap = max_gap_s if max_gap_s is not None else max_hole_s(ta)
        T_other, valid = interpolate_poses(ta, Ta, tq, gap)
        T_a_all, T_b_all = T_other, Tb
        inside = (tq >= ta[0]) & (tq <= ta[-1])
    if smooth_s is not None:
        T_a_all = smooth_poses(ta, Ta, ta if reference == "a" else tq, smooth_s)
        T_b_all = smooth_poses(tb, Tb, tq if reference == "a" else tb, smooth_s)
    keep = valid.copy()
    if window_s is not None:
        own = ta if reference == "a" else tb
        keep &= (own >= window_s[0]) & (own <= window_s[1])
    counts = {"reference_stamps": int(t_ref.size), "outside_overlap": int((~inside).sum()),
              "in_gaps": int((inside & ~valid).sum()), "kept": int(keep.sum())}
    qa, qb = (ta, tq) if reference == "a" else (tq, tb)
    world, ok = instant_worlds(stream_a, stream_b, qa, qb, reference, smooth_s)
    if world is not None:
        counts |= {"across_a_world_jump": int((keep & ~ok).sum()),
                   "kept": int((keep & ok).sum())}
        keep &= ok
        world = world[keep]
    return SyncedPoses(t_ref[keep], T_a_all[keep], T_b_all[keep], reference, counts, world)


def make_motions(synced: SyncedPoses, *, step_s: float | None = None, step: int = 1,
                 min_rotation_deg: float | None = None, max_rotation_deg: float | None = None,
                 keyframes: bool = False):
    """Relative motions ``C = T_a[i]^-1 T_a[j]``, ``H = T_b[i]^-1 T_b[j]`` (so ``C X = X H``,
    ``X = T_a_b``). Returns ``(C, H, i, j)``.

    * ``step_s``: ``j`` is the first instant at least ``step_s`` after ``i`` (every ``i``);
      otherwise ``j = i + step``.
    * ``keyframes=True`` with ``min_rotation_deg``: non-overlapping motions, each ending at
      the first instant where stream a has turned by ``min_rotation_deg`` since the last.
    * ``min_rotation_deg`` / ``max_rotation_deg``: motions whose rotation (mean of the two
      streams' angles) is smaller / larger are dropped (small motions carry no information,
      huge ones indicate tracking jumps).
    """
    t, Ta, Tb = synced.time_s, synced.T_a, synced.T_b
    n = t.size
    if n < 3:
        raise DataError(f"only {n} synchronised poses; at least 3 are needed (do the streams "
                         "overlap in time with this offset?)")
    if keyframes:
        if min_rotation_deg is None or not min_rotation_deg > 0:
            raise ValueError("keyframes=True needs min_rotation_deg > 0")
        thr = math.radians(min_rotation_deg)
        Ra = Ta[:, :3, :3]
        ii, jj = [], []
        i = 0
        while i < n - 1:
            ang = rotation_angle_rad(np.swapaxes(Ra[i], 0, 1)[None] @ Ra[i + 1:])
            hit = np.nonzero(ang >= thr)[0]
            if hit.size == 0:
                break
            j = i + 1 + int(hit[0])
            ii.append(i)
            jj.append(j)
            i = j
        i = np.asarray(ii, dtype=np.int64)
        j = np.asarray(jj, dtype=np.int64)
    elif step_s is not None:
        from simcalib.estimation.motions import span_pairs
        i, j = span_pairs(t, step_s)
    else:
        if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
            raise ValueError(f"step must be an integer >= 1; received {step!r}")
        i = np.arange(n - step)
        j = i + step
    C = invert_transform(Ta[i]) @ Ta[j]
    H = invert_transform(Tb[i]) @ Tb[j]
    if (min_rotation_deg is not None and not keyframes) or max_rotation_deg is not None:
        ang = 0.5 * (rotation_angle_rad(C[:, :3, :3]) + rotation_angle_rad(H[:, :3, :3]))
        ok = np.ones(ang.shape, dtype=bool)
        if min_rotation_deg is not None and not keyframes:
            ok &= ang >= math.radians(min_rotation_deg)
        if max_rotation_deg is not None:
            ok &= ang <= math.radians(max_rotation_deg)
        C, H, i, j = C[ok], H[ok], i[ok], j[ok]
    return C, H, i, j


# ----------------------------------------------------------------- cross-correlation
#: the most samples a stream's angular-speed signal gets on the correlation grid
MAX_GRID = 2 ** 22


def _grid_signal(t_mid, speed, t0, t1, dt, smooth_s):
    grid = np.arange(t0, t1 + 0.5 * dt, dt)
    y = np.interp(grid, t_mid, speed)
    w = max(1, int(round(smooth_s / dt)))
    if w > 1:
        y = np.convolve(y, np.ones(w) / w, mode="same")
    return grid, y


def _normalised_xcorr(x: np.ndarray, y: np.ndarray, min_overlap: int):
    """Pearson r between x[i] and y[i + L] for every lag L (FFT); lags with fewer than
    ``min_overlap`` overlapping samples get NaN. Returns (lags, r)."""
    from simcalib.estimation.signals import correlate_full, correlation_lags_full
    ox, oy = np.ones_like(x), np.ones_like(y)
    c = correlate_full
    n = np.rint(c(oy, ox))
    sxy = c(y, x)
    sx = c(oy, x)
    sy = c(y, ox)
    sxx = c(oy, x * x)
    syy = c(y * y, ox)
    lags = correlation_lags_full(y.size, x.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        num = n * sxy - sx * sy
        den = np.sqrt(np.clip(n * sxx - sx * sx, 0, None) * np.clip(n * syy - sy * sy, 0, None))
        r = num / den
    r[(n < min_overlap) | ~np.isfinite(r)] = np.nan
    return lags, r


def _raise_if_unmeasurable(ta, tb, x, y, min_overlap, signal="rotation"):
    """The stamps overlap but the offset cannot be measured: too few poses, or a stream
    that does not move (its speed is flat, so nothing correlates)."""
    lo, hi = max(ta[0], tb[0]), min(ta[-1], tb[-1])
    if hi <= lo:
        return
    span = (f"their stamps overlap for {hi - lo:.3f} s (a: {ta[0]:.3f}..{ta[-1]:.3f} s, "
            f"b: {tb[0]:.3f}..{tb[-1]:.3f} s)")
    if min(ta.size, tb.size) < 4 or min(x.size, y.size) < min_overlap:
        raise DataError(f"the time offset cannot be estimated: a has {ta.size} poses, b has "
                        f"{tb.size}, too few to correlate; {span}; give time_offset=")
    flat = [n for n, w in (("a", x), ("b", y)) if np.ptp(w) <= 1e-12 * max(1.0, np.abs(w).max())]
    if flat:
        what = "rotate (its angular" if signal == "rotation" else "translate (its"
        raise DataError(f"the time offset cannot be estimated: stream {' and '.join(flat)} does "
                        f"not {what} speed is constant); {span}; give time_offset=")


def _coarse_offset(ta, Ta, tb, Tb, max_offset_s, min_overlap_frac, robust=True,
                   signal="rotation"):
    speed = SPEEDS[signal]
    step_a, step_b = speed_steps(ta, tb)
    tma, wa = speed((ta, Ta), step_a)
    tmb, wb = speed((tb, Tb), step_b)
    if robust:      # outlier poses make spikes: running medians
        wa, wb = despike(wa), despike(wb)
    dt_a, dt_b = float(np.median(np.diff(ta))), float(np.median(np.diff(tb)))
    # half the faster stream's period, but never more than MAX_GRID samples per stream
    # (streams stamped in different units, ns and s, would ask for 1e10)
    dt = max(0.5 * min(dt_a, dt_b), max(ta[-1] - ta[0], tb[-1] - tb[0]) / MAX_GRID)
    smooth = max(dt_a, dt_b)
    ga, x = _grid_signal(tma, wa, tma[0], tma[-1], dt, smooth)
    gb, y = _grid_signal(tmb, wb, tmb[0], tmb[-1], dt, smooth)
    min_overlap = max(10, int(min_overlap_frac * min(x.size, y.size)))
    lags, r = _normalised_xcorr(x, y, min_overlap)
    offsets = gb[0] - ga[0] + lags * dt        # t_b - t_a at lag L
    if max_offset_s is not None:
        r = np.where(np.abs(offsets) <= max_offset_s, r, np.nan)
    if not np.isfinite(r).any():
        _raise_if_unmeasurable(ta, tb, x, y, min_overlap, signal)
        raise DataError(
            f"the streams do not overlap by {min_overlap_frac:.0%} of the shorter one at any "
            f"allowed offset (a: {ta[0]:.3f}..{ta[-1]:.3f} s, b: {tb[0]:.3f}..{tb[-1]:.3f} s"
            + (f", |offset| <= {max_offset_s} s" if max_offset_s is not None else "")
            + "); check the timestamps' units and clocks, or give time_offset=")
    k = int(np.nanargmax(r))
    best = offsets[k]
    if 0 < k < r.size - 1 and np.isfinite(r[k - 1]) and np.isfinite(r[k + 1]):
        den = r[k - 1] - 2 * r[k] + r[k + 1]
        if den < 0:
            best += 0.5 * (r[k - 1] - r[k + 1]) / den * dt
    ok = np.isfinite(r)
    return float(best), float(r[k]), offsets[ok], r[ok], dt


def peak_z(r: np.ndarray, peak: float) -> float:
    """How far the correlation's peak stands above its values at other lags: (peak -
    median) / (1.4826 MAD) over every allowed lag (a clear peak: >> 3)."""
    if r.size < 5 or not math.isfinite(peak):
        return float("nan")
    med = float(np.median(r))
    mad = 1.4826 * float(np.median(np.abs(r - med))) + 1e-12
    return (peak - med) / mad


def _other_peaks(offsets, r, peak, best, min_sep_s, rel: float = 0.9, max_n: int = 3):
    """Offsets of local maxima of the correlation ``r`` other than ``best`` that reach
    ``rel`` x ``peak`` and lie at least ``min_sep_s`` from ``best`` and each other (at most
    ``max_n``, highest first)."""
    if r.size < 3 or not peak > 0:
        return []
    is_max = np.zeros(r.size, dtype=bool)
    is_max[1:-1] = (r[1:-1] >= r[:-2]) & (r[1:-1] >= r[2:]) & (r[1:-1] >= rel * peak)
    out = []
    for k in np.nonzero(is_max)[0][np.argsort(-r[is_max])]:
        o = float(offsets[k])
        if all(abs(o - x) >= min_sep_s for x in [best, *out]):
            out.append(o)
        if len(out) >= max_n:
            break
    return out



def estimate_time_offset(stream_a, stream_b, *, max_offset_s: float | None = None,
                         refine: bool = True, drift: bool | str = "auto",
                         step_s: float | None = None,
                         alpha: float = 1.0, min_overlap_frac: float = 0.3,
                         robust: bool = True, signal: str = "auto") -> TimeOffset:
    """Estimate ``offset_s = t_b - t_a`` between two pose streams, where the data tell it.

    Coarse: the angular speeds (convention-free; running medians remove outlier poses'
    spikes of any share below half a window) on a common grid at half the faster period,
    smoothed over the slower period, normalised cross-correlation over every lag that keeps
    ``min_overlap_frac`` of the shorter stream (the plausibility window; also
    ``|offset| <= max_offset_s`` if given); parabolic peak, and ``peak_z`` (its height over
    the spread at other lags). Refine (``refine=True``): candidates are the peak, other
    peaks within 90 % of it (periodic motion) and 0; around each the mean dqopt cost per
    motion of a fixed set of motions (:class:`simcalib.estimation.offset_cost.OffsetCost`:
    motions over ``step_s``, default 4 slower periods and >= ``OFFSET_STEP_S``, 1 s; the
    RANSAC inliers) is minimised (grid over +- 2 slower periods, then bounded Brent). The
    lowest cost wins; its sigma (the cost's curvature) is checked by re-estimating the
    offset on contiguous parts of the overlap (``split_check``) and raised to their spread
    where that is beyond chance. The estimate is used only when it beats offset 0 by the
    evidence ``n_eff ln(J(0) / J)`` (divided by the split's variance ratio where raised)
    > ``EVIDENCE_MIN`` (``decision`` "estimated"); otherwise the data do not tell an
    offset and 0 is used ("zero"). ``drift``: a linear clock drift fitted through the
    split check's parts (:mod:`simcalib.estimation.drift`): ``"auto"`` where they tell it,
    ``True`` always (on an overlap too short for the parts, from its two halves),
    ``False`` never. Needs the streams' readings resolved for the
    refinement (:mod:`simcalib.estimation.readings`); the coarse step does not.

    ``signal``: ``rotation`` (angular speeds) or ``translation`` (translation speeds, for a
    rig that does not turn: their norms agree in every sensor, whatever the reading; the
    cost's motions are the ones that translate); ``auto``: rotation unless neither stream
    turns (:func:`simcalib.estimation.stillness.motion_signal`); with ``auto``, where the
    rotation signal leaves the offset in doubt (its sigma above
    :data:`~simcalib.estimation.offset_cost.CLEAR_SIGMA_S` or unknown: a rig that turns
    only a little) and both streams translate, the translation signal is estimated too and the
    one that tells the offset more precisely is used (:func:`~simcalib.estimation.
    offset_cost.clearer`; ``TimeOffset.signal`` says which).
    """
    from simcalib.estimation import offset_cost as oc
    ta, Ta = as_time_poses(stream_a, "stream_a")
    tb, Tb = as_time_poses(stream_b, "stream_b")
    auto, signal = signal == "auto", checked_signal(signal, (ta, Ta), (tb, Tb))
    drift = check_drift(drift)
    kw = dict(max_offset_s=max_offset_s, refine=refine, drift=drift, step_s=step_s,
              alpha=alpha, min_overlap_frac=min_overlap_frac, robust=robust)
    jumps = tuple(tuple(getattr(st, "world_jumps_s", ())) for st in (stream_a, stream_b))
    if any(jumps):                  # the cost's motions only within a stretch of the worlds
        kw["jumps"] = jumps
    first = _estimate(ta, Ta, tb, Tb, signal, **kw)
    if not (auto and refine and signal == "rotation" and oc.in_doubt(first)
            and oc.both_translate(Ta, Tb)):
        return presence.checked(first, ta, Ta, tb) if refine else first
    try:
        second = _estimate(ta, Ta, tb, Tb, "translation", **kw)
    except DataError:
        return presence.checked(first, ta, Ta, tb)
    return presence.checked(oc.clearer(first, second), ta, Ta, tb)


def _estimate(ta, Ta, tb, Tb, signal, *, max_offset_s, refine, drift, step_s, alpha,
              min_overlap_frac, robust, jumps=None) -> TimeOffset:
    """:func:`estimate_time_offset` on one ``signal``: its correlation's candidates refined
    on the cost of the motions that move that way."""
    from simcalib.estimation import offset_cost as oc
    coarse, peak, lags, corr, grid_dt = _coarse_offset(ta, Ta, tb, Tb, max_offset_s,
                                                       min_overlap_frac, robust, signal)
    z = peak_z(corr, peak)
    window = (float(lags.min()), float(lags.max())) if lags.size else (coarse, coarse)
    slow_dt = max(float(np.median(np.diff(ta))), float(np.median(np.diff(tb))))
    msg = _coarse_message(coarse, peak, z, window, signal)
    base = dict(peak_z=z, window_s=window, signal=signal)
    if not refine:
        return TimeOffset(coarse, grid_dt, coarse, peak, lags, corr, refined=False,
                          message=msg, **base)
    half = 2.0 * slow_dt
    step_s = _offset_step_s(ta, tb, coarse, slow_dt, half) if step_s is None else step_s
    kw = dict(step_s=step_s, alpha=alpha, robust=robust, turning=signal == "rotation",
              smooth_s=min(float(np.median(np.diff(ta))), float(np.median(np.diff(tb)))))
    if jumps is not None:
        kw["jumps"] = jumps
    cands = [coarse] + _other_peaks(lags, corr, peak, coarse, 4 * slow_dt)
    if window[0] <= 0.0 <= window[1] and all(abs(c) > half for c in cands):
        cands.append(0.0)
    still: list = []
    tried = oc._refine_candidates(ta, Ta, tb, Tb, cands, half, kw, still, window)
    if not tried:
        return _unrefined(coarse, grid_dt, peak, lags, corr, msg, still, base)
    if len(tried) > 1:
        msg += ("; refined around " + ", ".join(f"{t.centre * 1e3:.0f}" for t in tried)
                + " ms: calibration costs " + ", ".join(f"{t.cost_best:.3g}" for t in tried))
    return _refined((ta, Ta, tb, Tb), tried, half, kw, drift, msg,
                    dict(peak_correlation=peak, lags_s=lags, correlation=corr, **base))


def _coarse_message(coarse, peak, z, window, signal) -> str:
    return (f"coarse offset {coarse * 1e3:.1f} ms from "
            f"{'angular' if signal == 'rotation' else 'translation'}-speed cross-correlation "
            f"(peak r = {peak:.3f}, {z:.1f} robust sigma above the other lags; offsets "
            f"{window[0]:.3g}..{window[1]:.3g} s allowed)")


def _offset_step_s(ta, tb, coarse, slow_dt, half) -> float:
    """The span of the offset cost's motions: :data:`~simcalib.estimation.offset_cost.
    OFFSET_STEP_S` and >= 4 slower periods; shorter on a short overlap, so that 5 motions
    fit into what the cost's bracket and margins leave of it (never below 4 periods)."""
    from simcalib.estimation import offset_cost as oc
    overlap = min(ta[-1], tb[-1] - coarse) - max(ta[0], tb[0] - coarse)
    usable = overlap - 2.0 * half - 2.0 * (5.0 * min(np.median(np.diff(ta)),
                                                     np.median(np.diff(tb))) + slow_dt)
    return float(max(4.0 * slow_dt, min(oc.OFFSET_STEP_S, usable / 5.0)))


#: the correlation's peak must stand this many robust sigmas above its other lags for an
#: offset the cost could not refine to be used (else 0 is)
PEAK_Z_MIN = 5.0


def _unrefined(coarse, grid_dt, peak, lags, corr, msg, still, base) -> TimeOffset:
    """No candidate could be refined: where the reference stream stands still between its
    samples (``still``: why) the cost cannot tell an offset and 0 is used; else the
    overlap is too short, and the correlation's offset stands only where its peak is
    clear (:data:`PEAK_Z_MIN`; else 0, its sigma up to the peak's offset)."""
    if still:
        return TimeOffset(0.0, float("nan"), coarse, peak, lags, corr, refined=False,
                          decision="zero", message=msg + f"; but {still[0]}: 0 is used",
                          why_zero=still[0], **base)
    msg += "; the overlap is too short to refine it"
    if not base["peak_z"] >= PEAK_Z_MIN:
        return TimeOffset(0.0, math.hypot(grid_dt, coarse), coarse, peak, lags, corr,
                          refined=False, decision="zero", message=msg + (
                              f", and its peak is not clear (< {PEAK_Z_MIN:g} robust sigma): "
                              "0 is used"), **base)
    return TimeOffset(coarse, grid_dt, coarse, peak, lags, corr, refined=False,
                      message=msg, **base)


def _unbounded(chosen, msg, fields) -> TimeOffset:
    """The best candidate's cost still fell at the edge of the offsets searched (the
    allowed window, or :data:`~simcalib.estimation.offset_cost.MAX_SLIDES` slides of its
    bracket): no minimum, no curvature; 0 is used and its sigma is unknown."""
    from simcalib.estimation import offset_cost as oc
    return TimeOffset(0.0, float("nan"), chosen.centre, refined=True,
                      cost_offsets_s=chosen.offsets, cost=chosen.costs, decision="zero",
                      message=msg + (f"; the calibration cost still falls at "
                                     f"{chosen.best * 1e3:.1f} ms, the edge of the offsets "
                                     f"searched (the allowed window or {oc.MAX_SLIDES} slides"
                                     " of the bracket): the data do not bound an offset, 0 is "
                                     "used"), **fields)


def _refined(streams, tried, half, kw, drift, msg, fields) -> TimeOffset:
    """The :class:`TimeOffset` of the refined candidates ``tried``: the best one refined
    again around its estimate, its sigma split-checked, compared with 0, drift fitted
    (``drift``: True, or ``"auto"`` where the parts tell it: :mod:`simcalib.estimation.
    drift`)."""
    from simcalib.estimation import offset_cost as oc
    chosen, decision, evidence, _ = oc._decide(tried, half)
    again = oc._refine_candidates(*streams, [chosen.best], half / 2, kw,
                                  window=fields["window_s"])
    if again:     # centred on the estimate: the inliers chosen there, a narrower bracket
        chosen = replace(again[0], centre=chosen.centre, origin=chosen.origin)
    if chosen.unbounded:
        return _unbounded(chosen, msg, fields)
    best, sigma = oc._offset_and_sigma(chosen)
    split = oc.split_check(*streams, best, half, kw, chosen.cost.window)
    t_ref = 0.5 * (chosen.cost.window[0] + chosen.cost.window[1])
    line, d, d_sigma = fitted_line(split, t_ref, drift), 0.0, 0.0
    model_sigma, note = (line.sigma_s, line.note()) if line else _split_sigma(split, sigma)
    msg += note
    if model_sigma > sigma and math.isfinite(evidence):  # dispersion beyond the model's
        evidence *= (sigma / model_sigma) ** 2
        decision = "estimated" if evidence > oc.EVIDENCE_MIN else "zero"
    sigma = max(sigma, model_sigma)
    if chosen.cost.reference == "b":
        t_ref -= line.offset_s if line else best        # the window is in b's clock
    if decision == "estimated" and line:
        best, sigma, d, d_sigma, more = drift_applied(streams, line, t_ref, sigma, half, kw,
                                                      fields["window_s"])
        msg += more
    elif drift is True and decision == "estimated":     # too short for the parts' line
        d, best, more = drift_from_halves(*streams, best, half, kw)
        msg += more
    msg += (f"; refined to {best * 1e3:.2f} +- {sigma * 1e3:.2f} ms by the dqopt cost over "
            f"{chosen.cost.n} motions of {kw['step_s']:.2f} s")
    told = best
    if decision == "zero":
        # 0 is used where the data put the offset at ``best``: its error is up to that far
        sigma = math.hypot(sigma, best)
        msg += (f"; but the cost at 0 is not worse beyond chance (evidence {evidence:.1f} <= "
                f"{oc.EVIDENCE_MIN:g}): the data do not tell an offset, 0 is used (sigma "
                f"{sigma * 1e3:.2f} ms: the estimate's and its distance from 0)")
        best, d, d_sigma = 0.0, 0.0, 0.0
    elif math.isfinite(evidence):
        msg += f"; it beats offset 0 with evidence {evidence:.1f} (> {oc.EVIDENCE_MIN:g})"
    return TimeOffset(best, sigma, chosen.centre, drift=d, t_ref_s=t_ref, refined=True,
                      cost_offsets_s=chosen.offsets, cost=chosen.costs, message=msg,
                      decision=decision, evidence=evidence, split=split, best_s=told,
                      drift_sigma=d_sigma, **fields)


def _split_sigma(split, sigma) -> tuple[float, str]:
    """The sigma one offset's parts give where they disperse beyond chance (else
    ``sigma``), and the note that says so."""
    if not (split.raised and split.sigma_s > sigma):
        return sigma, ""
    return split.sigma_s, (
        f"; the offsets of {len(split.offsets_s)} parts of the overlap ("
        + ", ".join(f"{o * 1e3:.1f}" for o in split.offsets_s)
        + f" ms) disperse {split.ratio:.3g}x beyond their curvatures' sigmas: "
        f"sigma raised from {sigma * 1e3:.2f} ms")
