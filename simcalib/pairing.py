"""Relative motions ``(C_i, H_i)`` from two cameras' pose streams.

1. **Matching.** The two streams are matched by timestamp: a pose of camera a and a pose
   of camera b form a *datapoint* when each is the other's nearest neighbour in time.
2. **Pre-filter, timestamps** (appendix D.1 of the paper): datapoints whose two timestamps
   differ by more than ``max_time_diff_s`` (0.1 s) are dropped.
3. **Pairs.** Datapoint ``k`` is paired with datapoint ``k + step``:
   ``C = T_w_a[k]^-1 T_w_a[k+step]`` and ``H = T_w_b[k]^-1 T_w_b[k+step]``, so that
   ``C X = X H`` with ``X = T_a_b`` (NOTES.md).
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
    """Indices ``(ia, ib)`` of mutual nearest neighbours between two sorted time arrays.

    A pose of a and a pose of b are matched when each is the other's nearest in time
    (ties go to the earlier pose), so no pose is used twice. Vectorised.
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
    nn_ab = _nearest(t_b, t_a)  # for each a, nearest b
    nn_ba = _nearest(t_a, t_b)  # for each b, nearest a
    ia = np.arange(t_a.size)
    mutual = nn_ba[nn_ab] == ia
    return ia[mutual], nn_ab[mutual]


def _nearest(ref: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Index into sorted ``ref`` of the element nearest each ``query`` (ties: earlier)."""
    pos = np.searchsorted(ref, query)
    lo = np.clip(pos - 1, 0, ref.size - 1)
    hi = np.clip(pos, 0, ref.size - 1)
    return np.where(np.abs(query - ref[lo]) <= np.abs(ref[hi] - query), lo, hi)


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
        trans = np.maximum(np.linalg.norm(C[:, :3, 3], axis=-1),
                           np.linalg.norm(H[:, :3, 3], axis=-1))
        rot = np.rad2deg(np.maximum(rotation_angle_rad(C[:, :3, :3]),
                                    rotation_angle_rad(H[:, :3, :3])))
        bad_t = trans > cfg.max_translation_m
        bad_r = rot > cfg.max_rotation_deg
        counts["dropped_translation"] = int(bad_t.sum())
        counts["dropped_rotation"] = int((bad_r & ~bad_t).sum())
        keep = ~(bad_t | bad_r)
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
