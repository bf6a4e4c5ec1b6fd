"""Motion formation: which pairs of synchronised poses become the motions ``(C_i, H_i)``.

A policy is a small function ``(synced, options) -> (i, j, how[, stations])`` in
:data:`POLICIES` (the pose pairs, in words how, and the station of every pose for
``bursts``); :func:`form_motions` makes the :class:`MotionSet`:

* ``stations`` — pairs of poses far apart in the recording: every pair ``i < j`` when there
  are at most :data:`ALL_PAIRS_MAX` poses (what OpenCV's solvers build from stop-and-go
  data), otherwise pairs at a geometric set of index distances (1, 2, 3, 5, 8, ...), so
  each pose still meets far partners. For stop-and-go ("station") data and sample-index
  stamps.
* ``spans`` — from every synchronised instant to the instants 1, 2, 4 and 8 ``step_s``
  later (spans up to half the recording; :func:`span_strides`), counted in samples of the
  median period. Long baselines: a motion over 8 s turns far more than one over 1 s, and
  the error of X from the pose noise falls with the rotation the motions carry (all i<j
  pairs, as OpenCV's solvers take them, go further still but grow with the square of the
  poses). For continuous recordings.
* ``consecutive`` — from every synchronised instant to the first one ``step_s`` later
  (overlapping motions of a continuous recording; one span of ``spans``, in time).
* ``keyframes`` — non-overlapping motions, each ending where stream a has turned by
  ``min_rotation_deg`` since the last keyframe.
* ``bursts`` — stop-and-go data with several poses per stop (a camera taking a burst of
  frames at each station, or detecting the target only while the arm stands still): the
  poses fall into runs that stand still (:func:`station_runs`), and frame ``r`` of a
  station is joined to frame ``r`` of every other station (of a geometric set of them
  above :data:`ALL_PAIRS_MAX` stations). Poses of one station are never joined: their
  motion is noise. Each pose meets every other station once, so no pose's noise counts
  more than another's.

Why ``spans`` counts samples, not seconds: joined by a fixed index distance, every pose
starts exactly one motion and ends exactly one of each span, so along a smooth path the
noise of a pose enters two neighbouring motions with opposite signs and nearly cancels in
X. Joined by time ("the first instant 1 s later"), a dropped frame or a gap makes several
motions end on the same pose (all that start within the gap's length before it) and
others on none: that pose's noise then counts many times over. On the generated
recordings with a 1-3 s gap in the 100 Hz stream this tripled X's translation error (gaps
seeds 3, 5: 1.3 / 0.8 mm by time, 0.3 / 0.1 mm by samples; OpenCV Park 0.49 / 0.23 mm).

``auto`` (the default) takes ``stations`` for sample-index data and stamp-paired
stop-and-go data (consecutive poses far apart) of at most :data:`STATIONS_MAX` poses, and
``bursts`` when the synchronised poses come in runs that stand still (several poses per
stop), and ``spans`` otherwise (continuous tracks, even when they share their stamps), and
says why. Motions whose
rotation (mean of the two streams' angles) is below ``min_rotation_deg`` are dropped (they
carry no information) unless fewer than 3 would remain; above ``max_rotation_deg`` too.

Every motion remembers its two pose indices (``i``, ``j``), so the uncertainty knows which
motions share a pose (:func:`simcalib.solve`'s ``pose_pairs``); ``MotionSet.passes`` says
how many spans pass over the same poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simcalib.errors import DataError, unknown_choice
from simcalib.geometry import invert_transform, rotation_angle_rad

__all__ = ["MotionSet", "form_motions", "span_pairs", "span_strides", "station_runs",
           "POLICIES", "ALL_PAIRS_MAX", "STATIONS_MAX", "MAX_SPANS", "SPAN_SHARE"]

ALL_PAIRS_MAX = 64          # up to this many poses: every pair
STATIONS_MAX = 600          # stamp-paired recordings up to this many poses: stations


@dataclass(frozen=True, eq=False)
class MotionSet:
    """Motions ``C = T_a[i]^-1 T_a[j]``, ``H = T_b[i]^-1 T_b[j]`` (``C X = X H``) between
    synchronised poses ``i`` -> ``j``; ``policy`` the policy used and ``reason`` why;
    ``counts``: formed, dropped for small / large rotation, kept."""
    C: np.ndarray = field(repr=False)
    H: np.ndarray = field(repr=False)
    i: np.ndarray = field(repr=False)
    j: np.ndarray = field(repr=False)
    policy: str
    reason: str
    counts: dict = field(default_factory=dict)
    #: how many times the motions pass over the same poses (``spans``: one full set per
    #: span); the cost sums them, so a prior's weights are scaled by it
    passes: int = 1
    #: ``bursts``: the station (0, 1, ...) of every synchronised pose; None otherwise
    stations: np.ndarray | None = field(default=None, repr=False)

    @property
    def n(self) -> int:
        return int(self.C.shape[0])

    @property
    def pose_pairs(self) -> np.ndarray:
        return np.stack([self.i, self.j], axis=1)

    def subset(self, mask) -> "MotionSet":
        m = np.asarray(mask, dtype=bool)
        return MotionSet(self.C[m], self.H[m], self.i[m], self.j[m], self.policy,
                         self.reason, dict(self.counts), self.passes, self.stations)


def _strides(n: int) -> np.ndarray:
    s, out = [1, 2], []
    while s[-1] < n:
        s.append(s[-1] + s[-2])
    for d in [1, 2] + s[2:]:
        if d < n and d not in out:
            out.append(d)
    return np.asarray(out, dtype=np.int64)


def _stations(synced, options):
    n = synced.n
    if n <= ALL_PAIRS_MAX:
        i, j = np.triu_indices(n, k=1)
        how = f"every pair of the {n} poses"
    else:
        d = _strides(n)
        i = np.concatenate([np.arange(n - s) for s in d])
        j = np.concatenate([np.arange(s, n) for s in d])
        how = (f"pairs of the {n} poses {', '.join(map(str, d[:6]))}"
               f"{', ...' if d.size > 6 else ''} apart")
    return i.astype(np.int64), j.astype(np.int64), how


def span_pairs(t: np.ndarray, step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(i, j)``: from every stamp ``t[i]`` to the first ``t[j]`` at least ``step_s`` less
    half the median period (or half ``step_s``, if shorter) later, never across a gap
    (``t[j] - t[i] <= 2 step_s``). A step of exactly k periods gives ``j = i + k`` whatever
    the rounding and the jitter of the stamps (below half a period): which pose ends a
    motion does not depend on the sign of its stamp's error. (Joined to the first stamp a
    hair short of ``step_s`` later, a motion ended on ``i + k`` only when that stamp ran
    late enough, else on ``i + k + 1``: the chosen ends' stamps ran late on average, and
    the clock offset read from such motions came out ~0.1 ms too large with 1 ms of stamp
    jitter at 30 Hz.)"""
    if not (step_s > 0 and math.isfinite(step_s)):
        raise ValueError(f"step_s must be finite and > 0; received {step_s}")
    period = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    tol = 0.5 * min(period, step_s) + 1e-9
    j = np.searchsorted(t, t + step_s - tol, side="left")
    i = np.arange(t.size)
    ok = j < t.size
    i, j = i[ok], j[ok]
    ok = t[j] - t[i] <= 2.0 * step_s + tol
    return i[ok], j[ok]


