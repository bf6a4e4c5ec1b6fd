"""How two pose streams were sampled, decided from their stamps alone.

Three kinds of recording need different handling, and none of them needs a key to say so:

* ``shared_stamps`` — the two streams carry the same stamps (a robot that stops and takes
  one image per stop, "station" data; sample-index stamps; two trackers of the same frames,
  e.g. a SLAM estimate stamped with the ground truth's frame times). The poses are paired
  by stamp; a clock offset cannot be told from such stamps, so none is estimated from them
  (0, or the value given; two continuous streams are checked for an offset their motions
  show, :mod:`simcalib.estimation.hidden_offset`). Shared must beat chance (coarsely
  written stamps coincide by chance), and stamps shared up to a constant shift (one file
  relative, the other unix time) are paired after that shift, which is the offset used
  (``Sampling.shift_s``).
* ``index_stamps`` — the stamps are sample numbers, not times (0, 1, 2, ... with gaps, or a
  file without a time column). Paired by stamp as well, never shifted.
* ``continuous`` — two clocks sampling a moving rig at their own rates. The faster stream is
  interpolated at the slower one's shifted stamps, and the offset is estimated where the data
  can tell it (:mod:`simcalib.estimation.alignment`).

:func:`classify_sampling` returns a :class:`Sampling`; :func:`pair_by_stamp` pairs the poses
of stamp-paired streams one-to-one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Sampling", "classify_sampling", "pair_by_stamp", "lag_shifts", "resolution",
           "median_period", "is_sample_numbers", "SHARED_FRACTION"]

#: share of the sparser stream's stamps that must have a partner for "shared stamps"
SHARED_FRACTION = 0.8
#: streams whose periods differ by this factor or more are refused (stamp units)
MAX_PERIOD_RATIO = 1e6
#: a share of partners that chance would give with a probability below this is not chance
CHANCE_P = 1e-6
#: stamps shared up to a shift: no other shift may pair more than this share as many
SHIFT_RUNNER_UP = 0.5
#: lags (in samples) between the two files' first common stamp that the shift search tries
MAX_SHIFT_LAGS = 16


@dataclass(frozen=True)
class Sampling:
    """The sampling of a pair of streams.

    ``kind``: ``shared_stamps``, ``index_stamps`` or ``continuous``; ``paired_by_stamp``:
    the poses are paired by equal stamps (no interpolation, no offset search);
    ``tolerance_s``: the stamp difference still counted as equal; ``shared``: how many
    stamps of the sparser stream have a partner; ``period_a_s`` / ``period_b_s``: median
    sampling periods; ``reason``: one line for people; ``shift_s``: the constant stamp shift
    ``t_b - t_a`` after which the stamps are shared (0 for equal stamps; the offset used);
    ``resolution_s``: the finer of the two streams' stamp resolutions (:func:`resolution`)."""
    kind: str
    paired_by_stamp: bool
    tolerance_s: float
    shared: int
    n_a: int
    n_b: int
    period_a_s: float
    period_b_s: float
    reason: str
    shift_s: float = 0.0
    resolution_s: float = 0.0
    #: sample-number stamps of a continuous motion: the motions' base step in samples,
    #: chosen from the motion (:func:`simcalib.estimation.hidden_offset.motion_stride`;
    #: replaces ``step_s``, whose seconds such stamps do not have); 0: ``step_s``
    motion_step: int = 0

    def to_dict(self) -> dict:
        return {"kind": self.kind, "paired_by_stamp": self.paired_by_stamp,
                "tolerance_s": self.tolerance_s, "shared_stamps": self.shared,
                "poses_a": self.n_a, "poses_b": self.n_b,
                "period_a_s": self.period_a_s, "period_b_s": self.period_b_s,
                "shift_s": self.shift_s, "resolution_s": self.resolution_s,
                "motion_step": self.motion_step, "reason": self.reason}


