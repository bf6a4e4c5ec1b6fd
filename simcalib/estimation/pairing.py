"""Relative motions ``(C_i, H_i)`` from two cameras' pose streams.

1. **Matching.** The two streams are matched by timestamp, one-to-one, closest pairs
   first (see :func:`match_by_timestamp`). A matched pair is a *datapoint*.
2. **Pre-filter, timestamps** (appendix D.1 of the paper): datapoints whose two timestamps
   differ by more than ``max_time_diff_s`` (0.1 s) are dropped.
3. **Pairs.** Datapoint ``k`` is paired with datapoint ``k + step``:
   ``C = T_w_a[k]^-1 T_w_a[k+step]`` and ``H = T_w_b[k]^-1 T_w_b[k+step]``, so that
   ``C X = X H`` with ``X = T_a_b`` (docs/paper-notes.md).
4. **Pre-filter, motion** (appendix D.1): pairs in which either camera moved more than
   ``max_translation_m`` (10 cm) or rotated more than ``max_rotation_deg`` (11.5°) are
   dropped — such jumps indicate tracking errors.
5. **Sampling.** ``mode=consecutive`` keeps every surviving pair; ``mode=random`` draws
   ``n_pairs`` of them at random (appendix D: "drawn randomly from the entire trajectory").

Every stage's count is kept in :attr:`MotionPairs.counts`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import check_transforms, invert_transform, rotation_angle_rad

__all__ = ["MotionPairs", "match_by_timestamp", "make_pairs", "pairs_from_motions"]


@dataclass(frozen=True)
class MotionPairs:
    """Relative motions of camera a (``C``) and camera b (``H``), ``(N, 4, 4)`` each.

    ``start``/``end`` ``(N,)`` index the matched datapoints; ``frame_a``/``frame_b``
    ``(D, )`` and ``time_a_s``/``time_b_s`` ``(D,)`` describe the matched datapoints
    (simulated frame index and timestamp of each camera's pose). ``counts`` records what
    each stage kept and dropped.
    """
    C: np.ndarray
    H: np.ndarray
    start: np.ndarray
    end: np.ndarray
    frame_a: np.ndarray
    frame_b: np.ndarray
    time_a_s: np.ndarray
    time_b_s: np.ndarray
    counts: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.C.shape[0])


def match_by_timestamp(t_a: np.ndarray, t_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(ia, ib)`` matching two sorted time arrays one-to-one.

    Candidate pairs are each pose of camera a with the poses of camera b just before and
    just after it; they are accepted greedily, closest in time first (differences rounded
    to 1 ns; ties: earlier pose), when neither pose is taken yet. No pose is used twice and
    the matches increase in both streams. A half-period offset between the cameras (every
    pose has two equally near neighbours) still matches every frame.
    """
    t_a = np.asarray(t_a, dtype=np.float64)
    t_b = np.asarray(t_b, dtype=np.float64)
    if t_a.ndim != 1 or t_b.ndim != 1:
        raise ValueError(f"timestamps must be 1-D; received shapes {t_a.shape} and {t_b.shape}")
    if t_a.size == 0 or t_b.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    for name, t in (("camera a", t_a), ("camera b", t_b)):
        if not np.isfinite(t).all():
            raise ValueError(f"timestamps of {name} contain NaN or inf")
        if np.any(np.diff(t) < 0):
            raise ValueError(f"timestamps of {name} must be non-decreasing")
    # candidate edges: each pose of a with its two neighbours in b (before / after)
    pos = np.searchsorted(t_b, t_a)
    ia = np.arange(t_a.size)
    cand_a = np.concatenate([ia, ia])
    cand_b = np.concatenate([pos - 1, pos])
    ok = (cand_b >= 0) & (cand_b < t_b.size)
    cand_a, cand_b = cand_a[ok], cand_b[ok]
    dist = np.abs(t_a[cand_a] - t_b[cand_b])
    # greedy, closest first (ties: earlier a, then earlier b); O(number of poses), not a
    # hot path
    order = np.lexsort((cand_b, cand_a, np.round(dist, 9)))
    used_a = np.zeros(t_a.size, dtype=bool)
    used_b = np.zeros(t_b.size, dtype=bool)
    match_b = np.full(t_a.size, -1, dtype=np.int64)
    for k in order:
        a, b = cand_a[k], cand_b[k]
        if not used_a[a] and not used_b[b]:
            used_a[a] = used_b[b] = True
            match_b[a] = b
    ia = np.flatnonzero(used_a)
    ib = match_b[ia]
    mono = np.concatenate([[True], np.diff(ib) > 0])  # drop (rare) crossing matches
    return ia[mono], ib[mono]


def _nearest(ref: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Index into sorted ``ref`` of the element nearest each ``query`` (ties: earlier)."""
    pos = np.searchsorted(ref, query)
    lo = np.clip(pos - 1, 0, ref.size - 1)
    hi = np.clip(pos, 0, ref.size - 1)
    return np.where(np.abs(query - ref[lo]) <= np.abs(ref[hi] - query), lo, hi)


def _motion_filter(C, H, cfg, counts: dict) -> np.ndarray:
    """D.1's pre-filter of the motions: too large a translation or rotation (either
    sensor) is dropped; the counts say how many for which reason. Returns the kept mask."""
    trans = np.maximum(np.linalg.norm(C[:, :3, 3], axis=-1),
                       np.linalg.norm(H[:, :3, 3], axis=-1))
    rot = np.rad2deg(np.maximum(rotation_angle_rad(C[:, :3, :3]),
                                rotation_angle_rad(H[:, :3, :3])))
    bad_t = trans > cfg.max_translation_m
    bad_r = rot > cfg.max_rotation_deg
    counts["dropped_translation"] = int(bad_t.sum())
    counts["dropped_rotation"] = int((bad_r & ~bad_t).sum())
    return ~(bad_t | bad_r)


def make_pairs(stream_a, stream_b, cfg, rng: np.random.Generator | None = None) -> MotionPairs:
    """Relative motions from two :class:`~simcalib.streams.PoseStream`\\ s (camera a, b)
    following :class:`~simcalib.config.PairingConfig` ``cfg``.

    Raises ``ValueError`` when fewer than 2 motions survive, naming where they were lost.
    """
    if cfg.mode == "random" and not isinstance(rng, np.random.Generator):
        raise TypeError("pairing mode 'random' needs a numpy.random.Generator; received "
                        f"{type(rng).__name__}")
    T_a = check_transforms(stream_a.T_world_cam, f"poses of {stream_a.camera}")
    T_b = check_transforms(stream_b.T_world_cam, f"poses of {stream_b.camera}")
    ia, ib = match_by_timestamp(stream_a.timestamp_s, stream_b.timestamp_s)
    counts = {"poses_a": int(T_a.shape[0]), "poses_b": int(T_b.shape[0]),
              "matched": int(ia.size)}
    dt = np.abs(np.asarray(stream_a.timestamp_s)[ia] - np.asarray(stream_b.timestamp_s)[ib])
    if cfg.prefilter:
        keep = dt <= cfg.max_time_diff_s
        counts["dropped_time_diff"] = int((~keep).sum())
        ia, ib, dt = ia[keep], ib[keep], dt[keep]
    else:
        counts["dropped_time_diff"] = 0
    counts["datapoints"] = int(ia.size)
    counts["time_diff_median_s"] = float(np.median(dt)) if dt.size else None

    k0 = np.arange(max(ia.size - cfg.step, 0))
    k1 = k0 + cfg.step
    Ta, Tb = T_a[ia], T_b[ib]
    C = invert_transform(Ta[k0]) @ Ta[k1]
    H = invert_transform(Tb[k0]) @ Tb[k1]
    counts["candidate_pairs"] = int(k0.size)
    if cfg.prefilter and k0.size:
        keep = _motion_filter(C, H, cfg, counts)
        k0, k1, C, H = k0[keep], k1[keep], C[keep], H[keep]
    else:
        counts["dropped_translation"] = 0
        counts["dropped_rotation"] = 0
    counts["surviving_pairs"] = int(k0.size)
    if cfg.mode == "random" and k0.size > 0:
        n = min(cfg.n_pairs, k0.size)
        sel = np.sort(rng.choice(k0.size, size=n, replace=False))
        k0, k1, C, H = k0[sel], k1[sel], C[sel], H[sel]
    counts["used"] = int(k0.size)
    if k0.size < 2:
        raise ValueError(
            f"only {k0.size} relative motion(s) left after pairing, at least 2 are needed: "
            f"{_describe_counts(counts)}. Relax pairing.* (e.g. pairing.step, "
            "pairing.max_translation_m, pairing.max_rotation_deg) or record more frames")
    return MotionPairs(C=C, H=H, start=k0, end=k1,
                       frame_a=np.asarray(stream_a.frame_index)[ia],
                       frame_b=np.asarray(stream_b.frame_index)[ib],
                       time_a_s=np.asarray(stream_a.timestamp_s, dtype=np.float64)[ia],
                       time_b_s=np.asarray(stream_b.timestamp_s, dtype=np.float64)[ib],
                       counts=counts)


def pairs_from_motions(C: np.ndarray, H: np.ndarray) -> MotionPairs:
    """Wrap relative motions that a source produced directly (the synthetic generator)."""
    C = check_transforms(C, "C", min_count=2)
    H = check_transforms(H, "H", min_count=2)
    if C.shape != H.shape:
        raise ValueError(f"C and H must have the same shape; received {C.shape} and {H.shape}")
    n = C.shape[0]
    idx = np.arange(n)
    counts = {"poses_a": None, "poses_b": None, "matched": None, "dropped_time_diff": 0,
              "datapoints": None, "candidate_pairs": n, "dropped_translation": 0,
              "dropped_rotation": 0, "surviving_pairs": n, "used": n}
    empty = np.zeros(0, dtype=np.int64)
    return MotionPairs(C=C, H=H, start=idx, end=idx, frame_a=empty, frame_b=empty,
                       time_a_s=np.zeros(0), time_b_s=np.zeros(0), counts=counts)


def _describe_counts(c: dict) -> str:
    return (f"{c['poses_a']} poses of camera a and {c['poses_b']} of camera b, "
            f"{c['matched']} matched by timestamp, {c['dropped_time_diff']} dropped for "
            f"timestamp difference, {c['candidate_pairs']} candidate pairs, "
            f"{c['dropped_translation']} dropped for translation and "
            f"{c['dropped_rotation']} for rotation")