def _consecutive(synced, options):
    step_s = options.get("step_s", 1.0)
    i, j = span_pairs(synced.time_s, step_s)
    return i, j, f"from every instant to the first {step_s:g} s later"


#: the spans policy: every instant joined to the instants 1, 2, 4, ... x step_s later, as
#: long as a span is at most this share of the recording ...
SPAN_SHARE = 0.5
#: ... and at most this many spans (1, 2, 4, 8 x step_s)
MAX_SPANS = 4


def span_strides(t: np.ndarray, step_s: float) -> np.ndarray:
    """The index strides of the ``spans`` policy for stamps ``t``: ``step_s`` doubled up to
    :data:`MAX_SPANS` times while a span stays within :data:`SPAN_SHARE` of the recording
    (at least ``step_s``), each in samples of the median period (at least 1)."""
    if t.size < 2:
        return np.zeros(0, dtype=np.int64)
    period = float(np.median(np.diff(t)))
    length = float(t[-1] - t[0])
    spans = [step_s]
    while len(spans) < MAX_SPANS and 2 * spans[-1] <= SPAN_SHARE * length:
        spans.append(2 * spans[-1])
    k = np.unique(np.maximum(1, np.round(np.asarray(spans) / period)).astype(np.int64))
    return k[k < t.size]


def _spans(synced, options):
    t = synced.time_s
    step_s = options.get("step_s", 1.0)
    k = span_strides(t, step_s)
    i = np.concatenate([np.arange(t.size - s) for s in k]) if k.size else np.zeros(0)
    j = np.concatenate([np.arange(s, t.size) for s in k]) if k.size else np.zeros(0)
    period = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    return (i.astype(np.int64), j.astype(np.int64),
            "from every instant to the one " + ", ".join(str(int(s)) for s in k)
            + f" samples later (~{', '.join(f'{s * period:.3g}' for s in k)} s)")