def median_period(t: np.ndarray) -> float:
    """The median step between stamps (NaN for fewer than 2)."""
    return float(np.median(np.diff(t))) if t.size >= 2 else math.nan


def is_sample_numbers(t: np.ndarray) -> bool:
    """Stamps that are sample numbers: integers with a unit step most of the time (from 0
    or more, below 1e6)."""
    if t.size < 2 or not np.allclose(t, np.round(t), atol=1e-9, rtol=0):
        return False
    d = np.diff(np.round(t))
    return bool(np.median(d) == 1.0 and t[0] >= 0 and t[-1] < 1e6)


def _partners(t_a: np.ndarray, t_b: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(ia, ib)`` of the stamps of ``a`` with a stamp of ``b`` within ``tol``
    (nearest partner; one-to-one, increasing)."""
    pos = np.clip(np.searchsorted(t_b, t_a), 1, t_b.size - 1) if t_b.size > 1 else \
        np.zeros(t_a.size, dtype=np.int64)
    lo = np.clip(pos - 1, 0, t_b.size - 1)
    near = np.where(np.abs(t_b[lo] - t_a) <= np.abs(t_b[pos] - t_a), lo, pos)
    ok = np.abs(t_b[near] - t_a) <= tol
    ia, ib = np.flatnonzero(ok), near[ok]
    if ib.size:
        keep = np.concatenate([[True], np.diff(ib) > 0])     # one-to-one
        ia, ib = ia[keep], ib[keep]
    return ia, ib


def _check_time_units(t_a, t_b, pa: float, pb: float) -> None:
    """DataError when the two streams' periods differ by MAX_PERIOD_RATIO or more: no two
    pose sensors of one rig do (1 kHz motion capture against one pose in 17 minutes is
    1e6); stamps in different units (ns and s) or sample numbers against times do."""
    if not (pa > 0 and pb > 0) or max(pa, pb) < MAX_PERIOD_RATIO * min(pa, pb):
        return
    from simcalib.errors import DataError
    raise DataError(
        f"the streams' stamps step by {pa:.3g} (a) and {pb:.3g} (b) per pose (median; a "
        f"starts at {t_a[0]:.6g} and spans {t_a[-1] - t_a[0]:.6g}, b starts at {t_b[0]:.6g} "
        f"and spans {t_b[-1] - t_b[0]:.6g}), a factor of "
        f"{max(pa, pb) / min(pa, pb):.3g}: more than two pose sensors of one rig differ "
        f"(at most {MAX_PERIOD_RATIO:.0e}); the stamps are in different units (ns, us, ms, "
        "s?) or one stream is stamped with sample numbers: write both in seconds")


def resolution(t) -> float:
    """The stamps' resolution (s): the largest power of ten (1000 s down) of which 95 % of
    the stamps are multiples (a file written with ``%.2f``: 0.01), else the spacing of the
    floats at the largest stamp (what the numbers can show)."""
    t = np.asarray(t, dtype=np.float64)
    if t.size == 0:
        return 0.0
    eps = float(np.spacing(np.max(np.abs(t))))
    for k in range(3, -10, -1):
        r = 10.0 ** k
        if r < 1e3 * eps:
            break
        if np.mean(np.abs(t - np.round(t / r) * r) <= 1e-3 * r + 4 * eps) >= 0.95:
            return r
    return eps


def _chance_share(sparse, dense, tol: float, res: float) -> float:
    """The share of the sparse stream's stamps that would find a partner in the dense one by
    chance: a window of ``2 tol`` plus the stamps' common resolution ``res`` (stamps on one
    coarse grid coincide whenever the dense stream holds that grid point) against the dense
    stream's mean spacing."""
    spacing = (dense[-1] - dense[0]) / max(dense.size - 1, 1)
    return float(min(1.0, (2.0 * tol + res) / spacing)) if spacing > 0 else 1.0


