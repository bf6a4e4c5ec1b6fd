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

The path then keeps each stream's longest stretch without a jump (by duration) and says
so (the repairs ``world_jumps`` and ``poses_beyond_a_world_jump_dropped``, and a warning);
calibrating each stretch on its own is the user's choice (split the file).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from simcalib.estimation.speeds import apart

__all__ = ["find_jumps", "longest_stretches", "JUMP_GAIN", "OTHER_GAIN", "JUMP_PERSIST"]

#: a step this many times the stream's 90th-percentile speed may be a jump ...
JUMP_GAIN = 10.0
#: ... when its ratio is also this many times the other stream's largest ratio ...
OTHER_GAIN = 3.0
#: ... and the poses up to this many samples on either side stay half as far apart
JUMP_PERSIST = 5
_SIGNALS = ("rotation", "translation")


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


def _longest(stream, jumps: np.ndarray):
    """``stream`` cut to its longest stretch (by duration) between ``jumps``, with the
    repairs counted; ``(stream, (t_start, t_end, share of poses kept))``."""
    t = np.asarray(stream.timestamps_s)
    edges = np.concatenate([[0], jumps, [t.shape[0]]])
    spans = [(t[e1 - 1] - t[e0], e0, e1) for e0, e1 in zip(edges[:-1], edges[1:])]
    _, e0, e1 = max(spans)
    repairs = dict(stream.repairs, world_jumps=int(jumps.size),
                   poses_beyond_a_world_jump_dropped=int(t.shape[0] - (e1 - e0)))
    kept = replace(stream, timestamps_s=t[e0:e1],
                   T_world_sensor=np.asarray(stream.T_world_sensor)[e0:e1], repairs=repairs)
    return kept, (float(t[e0]), float(t[e1 - 1]), (e1 - e0) / t.shape[0])


def longest_stretches(sa, sb):
    """Both streams (PoseStreamData) cut to their longest stretch without a jump of their
    world frame, and ``notes``: one sentence per stream that had one (empty: no jump)."""
    out, notes = [], []
    for s, other in ((sa, sb), (sb, sa)):
        jumps = find_jumps(np.asarray(s.timestamps_s), np.asarray(s.T_world_sensor),
                           np.asarray(other.timestamps_s), np.asarray(other.T_world_sensor))
        if jumps.size == 0:
            out.append(s)
            continue
        kept, (t0, t1, share) = _longest(s, jumps)
        at = ", ".join(f"{x:.3f}" for x in np.asarray(s.timestamps_s)[jumps][:5])
        notes.append(f"stream {s.name or s.source}'s world frame jumps at t = {at} s (a step "
                     "no motion of the rig makes, which stays: a SLAM map reset, a tracker "
                     f"re-initialised?); only its longest stretch without a jump is used "
                     f"(t = {t0:.3f} to {t1:.3f} s, {share:.0%} of its poses)")
        out.append(kept)
    return out[0], out[1], notes