def _keyframes(synced, options):
    t = synced.time_s
    thr = math.radians(options.get("min_rotation_deg") or 5.0)
    R = synced.T_a[:, :3, :3]
    ii, jj, i = [], [], 0
    while i < t.size - 1:
        hit = np.flatnonzero(rotation_angle_rad(R[i].T[None] @ R[i + 1:]) >= thr)
        if hit.size == 0:
            break
        ii.append(i)
        jj.append(i + 1 + int(hit[0]))
        i = jj[-1]
    return (np.asarray(ii, dtype=np.int64), np.asarray(jj, dtype=np.int64),
            f"keyframes every {math.degrees(thr):g} deg of a's rotation")


#: a stamp-paired recording whose consecutive poses turn by less than this (median) is a
#: continuous track that happens to share its stamps, not stop-and-go stations; a turn this
#: large between consecutive poses (in both streams) starts a new station of ``bursts``
STATION_STEP_DEG = 5.0
#: a run of poses that stays within this of its first pose (in the stiller stream) stands
#: still: one station of ``bursts``
STATION_SPREAD_DEG = 1.0
#: the same in translation (m; a rig that does not turn stops at stations too, a gantry):
#: a step this long between consecutive poses (in both streams) starts a new station ...
STATION_STEP_M = 0.025
#: ... and a run within this of its first pose (in the stiller stream) stands still
#: (:data:`simcalib.estimation.stillness.STILL_M`)
STATION_SPREAD_M = 0.005


def _turn_deg(T, i, j) -> np.ndarray:
    R = T[:, :3, :3]
    return np.degrees(rotation_angle_rad(np.swapaxes(R[i], -1, -2) @ R[j]))


def _shift_m(T, i, j) -> np.ndarray:
    return np.linalg.norm(T[j, :3, 3] - T[i, :3, 3], axis=-1)


def _moved(synced, i, j) -> tuple[np.ndarray, np.ndarray]:
    """``(turn deg, shift m)`` from pose ``i`` to pose ``j``, each in the stream that moves
    less there (one noisy or outlying stream cannot split or join stations)."""
    return (np.minimum(_turn_deg(synced.T_a, i, j), _turn_deg(synced.T_b, i, j)),
            np.minimum(_shift_m(synced.T_a, i, j), _shift_m(synced.T_b, i, j)))


def station_runs(synced) -> np.ndarray | None:
    """The station (0, 1, ...) of every synchronised pose when the poses come in runs that
    stand still (stop-and-go with several poses per stop): a new run starts where both
    streams move from one pose to the next - turn by :data:`STATION_STEP_DEG` or translate
    by :data:`STATION_STEP_M` or more -, every run stays within :data:`STATION_SPREAD_DEG`
    and :data:`STATION_SPREAD_M` of its first pose (in the stream that moves less there),
    and most runs hold several poses (a continuous track that moves that far between its
    poses, a car at 10 Hz, is no station data). None when that is not so, or fewer than 3
    stations."""
    n = synced.n
    if n < 3:
        return None
    turn, shift = _moved(synced, np.arange(n - 1), np.arange(1, n))
    cut = (turn >= STATION_STEP_DEG) | (shift >= STATION_STEP_M)
    labels = np.concatenate([[0], np.cumsum(cut)]).astype(np.int64)
    if labels[-1] + 1 < 3 or np.median(np.bincount(labels)) < 2:
        return None
    first = np.flatnonzero(np.concatenate([[True], cut]))[labels]
    turn, shift = _moved(synced, first, np.arange(n))
    still = float(turn.max()) < STATION_SPREAD_DEG and float(shift.max()) < STATION_SPREAD_M
    return labels if still else None


def _bursts(synced, options):
    runs = options.get("stations")          # auto has found them already
    runs = station_runs(synced) if runs is None else runs
    if runs is None:
        raise DataError(f"motions=bursts needs poses that stand still in runs of a station "
                        f"each (>= 3 stations, each within {STATION_SPREAD_DEG:g} deg, "
                        f"{STATION_STEP_DEG:g} deg or more between them); these "
                        f"{synced.n} poses do not (or move {STATION_STEP_M * 1e3:g} mm "
                        f"between stations, each within {STATION_SPREAD_M * 1e3:g} mm): use "
                        "motions=auto")
    first = np.flatnonzero(np.diff(np.concatenate([[-1], runs])))
    size = np.diff(np.concatenate([first, [synced.n]]))
    k = first.size
    if k <= ALL_PAIRS_MAX:
        s, u = np.triu_indices(k, k=1)
        which = "every other station"
    else:
        d = _strides(k)
        s = np.concatenate([np.arange(k - x) for x in d])
        u = np.concatenate([np.arange(x, k) for x in d])
        which = f"the stations {', '.join(map(str, d[:6]))}{', ...' if d.size > 6 else ''} on"
    m = np.minimum(size[s], size[u])
    r = np.arange(m.sum()) - np.repeat(np.cumsum(m) - m, m)
    i = np.repeat(first[s], m) + r
    j = np.repeat(first[u], m) + r
    return (i.astype(np.int64), j.astype(np.int64),
            f"frame r of each station joined to frame r of {which} ({synced.n} poses at "
            f"{k} stations, {int(size.min())}..{int(size.max())} a station)", runs)