def _beats_chance(shared: int, n: int, chance: float) -> bool:
    """Whether ``shared`` of ``n`` partners are more than chance would give (binomial tail
    below :data:`CHANCE_P`; ``scipy.special.bdtrc``: scipy.stats would cost ~0.6 s of
    import in every calibrate)."""
    from scipy.special import bdtrc
    return bool(shared > 0 and bdtrc(shared - 1, n, chance) < CHANCE_P)


def lag_shifts(t_a: np.ndarray, t_b: np.ndarray, tol: float) -> list[tuple]:
    """``[(shift, ia, ib)]`` per lag of the rows (-:data:`MAX_SHIFT_LAGS` ..
    :data:`MAX_SHIFT_LAGS`, the same poses, some missing at either end): the median
    difference ``t_b - t_a`` of the rows ``lag`` apart, and the rows whose stamps pair
    within ``tol`` after it (:func:`_partners`)."""
    out = []
    for lag in range(-MAX_SHIFT_LAGS, MAX_SHIFT_LAGS + 1):
        i0, j0 = max(0, -lag), max(0, lag)
        m = min(t_a.size - i0, t_b.size - j0)
        if m >= 3:
            shift = float(np.median(t_b[j0:j0 + m] - t_a[i0:i0 + m]))
            out.append((shift, *_partners(t_a + shift, t_b, tol)))
    return out


def _shift(sparse, dense, tol: float):
    """``(shift, paired, runner_up)``: the constant shift ``dense - sparse`` after which the
    most sparse stamps have a partner within ``tol``, found among the median stamp
    differences at lags -16..16 (the same poses, some missing at either end), and the
    second best lag's count; ``None`` for fewer than 3 stamps."""
    if sparse.size < 3:
        return None
    best = [(ia.size, shift) for shift, ia, _ in lag_shifts(sparse, dense, tol)]
    if not best:
        return None
    best.sort(key=lambda x: -x[0])
    runner = next((c for c, sh in best[1:] if abs(sh - best[0][1]) > tol), 0)
    return best[0][1], best[0][0], runner


def classify_sampling(stream_a, stream_b) -> Sampling:
    """The :class:`Sampling` of two :class:`simcalib.importers.PoseStreamData` (or any
    object with ``timestamps_s``; ``synthetic_time`` marks a file without times).

    Shared stamps must beat chance: stamps written coarsely (``%.2f``: 10 ms) put a 30 Hz
    stream's stamps on a 100 Hz stream's grid by chance. So the sparse stream's partners
    count only when chance would not give them (:func:`_chance_share`, binomial tail below
    :data:`CHANCE_P`) or when the dense stream is mostly paired too (the same stations).
    Failing that, stamps shared up to a constant shift (one file relative, the other unix
    time) are paired after it when no other shift pairs half as many."""
    t_a = np.asarray(stream_a.timestamps_s, dtype=np.float64)
    t_b = np.asarray(stream_b.timestamps_s, dtype=np.float64)
    pa, pb = median_period(t_a), median_period(t_b)
    _check_time_units(t_a, t_b, pa, pb)
    tol = 1e-3 * min(pa, pb) + 1e-9
    a_sparse = t_a.size <= t_b.size
    sparse, dense = (t_a, t_b) if a_sparse else (t_b, t_a)
    ia, ib = _partners(sparse, dense, tol)
    shared = int(ia.size)
    share = shared / max(sparse.size, 1)
    res = min(resolution(t_a), resolution(t_b))
    common = dict(tolerance_s=tol, shared=shared, n_a=int(t_a.size), n_b=int(t_b.size),
                  period_a_s=pa, period_b_s=pb, resolution_s=res)
    synthetic = bool(getattr(stream_a, "synthetic_time", False)
                     or getattr(stream_b, "synthetic_time", False))
    if synthetic or (is_sample_numbers(t_a) and is_sample_numbers(t_b)):
        why = ("a file has no time column (row index used)" if synthetic else
               "both streams are stamped with sample numbers")
        return Sampling("index_stamps", True, reason=f"{why}: poses paired by index "
                        f"({shared} of {sparse.size} shared), no clock offset estimated",
                        **{**common, "tolerance_s": 1e-6})
    chance = _chance_share(sparse, dense, tol, res)
    if share >= SHARED_FRACTION and (_beats_chance(shared, sparse.size, chance)
                                     or ib.size >= SHARED_FRACTION * dense.size):
        return Sampling("shared_stamps", True, reason=(
            f"{shared} of {sparse.size} stamps are shared by both streams (within "
            f"{tol * 1e3:.3g} ms; chance would pair {100 * chance:.3g} %): poses paired by "
            "stamp; equal stamps cannot show a clock offset, so none is estimated (give "
            "time_offset= to shift b)"), **common)
    shifted = _shifted(sparse, dense, tol, res, min(pa, pb), a_sparse, common)
    if shifted is not None:
        return shifted
    why = (f"; {100 * share:.3g} % shared, but stamps of {res:.3g} s resolution pair "
           f"{100 * chance:.3g} % by chance" if share >= SHARED_FRACTION else "")
    return Sampling("continuous", False, reason=(
        f"two clocks ({1 / pa:.3g} Hz and {1 / pb:.3g} Hz, {shared} of {sparse.size} "
        f"stamps shared{why}): the faster stream is interpolated at the slower one's "
        "stamps"), **common)


