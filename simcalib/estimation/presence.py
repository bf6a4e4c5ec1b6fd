"""Where a camera sees: the clock offset of a stop-and-go recording from its times alone.

In a stop-and-go recording the camera (b) sees the target only while the rig stands still:
its poses come in clusters, one per stop, with gaps where the rig moved. Within a cluster b
does not move, so neither the speeds' correlation nor the calibration cost tells an
offset, and none is needed while the clocks agree (b's poses at a stop pair with a's at
that stop, whatever the offset within it). With the clocks tens of seconds apart (two
computers) they do not: generated stop-and-go recordings with b 30 s late were aligned at
-20.2 s (a weak translation-speed peak, r = 0.34) and X came out 150 deg off.

b's clusters must fall on a's stops. :func:`presence_offset` slides b's stamps over the
offsets allowed and keeps those that put at least :data:`FIT_SHARE` of b's samples where
a stands still (a's angular and translation speeds both below :data:`STILL_SHARE` of their
90th percentiles); the run of such offsets that puts the most of b's samples there gives
the offset, its centre, and its sigma, the run's width over sqrt(12), unless another run
puts nearly as many there (:data:`RIVAL_SHARE`: stops at a regular pace). (Any second run
used to refuse: with b 36 s late, an offset at which only half of b overlapped a and its
few clusters there fell on stops by chance left the offset at 0 and X 159 deg off.)
Within a stop nothing tells the offset: its error is up to about half the stop's slack
(the camera's settling, ~0.15 s on the generated recordings), within its sigma; nor does it
matter there (``TimeOffset.at_stops``: X's covariance takes nothing from it). It is used
(:func:`checked`) only where the offset decided otherwise puts fewer than
:data:`USED_SHARE` of b's samples where a stands still, or fewer than :data:`RIVAL_SHARE`
as many as the run does (b 19 s late, offset 0 put 89 % of the part of b inside a's span
on stops, by chance, and X came out 110 deg off), so recordings whose clocks agree keep
their offset.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from simcalib.geometry import rotation_angle_rad

__all__ = ["clustered", "still_share", "presence_offset", "checked", "FIT_SHARE",
           "STILL_SHARE", "USED_SHARE", "MIN_GAPS", "RIVAL_SHARE", "BASELINE_S"]

#: an offset fits where this share of b's samples falls where a stands still
FIT_SHARE = 0.95
#: a stands still where its speeds are below this share of their 90th percentiles
STILL_SHARE = 0.1
#: the offset decided otherwise is kept where this share of b's samples or more falls
#: where a stands still (at the right offset 0.99 on generated stop-and-go recordings; at
#: a wrong one about the share of a's time it stands still, 0.55-0.6 there)
USED_SHARE = 0.8
#: b comes in clusters: at least this many gaps of 10 median steps and 0.5 s or more
MIN_GAPS = 3
#: a second run of fitting offsets is a rival of the one that puts the most of b's samples
#: where a stands still where it puts at least this share of as many there: stops at a
#: regular pace shifted by one stop keep (k - 1) / k of them (>= 0.75 from the 4 stops
#: that :data:`MIN_GAPS` asks for); an offset at which only part of b overlaps a and its
#: few clusters there fall on stops by chance puts about that part (half: 0.5)
RIVAL_SHARE = 0.75


def clustered(tb: np.ndarray) -> bool:
    """b's stamps come in clusters (stops) apart by gaps (:data:`MIN_GAPS` or more)."""
    d = np.diff(np.asarray(tb, dtype=np.float64))
    if d.size < 2 * MIN_GAPS:
        return False
    gaps = d > max(10.0 * float(np.median(d)), 0.5)
    return int(gaps.sum()) >= MIN_GAPS


#: a's speeds are taken over this baseline (s), longer than its pose noise's reach
BASELINE_S = 0.25


def _still(ta: np.ndarray, Ta: np.ndarray) -> np.ndarray:
    """Per a's sample: the rig stands still there (its speeds between the samples
    :data:`BASELINE_S` before and after, below :data:`STILL_SHARE` of their 90th
    percentiles: pose noise over one short step would read as motion)."""
    n = ta.size
    k = max(1, int(round(BASELINE_S / max(float(np.median(np.diff(ta))), 1e-9))))
    i0, i1 = np.clip(np.arange(n) - k, 0, n - 1), np.clip(np.arange(n) + k, 0, n - 1)
    dt = np.maximum(ta[i1] - ta[i0], 1e-9)
    turn = rotation_angle_rad(np.swapaxes(Ta[i0, :3, :3], -1, -2) @ Ta[i1, :3, :3]) / dt
    move = np.linalg.norm(Ta[i1, :3, 3] - Ta[i0, :3, 3], axis=1) / dt
    return (turn <= STILL_SHARE * np.percentile(turn, 90)) & (
        move <= STILL_SHARE * np.percentile(move, 90))