POLICIES = {"stations": _stations, "consecutive": _consecutive, "spans": _spans,
            "keyframes": _keyframes, "bursts": _bursts}


def _median_step_deg(synced) -> float:
    return float(np.median(_turn_deg(synced.T_a, np.arange(synced.n - 1),
                                     np.arange(1, synced.n))))


def auto_policy(synced, paired_by_stamp: bool, index_stamps: bool = False
                ) -> tuple[str, str, np.ndarray | None]:
    """``(policy, reason, stations)`` chosen from the data: ``stations`` for sample-index
    data and for stamp-paired data whose consecutive poses are far apart (median turn >=
    :data:`STATION_STEP_DEG`), up to :data:`STATIONS_MAX` poses; ``bursts`` where the poses
    stand still in runs (``stations``: :func:`station_runs`, else None); ``spans`` else."""
    step = _median_step_deg(synced) if synced.n > 1 else 0.0
    if paired_by_stamp and synced.n <= STATIONS_MAX and (index_stamps
                                                         or step >= STATION_STEP_DEG):
        return "stations", (f"{synced.n} stamp-paired poses ("
                            + ("sample-index stamps" if index_stamps else
                               f"stop-and-go: consecutive poses {step:.3g} deg apart")
                            + "): pairs of poses far apart"), None
    runs = station_runs(synced)
    if runs is not None:
        return "bursts", (f"{synced.n} {'stamp-paired ' if paired_by_stamp else ''}poses "
                          f"standing still at {int(runs[-1]) + 1} stations (stop-and-go, "
                          "several poses a stop): pairs of stations"), runs
    if paired_by_stamp and synced.n <= STATIONS_MAX:
        return "spans", (f"{synced.n} stamp-paired poses of a continuous track "
                         f"(consecutive poses {step:.3g} deg apart): motions over several "
                         "time spans"), None
    if paired_by_stamp:
        return "spans", (f"{synced.n} stamp-paired poses, too many for pairs: motions over "
                         "several time spans"), None
    return "spans", "a continuous recording: motions over several time spans", None


def form_motions(synced, policy: str = "auto", *, paired_by_stamp: bool = False,
                 index_stamps: bool = False, step_s: float = 1.0,
                 min_rotation_deg: float | None = 2.0,
                 max_rotation_deg: float | None = None) -> MotionSet:
    """The :class:`MotionSet` of ``synced`` (:class:`simcalib.estimation.alignment.SyncedPoses`) under
    ``policy`` (``auto`` or a name of :data:`POLICIES`); ``paired_by_stamp`` /
    ``index_stamps`` from the sampling (:mod:`simcalib.estimation.sampling`)."""
    if synced.n < 2:
        raise DataError(f"only {synced.n} synchronised pose(s); at least 2 are needed (do "
                        "the streams overlap in time?)")
    reason, runs = "given", None
    if policy == "auto":
        policy, reason, runs = auto_policy(synced, paired_by_stamp, index_stamps)
    if policy not in POLICIES:
        raise unknown_choice("motion policy", policy, list(POLICIES) + ["auto"], key="motions")
    opts = {"step_s": step_s, "min_rotation_deg": min_rotation_deg, "stations": runs}
    i, j, how, *runs = POLICIES[policy](synced, opts)
    C = invert_transform(synced.T_a[i]) @ synced.T_a[j]
    H = invert_transform(synced.T_b[i]) @ synced.T_b[j]
    ang = 0.5 * (rotation_angle_rad(C[:, :3, :3]) + rotation_angle_rad(H[:, :3, :3]))
    keep = np.ones(ang.shape, dtype=bool)
    counts = {"formed": int(i.size)}
    world = getattr(synced, "world", None)
    if world is not None:               # never across a jump of a world frame
        keep = world[i] == world[j]
        counts["dropped_across_world_jump"] = int((~keep).sum())
    if min_rotation_deg and policy != "keyframes":
        small = ang < math.radians(min_rotation_deg)
        enough = (~small & keep).sum() >= 3   # else keep them: better than no motions
        counts["dropped_small_rotation"] = int((small & keep).sum()) if enough else 0
        keep &= ~small if enough else keep
    if max_rotation_deg is not None:
        big = ang > math.radians(max_rotation_deg)
        counts["dropped_large_rotation"] = int((big & keep).sum())
        keep &= ~big
    counts["kept"] = int(keep.sum())
    passes = int(np.unique(j - i).size) if policy == "spans" and i.size else 1
    return MotionSet(C[keep], H[keep], i[keep], j[keep], policy,
                     f"{reason}; {how}", counts, passes, runs[0] if runs else None)