def _shifted(sparse, dense, tol, res, period, a_sparse, common) -> Sampling | None:
    """The ``shared_stamps`` :class:`Sampling` of stamps shared after a constant shift
    (:func:`_shift`, within ``tol`` plus the stamps' resolution, at most a tenth of a
    period), when it pairs :data:`SHARED_FRACTION` of the sparse stream's stamps and no
    other shift pairs half as many (regular stamps, equal at many shifts, cannot tell one);
    else None."""
    tol_s = tol + min(res, 0.1 * period)
    found = _shift(sparse, dense, tol_s)
    if found is None:
        return None
    shift, paired, runner = found
    if paired < SHARED_FRACTION * sparse.size or runner > SHIFT_RUNNER_UP * paired:
        return None
    offset = shift if a_sparse else -shift                  # t_b - t_a
    return Sampling("shared_stamps", True, reason=(
        f"{paired} of {sparse.size} stamps are shared by both streams after a constant "
        f"shift of {offset:.9g} s (t_b - t_a; the next best shift pairs {runner}): poses "
        "paired by stamp after that shift, which is the offset reported; no other offset "
        "is estimated (give time_offset= to set it)"),
        **{**common, "tolerance_s": tol_s, "shared": paired}, shift_s=offset)


def pair_by_stamp(stream_a, stream_b, sampling: Sampling, offset_s: float = 0.0):
    """:class:`simcalib.estimation.alignment.SyncedPoses` of the poses whose stamps (b shifted by
    ``-offset_s``) agree within the sampling's tolerance, one-to-one."""
    from simcalib.estimation.alignment import SyncedPoses
    from simcalib.estimation.worlds import instant_worlds
    t_a = np.asarray(stream_a.timestamps_s, dtype=np.float64)
    t_b = np.asarray(stream_b.timestamps_s, dtype=np.float64) - offset_s
    ia, ib = _partners(t_a, t_b, sampling.tolerance_s)
    counts = {"reference_stamps": int(t_a.size), "outside_overlap": int(t_a.size - ia.size),
              "in_gaps": 0, "kept": int(ia.size), "paired_by_stamp": True}
    world, _ = instant_worlds(stream_a, stream_b, t_a[ia], t_b[ib] + offset_s, "both")
    return SyncedPoses(t_a[ia], np.asarray(stream_a.T_world_sensor)[ia],
                       np.asarray(stream_b.T_world_sensor)[ib], "a", counts, world)
