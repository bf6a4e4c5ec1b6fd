"""How two pose streams were sampled, decided from their stamps alone.

Three kinds of recording need different handling, and none of them needs a key to say so:

* ``shared_stamps`` — the two streams carry the same stamps (a robot that stops and takes
  one image per stop, "station" data; sample-index stamps; two trackers of the same frames,
  e.g. a SLAM estimate stamped with the ground truth's frame times). The poses are paired
  by stamp; a clock offset cannot be told from such stamps, so none is estimated (0, or the
  value given).
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

__all__ = ["Sampling", "classify_sampling", "pair_by_stamp", "SHARED_FRACTION"]

#: share of the sparser stream's stamps that must have a partner for "shared stamps"
SHARED_FRACTION = 0.8
#: streams whose periods differ by this factor or more are refused (stamp units)
MAX_PERIOD_RATIO = 1e6


@dataclass(frozen=True)
class Sampling:
    """The sampling of a pair of streams.

    ``kind``: ``shared_stamps``, ``index_stamps`` or ``continuous``; ``paired_by_stamp``:
    the poses are paired by equal stamps (no interpolation, no offset search);
    ``tolerance_s``: the stamp difference still counted as equal; ``shared``: how many
    stamps of the sparser stream have a partner; ``period_a_s`` / ``period_b_s``: median
    sampling periods; ``reason``: one line for people."""
    kind: str
    paired_by_stamp: bool
    tolerance_s: float
    shared: int
    n_a: int
    n_b: int
    period_a_s: float
    period_b_s: float
    reason: str

    def to_dict(self) -> dict:
        return {"kind": self.kind, "paired_by_stamp": self.paired_by_stamp,
                "tolerance_s": self.tolerance_s, "shared_stamps": self.shared,
                "poses_a": self.n_a, "poses_b": self.n_b,
                "period_a_s": self.period_a_s, "period_b_s": self.period_b_s,
                "reason": self.reason}


def _period(t: np.ndarray) -> float:
    return float(np.median(np.diff(t))) if t.size >= 2 else math.nan


def _is_index(t: np.ndarray) -> bool:
    """Stamps that are sample numbers: integers with a unit step most of the time."""
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


def classify_sampling(stream_a, stream_b) -> Sampling:
    """The :class:`Sampling` of two :class:`simcalib.importers.PoseStreamData` (or any
    object with ``timestamps_s``; ``synthetic_time`` marks a file without times)."""
    t_a = np.asarray(stream_a.timestamps_s, dtype=np.float64)
    t_b = np.asarray(stream_b.timestamps_s, dtype=np.float64)
    pa, pb = _period(t_a), _period(t_b)
    _check_time_units(t_a, t_b, pa, pb)
    tol = 1e-3 * min(pa, pb) + 1e-9
    sparse, dense = (t_a, t_b) if t_a.size <= t_b.size else (t_b, t_a)
    ia, _ = _partners(sparse, dense, tol)
    shared = int(ia.size)
    share = shared / max(sparse.size, 1)
    common = dict(tolerance_s=tol, shared=shared, n_a=int(t_a.size), n_b=int(t_b.size),
                  period_a_s=pa, period_b_s=pb)
    synthetic = bool(getattr(stream_a, "synthetic_time", False)
                     or getattr(stream_b, "synthetic_time", False))
    if synthetic or (_is_index(t_a) and _is_index(t_b)):
        why = ("a file has no time column (row index used)" if synthetic else
               "both streams are stamped with sample numbers")
        return Sampling("index_stamps", True, reason=f"{why}: poses paired by index "
                        f"({shared} of {sparse.size} shared), no clock offset estimated",
                        **{**common, "tolerance_s": 1e-6})
    if share >= SHARED_FRACTION:
        return Sampling("shared_stamps", True, reason=(
            f"{shared} of {sparse.size} stamps are shared by both streams (within "
            f"{tol * 1e3:.3g} ms): poses paired by stamp; equal stamps cannot show a clock "
            "offset, so none is estimated (give time_offset= to shift b)"), **common)
    return Sampling("continuous", False, reason=(
        f"two clocks ({1 / pa:.3g} Hz and {1 / pb:.3g} Hz, {shared} of {sparse.size} "
        "stamps shared): the faster stream is interpolated at the slower one's stamps"),
        **common)


def pair_by_stamp(stream_a, stream_b, sampling: Sampling, offset_s: float = 0.0):
    """:class:`simcalib.estimation.alignment.SyncedPoses` of the poses whose stamps (b shifted by
    ``-offset_s``) agree within the sampling's tolerance, one-to-one."""
    from simcalib.estimation.alignment import SyncedPoses
    t_a = np.asarray(stream_a.timestamps_s, dtype=np.float64)
    t_b = np.asarray(stream_b.timestamps_s, dtype=np.float64) - offset_s
    ia, ib = _partners(t_a, t_b, sampling.tolerance_s)
    counts = {"reference_stamps": int(t_a.size), "outside_overlap": int(t_a.size - ia.size),
              "in_gaps": 0, "kept": int(ia.size), "paired_by_stamp": True}
    return SyncedPoses(t_a[ia], np.asarray(stream_a.T_world_sensor)[ia],
                       np.asarray(stream_b.T_world_sensor)[ib], "a", counts)