def still_share(ta, Ta, tb, offsets) -> np.ndarray:
    """For each offset (``t_b - t_a``), the share of b's samples inside a's span whose
    nearest sample of a stands still (NaN where fewer than half of b's samples are
    inside)."""
    return _still_counts(ta, Ta, tb, offsets)[0]


def _still_counts(ta, Ta, tb, offsets) -> tuple[np.ndarray, np.ndarray]:
    """:func:`still_share` and, per offset, how many of b's samples fall inside a's span."""
    ta, tb = np.asarray(ta, np.float64), np.asarray(tb, np.float64)
    still = _still(ta, np.asarray(Ta, np.float64))
    offsets = np.asarray(offsets, np.float64)
    chunk = max(1, 2_000_000 // max(tb.size, 1))            # bounded memory per chunk
    out = [_shares(ta, still, tb, offsets[k:k + chunk]) for k in range(0, offsets.size, chunk)]
    if not out:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    return np.concatenate([s for s, _ in out]), np.concatenate([n for _, n in out])


def _shares(ta, still, tb, offsets) -> tuple[np.ndarray, np.ndarray]:
    t = tb[None, :] - offsets[:, None]                      # b's samples on a's clock
    inside = (t >= ta[0]) & (t < ta[-1])
    k = np.clip(np.searchsorted(ta, t), 1, ta.size - 1)
    k = np.where(t - ta[k - 1] < ta[k] - t, k - 1, k)        # the nearest sample of a
    n = inside.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = (still[k] & inside).sum(axis=1) / n
    return np.where(n >= 0.5 * tb.size, share, np.nan), n


def presence_offset(ta, Ta, tb, window) -> tuple[float, float] | None:
    """``(offset, sigma)``: the run of offsets in ``window`` (s, a's and b's clocks'
    difference) at which b's samples fall where a stands still (:data:`FIT_SHARE`) that
    puts the most of them there, or None where no offset fits or another run is its rival
    (:data:`RIVAL_SHARE`)."""
    found = _best_run(ta, Ta, tb, window)
    return None if found is None else found[:2]


def _best_run(ta, Ta, tb, window) -> tuple[float, float, float] | None:
    """:func:`presence_offset` and how many of b's samples its run puts where a stands
    still (at most)."""
    step = min(float(np.median(np.diff(tb))), 0.05)
    lo, hi = window
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return None
    offsets = np.arange(lo, hi + step, step)
    share, inside = _still_counts(ta, Ta, tb, offsets)
    fit = share >= FIT_SHARE
    if not fit.any():
        return None
    edges = np.flatnonzero(np.diff(np.concatenate([[0], fit.astype(np.int8), [0]])))
    runs = list(zip(edges[::2], edges[1::2]))
    placed = np.where(fit, share * inside, 0.0)             # b's samples on a's stops
    support = np.array([placed[i0:i1].max() for i0, i1 in runs])
    best = int(np.argmax(support))
    if np.sum(support >= RIVAL_SHARE * support[best]) > 1:
        return None
    i0, i1 = runs[best]
    width = (i1 - i0) * step
    return (float(0.5 * (offsets[i0] + offsets[i1 - 1])), width / math.sqrt(12.0),
            float(support[best]))


def checked(off, ta, Ta, tb):
    """The :class:`~simcalib.estimation.alignment.TimeOffset` ``off``, or where b comes in
    clusters and ``off`` puts fewer than :data:`USED_SHARE` of its samples where a stands
    still, or fewer than :data:`RIVAL_SHARE` as many as the run of :func:`presence_offset`
    does, that run's offset (module doc); ``off`` as it is, its message saying so, where
    none fits."""
    if not clustered(tb) or off.drift != 0.0:
        return off
    share, inside = _still_counts(ta, Ta, tb, [off.offset_s])
    used, placed = float(share[0]), float(np.nan_to_num(share[0]) * inside[0])
    if used >= USED_SHARE and placed >= RIVAL_SHARE * tb.size:     # no run can beat it
        return off
    found = _best_run(ta, Ta, tb, off.window_s)
    if used >= USED_SHARE and (found is None or placed >= RIVAL_SHARE * found[2]):
        return off
    where = ("most of b's samples fall outside a's span" if math.isnan(used) else
             f"only {used:.0%} of b's samples fall where a stands still"
             if used < USED_SHARE else f"only {placed:.0f} of b's {tb.size} samples fall "
             f"where a stands still ({used:.0%} of those inside a's span)")
    head = (f"; at {off.offset_s * 1e3:.1f} ms {where}, though b comes in clusters (a "
            "camera that sees while the rig stops?)")
    if found is None:
        return replace(off, message=off.message + head + ": no offset puts them there, the "
                       "offset may be wrong")
    offset, sigma, _ = found
    return replace(off, offset_s=offset, uncertainty_s=sigma, drift=0.0, refined=False,
                   decision="estimated", split=None, evidence=float("nan"), why_zero="",
                   at_stops=True,
                   message=off.message + head + f": {offset * 1e3:.1f} +- {sigma * 1e3:.1f}"
                   f" ms puts {FIT_SHARE:.0%} or more of them there, and is used")
