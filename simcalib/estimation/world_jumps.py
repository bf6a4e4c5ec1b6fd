"""Jumps of a stream's world frame: a SLAM map reset, a tracker that re-initialised, a
motion-capture system calibrated again, a robot re-homed.

Poses on the two sides of such a jump are in two worlds that no X relates: every motion
across it is wrong, and the poses' residuals to one world (:mod:`simcalib.estimation.
pose_errors`) mean nothing. Without this check a SLAM track reset half-way gave the right
X from the motions on either side, but the reading of the files "not clear" (1.03x) and
every direction of X "undetermined" (exit 6).

A jump is a step between two consecutive samples of a stream whose length (angle or
distance, :func:`simcalib.estimation.speeds.apart`) and speed (over the stamps'
difference)

* are both :data:`JUMP_GAIN` times the stream's 90th percentiles of them or more (the
  length: a long step over a gap in the stamps is a motion; the speed: so is a normal
  step over jittered stamps 0.1 ms apart, as in a 300 Hz motion capture),
* are :data:`OTHER_GAIN` times more so than the other stream's largest step is over its
  own 90th percentiles (both sensors of a rigid rig turn alike, and move alike up to
  their lever arm: a step the other stream never comes near is not a motion; the
  ratios need no clock offset, reading or scale), and
* stays: the poses :data:`JUMP_PERSIST` samples around it are still half that far
  apart (a bad pose, or a short run of them, comes back; outlier handling takes those).

Every stretch between jumps is then used, each as its own world (:func:`mark_stretches`:
the stream keeps all its poses and carries the jumps' stamps, ``world_jumps_s``). The
synchronised instants carry the stretch of both worlds they lie in
(``SyncedPoses.world``, :func:`simcalib.estimation.worlds.instant_worlds`; an instant interpolated across a jump mixes
two worlds and is dropped, counted ``across_a_world_jump``), and every step that uses
motions forms them only within a stretch: the reading's random pairs, the offset cost's
spans (also kept clear of a jump by the smoothing's reach), the motions of the fit
(``dropped_across_world_jump`` counted), hence outlier handling, the solve, the
covariance and the verdict; the pose residuals fit one world-to-world transform per
stretch (:func:`simcalib.estimation.pose_errors.world_transforms`), the velocities are
one-sided at a stretch's ends, the drawing aligns each stretch on its own, and the checks
that need one world-to-world transform (the reading's twin, OpenCV's all-pairs
comparison) use the stretch with the most instants. A stretch of one pose gives no
motion: its pose is dropped and counted (``poses_in_short_stretches_dropped``). The
repairs ``world_jumps`` and ``world_stretches`` and a warning say what was done. Not
world-aware: the angular-speed correlation of the coarse offset (a jump is one step's
spike in it, which its despiking takes) and the counter-lag search of sample-number
stamps (:mod:`simcalib.estimation.hidden_offset`).

Station data (poses paired by stamp, far apart: a robot that stops for each image) have
no smooth path to jump from, and a bumped target is their common accident. There the two
streams' relative rotation angles tell: both sensors of a rigid rig turn by the same angle
between any two poses (whatever the files' reading, X, the worlds or the scale), as long
as both worlds stay. A split of the poses (in stamp order) into two groups is a jump when
the pairs across it break that rule :data:`SPLIT_GAIN` times more (median) than the pairs
within the groups, and by :data:`SPLIT_MIN_DEG` or more; both groups are used, each as
its own world, pairs only within a group (:func:`station_groups`). A jump that moves a
world without turning it is not seen this way (the translations' screw pitch depends on
the unknown scale; a split by the pitches' misfit, b's scale taken as the median ratio of
their magnitudes, was measured and not used: with no jump it reached 27x and 49x on two
real crwhe sets, while a 5.4 cm move of b's world gave only 2.4-3x on kuka_2 and tabb).
A camera bumped on its mount also breaks the angle rule across the split, but each group
then has its own X: :mod:`simcalib.estimation.mount` tells the two apart after the fit
and then names it instead.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from simcalib.estimation.speeds import apart

__all__ = ["find_jumps", "mark_stretches", "station_split", "station_groups",
           "split_stations", "stretches_used", "align_worlds", "largest_world", "JUMP_GAIN",
           "OTHER_GAIN", "JUMP_PERSIST", "SPLIT_GAIN", "SPLIT_MIN_DEG"]

#: a step this many times the stream's 90th percentiles of step length and speed may be a
#: jump ...
JUMP_GAIN = 10.0
#: ... when its ratio is also this many times the other stream's largest ratio ...
OTHER_GAIN = 3.0
#: ... and the poses up to this many samples on either side stay half as far apart
JUMP_PERSIST = 5
_SIGNALS = ("rotation", "translation")
#: station data: a split whose pairs across break the equal-angle rule this many times more
#: (median) than the pairs within its groups ...
SPLIT_GAIN = 10.0
#: ... and by this much (median, deg) is a jump of a world frame
SPLIT_MIN_DEG = 0.5
#: poses of each group of a split (and the most poses the split search looks at: an even
#: subsample beyond)
_MIN_GROUP, _MAX_POSES = 3, 400


def _ratios(t: np.ndarray, T: np.ndarray, signal: str) -> np.ndarray:
    """Each consecutive step's length and speed over the stream's 90th percentiles of them,
    the smaller of the two, ``(n - 1,)`` (zeros where a percentile is 0: a still stream has
    no jumps to tell)."""
    step = apart(T, 1, signal)
    dt = np.diff(t)
    out = []
    for x in (step, step / np.where(dt > 0, dt, np.inf)):
        p90 = float(np.quantile(x, 0.9))
        out.append(x / p90 if p90 > 0 else np.zeros_like(x))
    return np.minimum(*out)


def _persists(T: np.ndarray, k: int, signal: str) -> bool:
    """The step into pose ``k`` stays: poses ``k - 1 - m`` and ``k + m`` (m = 1 ..
    JUMP_PERSIST) are at least half as far apart as poses ``k - 1`` and ``k``."""
    m = np.arange(1, JUMP_PERSIST + 1)
    before, after = k - 1 - m, k + m
    if before[-1] < 0 or after[-1] >= T.shape[0]:
        return False
    step = apart(T[[k - 1, k]], 1, signal)[0]
    pairs = np.stack([T[before], T[after]], axis=1)           # (m, 2, 4, 4)
    far = np.array([apart(p, 1, signal)[0] for p in pairs])
    return bool(np.all(far >= 0.5 * step))


def find_jumps(t: np.ndarray, T: np.ndarray, t_other: np.ndarray,
               T_other: np.ndarray) -> np.ndarray:
    """Indices ``k`` of the poses that follow a jump of the world frame of the stream
    ``(t, T)`` (module doc), judged against the other stream ``(t_other, T_other)``."""
    if t.shape[0] < 2 * JUMP_PERSIST + 8 or t_other.shape[0] < 8:
        return np.empty(0, dtype=np.int64)
    ks = []
    for signal in _SIGNALS:
        r = _ratios(t, T, signal)
        bar = max(JUMP_GAIN, OTHER_GAIN * float(np.max(_ratios(t_other, T_other, signal))))
        ks += [int(k) + 1 for k in np.flatnonzero(r >= bar) if _persists(T, int(k) + 1, signal)]
    return np.unique(np.asarray(ks, dtype=np.int64))


def _stretches(stream, jumps: np.ndarray):
    """``stream`` with its world jumps marked (``world_jumps_s``) and the poses of
    stretches too short to give a motion (one pose) dropped; ``(stream, stretches used,
    poses dropped)``."""
    t = np.asarray(stream.timestamps_s)
    edges = np.concatenate([[0], jumps, [t.shape[0]]])
    spans = [(e0, e1) for e0, e1 in zip(edges[:-1], edges[1:]) if e1 - e0 >= 2]
    keep = np.zeros(t.shape[0], dtype=bool)
    for e0, e1 in spans:
        keep[e0:e1] = True
    marks = tuple(float(t[e0]) for e0, _ in spans[1:])
    repairs = dict(stream.repairs, world_jumps=int(jumps.size), world_stretches=len(spans),
                   poses_in_short_stretches_dropped=int((~keep).sum()))
    out = replace(stream, timestamps_s=t[keep],
                  T_world_sensor=np.asarray(stream.T_world_sensor)[keep], repairs=repairs,
                  world_jumps_s=marks)
    return out, len(spans), int((~keep).sum())


def mark_stretches(sa, sb):
    """Both streams (PoseStreamData) with the jumps of their world frames marked
    (``world_jumps_s``: every stretch between jumps is used as its own world; stretches of
    one pose dropped), and ``notes``: one sentence per stream that had a jump (empty: no
    jump)."""
    out, notes = [], []
    for s, other in ((sa, sb), (sb, sa)):
        jumps = find_jumps(np.asarray(s.timestamps_s), np.asarray(s.T_world_sensor),
                           np.asarray(other.timestamps_s), np.asarray(other.T_world_sensor))
        if jumps.size == 0:
            out.append(s)
            continue
        marked, used, dropped = _stretches(s, jumps)
        at = ", ".join(f"{x:.3f}" for x in np.asarray(s.timestamps_s)[jumps][:5])
        short = (f"; {dropped} pose(s) in stretches too short for a motion dropped"
                 if dropped else "")
        notes.append(f"stream {s.name or s.source}'s world frame jumps {jumps.size} time(s), "
                     f"at t = {at} s (a step no motion of the rig makes, which stays: a SLAM "
                     f"map reset, a tracker re-initialised?); each of its {used} stretches is "
                     f"used as its own world (motions only within a stretch){short}")
        out.append(marked)
    return out[0], out[1], notes


def stretches_used(synced, motions, robust) -> list[str]:
    """One sentence on the stretches of the worlds the fit used (``synced``:
    SyncedPoses, ``motions``: MotionSet, ``robust``: RobustSolution); empty with one
    world."""
    world = getattr(synced, "world", None)
    if world is None:
        return []
    w = world[motions.i]
    inl = np.asarray(robust.inlier_mask, dtype=bool)
    per = [int(((w == v) & inl).sum()) for v in np.unique(world)]
    return [f"{sum(k > 0 for k in per)} of {len(per)} stretches of the two streams' worlds "
            f"give the fit's motions (inliers per stretch: {', '.join(map(str, per))}); "
            f"{motions.counts.get('dropped_across_world_jump', 0)} motions across a jump "
            f"were not formed, {synced.counts.get('across_a_world_jump', 0)} instants "
            "interpolated across one dropped"]


def _angle_misfit(T_a: np.ndarray, T_b: np.ndarray) -> np.ndarray:
    """``(n, n)``: |angle of a's motion - angle of b's motion| between every two poses."""
    from simcalib.estimation.station_rows import pair_angles_rad
    return np.abs(pair_angles_rad(T_a) - pair_angles_rad(T_b))


def station_split(T_a: np.ndarray, T_b: np.ndarray) -> tuple[int, float] | None:
    """``(k, ratio)``: poses ``k..`` of the paired poses ``T_a``, ``T_b`` (n, 4, 4) (stamp
    order) are in other worlds than poses ``..k-1`` (module doc; ``ratio``: the median
    misfit across over within); None when no split is one. The splits tried are the five
    largest misfits of consecutive poses."""
    n = T_a.shape[0]
    if n < 2 * _MIN_GROUP:
        return None
    E = _angle_misfit(T_a, T_b)
    steps = np.diagonal(E, 1)[_MIN_GROUP - 1:n - _MIN_GROUP]
    best = None
    for k in np.argsort(steps)[::-1][:5] + _MIN_GROUP:
        within = np.concatenate([E[:k, :k][np.triu_indices(k, 1)],
                                 E[k:, k:][np.triu_indices(n - k, 1)]])
        across = float(np.median(E[:k, k:]))
        ratio = across / max(float(np.median(within)), 1e-12)
        if (ratio >= SPLIT_GAIN and across >= np.radians(SPLIT_MIN_DEG)
                and (best is None or ratio > best[1])):
            best = (int(k), ratio)
    return best


def station_groups(sa, sb, synced, shift_s: float = 0.0):
    """Both streams with the jump of a :func:`station_split` of their poses paired by
    stamp marked (``synced``: :class:`~simcalib.estimation.alignment.SyncedPoses`, on a's
    stamps; b's are ``shift_s`` later): both groups are used, each as its own world (pairs
    only within a group); and ``notes`` (empty: no split; the streams returned as they
    are)."""
    n = synced.n
    pick = np.unique(np.linspace(0, n - 1, min(n, _MAX_POSES)).round().astype(np.int64))
    split = station_split(np.asarray(synced.T_a)[pick], np.asarray(synced.T_b)[pick])
    if split is None:
        return sa, sb, []
    t = np.asarray(synced.time_s)
    k = int(pick[split[0]])
    cut = 0.5 * (t[k - 1] + t[k])           # between the two groups' poses
    out = []
    for s, shift in ((sa, 0.0), (sb, shift_s)):
        marks = tuple(sorted(set(s.world_jumps_s) | {float(cut + shift)}))
        out.append(replace(s, world_jumps_s=marks, repairs=dict(
            s.repairs, world_jumps=len(marks), world_stretches=len(marks) + 1)))
    note = (f"the two streams' worlds move apart between the poses at t = {t[k - 1]:.3f} and "
            f"{t[k]:.3f} s (the rotation angles of the motions across break the rule both "
            f"sensors turn alike {split[1]:.0f}x more than within: a bumped target, a moved "
            f"base or camera?); both groups ({k} and {n - k} of {n} poses) are used, each as "
            "its own world (pairs only within a group)")
    return out[0], out[1], [note]


def split_stations(sa, sb, sampling):
    """``(stream_a, stream_b, notes)``: station data (paired by stamp, and the motions'
    ``auto`` policy takes them as stations or bursts:
    :func:`simcalib.estimation.motions.auto_policy`) with the jump of
    :func:`station_groups` marked; other data, and stations with no split, as they are
    (``notes`` empty)."""
    from simcalib.estimation.motions import auto_policy
    from simcalib.estimation.sampling import pair_by_stamp
    if not sampling.paired_by_stamp:
        return sa, sb, []
    synced = pair_by_stamp(sa, sb, sampling, sampling.shift_s)
    policy = auto_policy(synced, True, sampling.kind == "index_stamps")[0]
    if policy not in ("stations", "bursts"):
        return sa, sb, []
    return station_groups(sa, sb, synced, sampling.shift_s)


def align_worlds(T_a: np.ndarray, T_b: np.ndarray, X: np.ndarray, world=None,
                 world_fit=None) -> np.ndarray:
    """``T_wa_wb``: the fixed transform between the two streams' world frames implied by
    ``X`` (``T_wa_a X = T_wa_wb T_wb_b`` at every synchronised instant), as the chordal
    mean rotation (SVD projection of the mean) and the median translation of the per-instant
    estimates ``T_wa_a X T_wb_b^-1``. Used to draw both trajectories in one frame. With
    ``world`` (the stretch of the worlds of each instant of ``T_a``, ``T_b``: a world frame
    jumps) one transform per stretch, returned per instant ``(n, 4, 4)``; ``world_fit``:
    the stretches of the instants the fit uses where they are a subset (default all)."""
    from simcalib.geometry import chordal_mean_rotation, invert_transform
    if world is not None:
        fit = np.ones(world.shape, dtype=bool) if world_fit is None else world_fit
        out = np.tile(np.eye(4), (world.size, 1, 1))
        for w in np.unique(world):
            m = (world == w) & fit
            out[world == w] = align_worlds(T_a[m], T_b[m], X) if m.any() else np.eye(4)
        return out
    Y = T_a @ X @ invert_transform(T_b)
    out = np.eye(4)
    out[:3, :3] = chordal_mean_rotation(Y[:, :3, :3])
    out[:3, 3] = np.median(Y[:, :3, 3], axis=0)
    return out


def largest_world(synced) -> np.ndarray:
    """``(n,)`` bool: the synchronised instants of the stretch of the worlds with the most
    instants (all where there is one world): for a check that needs one world-to-world
    transform."""
    world = getattr(synced, "world", None)
    if world is None:
        return np.ones(synced.n, dtype=bool)
    values, counts = np.unique(world, return_counts=True)
    return world == values[int(np.argmax(counts))]
