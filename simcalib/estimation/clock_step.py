"""A clock that steps once mid-recording: the offset ``t_b - t_a`` constant on two stretches
with a jump between them.

An NTP correction, or a logger restarted on another machine's clock, moves b's stamps by a
constant (+0.4 s, -2 s) from one instant on. Fitted as one offset, the split check's parts
(:func:`simcalib.estimation.offset_cost.split_check`) of the stretch the offset does not
fit stop at the edge of their bracket, their spread raises the offset's sigma (or, a
stretch far off, whose cost barely curves at the edge, raises nothing and drags X off),
and X's sigma grows with the misaligned motions ("poorly determined"); a linear drift
(:mod:`simcalib.estimation.drift`) does not explain them.

:func:`find_step` looks for one only where the split check raised, has a part at its
bracket's edge, or left a part out as flat (its cost does not curve within the bracket:
a step of seconds), and no drift was fitted (else it costs nothing): the parts at their
bracket's edge and the flat ones must be one run at an end of the recording
(:func:`edge_run`: there the offset is off by more than the bracket), or the parts split
into two contiguous groups, each about one offset, that explain their dispersion
:data:`STEP_GAIN` times better than one offset and than a line (:func:`two_levels`; a part
between the groups whose offset lies between theirs may be left out: it holds the step).
Then

* the offset is estimated again on b's stamps on either side of the groups' boundary
  (each stretch alone) -> ``o1``, ``o2``;
* the step's instant is the b stamp that best separates the motions fitting ``o1`` from
  those fitting ``o2`` (:func:`changepoint`: the screw's invariants, rotation angle and
  pitch, which X does not change, over 1 s motions; the translation's length for a rig
  that does not turn; a motion across the step fits neither);
* the offset is estimated once more on each side of that stamp (with its drift where
  the stretch tells one); the step is told when it stands :data:`STEP_Z` of its sigmas
  from 0 and the stretches' points (their split checks' parts, or a short stretch's own
  offset; 4 or more) lie about a line with a jump at the step :data:`STEP_GAIN` times
  closer than about one line and about one offset (a drift climbs through both); with
  fewer points, where a line through them would need a drift above :data:`MAX_DRIFT`.

:func:`step_at` does the same at a boundary given (the path's mount check, where the
offset's own checks missed a stretch it does not fit: :func:`simcalib.estimation.path.
_stepped`).

Where it is told, :func:`shifted` moves b's stamps from the step on by ``-(o2 - o1)`` and
the path aligns the corrected streams as usual (:mod:`simcalib.estimation.
reading_alignment`; streams paired by shared stamps, :mod:`simcalib.estimation.
hidden_offset`, are classified again); :class:`ClockStep` says what was done. A clock
that steps back (``o2 < o1``) leaves b's file with stamps out of order, which the reader
sorts: the stretches interleave over the step's length, the step is put at the first row
after them (:func:`changepoint`), and the later stretch's rows among them, not shifted, are
left to the outlier rejection (-0.4 s on a generated recording is told; -2 s is not: read
from a file it is taken for a restarted logger, and sorted its interleaved rows pull the
one offset seconds off, docs/calibrate.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["ClockStep", "find_step", "step_at", "shifted", "holds", "two_levels", "edge_run",
           "STEP_GAIN", "STEP_Z", "MAX_STEPS", "EDGE", "HOLD_Z", "HOLD_SHARE", "MAX_DRIFT"]

#: two constants leave at most this fraction's inverse of the parts' dispersion about one
#: offset and about a line
STEP_GAIN = 10.0
#: the step stands this many of its sigmas from 0
STEP_Z = 10.0
#: at most this many steps are told in one recording
MAX_STEPS = 3
#: a part of the split check this share of the bracket's half width from the offset
#: stopped at its edge
EDGE = 0.999
#: with the step removed from b's stamps, the offset aligned again is the first
#: stretch's within this many of their joint sigmas, or this share of the step (:func:`holds`)
HOLD_Z, HOLD_SHARE = 5.0, 0.1
#: where the stretches give fewer than 4 points (a short recording: a split check of
#: fewer than 2 parts each), a line is no explanation when it needs this drift (s/s):
#: 10x a crystal clock's worst (20-100 ppm, :mod:`simcalib.estimation.drift`)
MAX_DRIFT = 1e-3


@dataclass(frozen=True)
class ClockStep:
    """b's clock jumps by ``size_s`` (``o2 - o1``, 1-sigma ``size_sigma_s``) at b's stamp
    ``at_b_s`` (the first pose after the step, b's clock as written; ``at_a_s`` on a's):
    the offset ``t_b - t_a`` is ``before_s`` before it and ``after_s`` from it on (their
    1-sigmas, each stretch estimated alone); ``q_step``, ``q_line``, ``q_const``: the
    stretches' parts' chi-square about two constants, a line, one offset; ``rows_shifted``:
    b's poses moved by ``-size_s``."""
    at_b_s: float
    at_a_s: float
    size_s: float
    size_sigma_s: float
    before_s: float
    before_sigma_s: float
    after_s: float
    after_sigma_s: float
    q_step: float
    q_line: float
    q_const: float
    rows_shifted: int

    def to_dict(self) -> dict:
        return {"kind": "clock step", "at_b_s": self.at_b_s, "at_a_s": self.at_a_s,
                "size_s": self.size_s, "size_sigma_s": self.size_sigma_s,
                "offset_before_s": self.before_s, "sigma_before_s": self.before_sigma_s,
                "offset_after_s": self.after_s, "sigma_after_s": self.after_sigma_s,
                "parts_chi2": {"line_with_the_step": self.q_step, "line": self.q_line,
                               "one_offset": self.q_const},
                "b_rows_shifted": self.rows_shifted}

    def line(self) -> str:
        """The one line that names it (console, the offset's message)."""
        return (f"clock step: b's clock jumps by {self.size_s * 1e3:+.1f} +- "
                f"{self.size_sigma_s * 1e3:.1f} ms at b's t = {self.at_b_s:.3f} s (a's "
                f"{self.at_a_s:.3f} s): offset {self.before_s * 1e3:.1f} +- "
                f"{self.before_sigma_s * 1e3:.1f} ms before, {self.after_s * 1e3:.1f} +- "
                f"{self.after_sigma_s * 1e3:.1f} ms after; b's {self.rows_shifted} stamps "
                f"from it shifted by {-self.size_s * 1e3:+.1f} ms")


def _chi2(o, w, groups) -> float:
    """Weighted chi-square of offsets ``o`` about one constant per group label."""
    q = 0.0
    for g in np.unique(groups):
        m = groups == g
        q += float(np.sum(w[m] * (o[m] - np.sum(w[m] * o[m]) / np.sum(w[m])) ** 2))
    return q


def _q_line(t, o, w) -> float:
    A = np.stack([np.ones_like(t), t - np.mean(t)], axis=1) * np.sqrt(w)[:, None]
    coef = np.linalg.lstsq(A, o * np.sqrt(w), rcond=None)[0]
    return float(np.sum(w * (o - coef[0] - coef[1] * (t - np.mean(t))) ** 2))


def two_levels(times, offsets, sigmas) -> tuple | None:
    """``(last part of the first group, first part of the second)``: the contiguous split
    of the parts whose two constants leave :data:`STEP_GAIN` times less dispersion than one
    offset and than a line (the least of those that do); where none does, the same with
    one part between the groups left out (the part that holds the step: its offset lies
    between the groups', :func:`_between`); None where neither does (or fewer than 3
    parts)."""
    t, o = np.asarray(times, np.float64), np.asarray(offsets, np.float64)
    w = 1.0 / np.asarray(sigmas, np.float64) ** 2
    n = o.size
    if n < 3 or t.size != n:
        return None
    for gap in (0, 1):
        best = None
        for k in range(1, n - gap):
            keep = np.r_[np.arange(k), np.arange(k + gap, n)]
            if gap and not _between(o, w, k, n):
                continue
            q = _chi2(o[keep], w[keep], (keep >= k).astype(int))
            ok = min(_chi2(o[keep], w[keep], np.zeros(keep.size)),
                     _q_line(t[keep], o[keep], w[keep])) >= STEP_GAIN * max(q, 1e-300)
            if ok and (best is None or q < best[0]):
                best = (q, k - 1, k + gap)
        if best is not None:
            return best[1:]
    return None


def _between(o, w, k, n) -> bool:
    """Part ``k`` lies between the weighted means of parts ``0..k-1`` and ``k+1..n-1``: a
    part that holds the step mixes the two offsets (or stops at its bracket's edge, on
    the way from one to the other)."""
    lo = np.sum(w[:k] * o[:k]) / np.sum(w[:k])
    hi = np.sum(w[k + 1:n] * o[k + 1:n]) / np.sum(w[k + 1:n])
    return bool(min(lo, hi) < o[k] < max(lo, hi))


def _may_step(off, half_s: float = math.inf) -> bool:
    """The search runs: one offset refined (no drift, fewer than :data:`MAX_STEPS` steps
    removed) whose split check has 3 parts or more (2 fitted at least) and raised, or has
    a part that stopped at its bracket's edge (``half_s`` from the offset: a stretch the
    offset does not fit by more than the bracket, whose cost barely curves there, may not
    raise it), or one left out because its cost does not curve within the bracket at all
    (``flat_times_s``: a stretch the offset misses by seconds)."""
    split = getattr(off, "split", None)
    if not (off.refined and off.decision in ("estimated", "zero") and split is not None
            and off.drift == 0.0 and len(split.offsets_s) >= 2
            and len(split.offsets_s) + len(_flat(split)) >= 3
            and len(getattr(off, "steps", ())) < MAX_STEPS):
        return False
    edge = np.abs(np.asarray(split.offsets_s) - off.best_s) >= EDGE * half_s
    return bool(split.raised) or bool(edge.any()) or bool(_flat(split))


def _flat(split) -> tuple:
    return tuple(getattr(split, "flat_times_s", ()))


def _half_s(a, b) -> float:
    """The half width of the offset cost's bracket: 2 periods of the slower stream."""
    from simcalib.estimation.speeds import as_time_poses
    ta, tb = as_time_poses(a)[0], as_time_poses(b)[0]
    return 2.0 * max(float(np.median(np.diff(ta))), float(np.median(np.diff(tb))))


def _reference_is_b(a, b) -> bool:
    """The offset cost's reference (its parts' clock) is b: the slower stream."""
    from simcalib.estimation.speeds import as_time_poses
    ta, tb = as_time_poses(a)[0], as_time_poses(b)[0]
    return float(np.median(np.diff(ta))) < float(np.median(np.diff(tb)))


def _sub(stream, keep):
    """``stream`` (PoseStreamData or ``(t, T)``) restricted to the rows ``keep``."""
    if isinstance(stream, tuple):
        return stream[0][keep], stream[1][keep]
    return replace(stream, timestamps_s=stream.timestamps_s[keep],
                   T_world_sensor=stream.T_world_sensor[keep])


def _stretch(a, b, keep, kw):
    """The offset of b's rows ``keep`` alone (its drift where it tells one), or None where
    the cost cannot bound it."""
    from simcalib.errors import DataError
    from simcalib.estimation.alignment import estimate_time_offset
    if int(np.sum(keep)) < 20:
        return None
    try:
        off = estimate_time_offset(a, _sub(b, keep), **kw)
    except (DataError, ValueError):
        return None
    ok = off.refined and math.isfinite(off.uncertainty_s) and off.uncertainty_s > 0
    return off if ok else None


def _invariants(T, i, j, signal) -> np.ndarray:
    """``(n, k)``: what X does not change of the motions ``T[i]^-1 T[j]``: the rotation
    angle (rad) and the translation along the rotation axis (the screw's pitch, m), or the
    translation's length for a rig that does not turn (``signal`` translation)."""
    from simcalib.geometry import invert_transform, rotvec_from_matrix
    M = invert_transform(T[i]) @ T[j]
    if signal == "translation":
        return np.linalg.norm(M[:, :3, 3], axis=1)[:, None]
    r = rotvec_from_matrix(M[:, :3, :3])
    angle = np.linalg.norm(r, axis=1)
    pitch = np.sum(M[:, :3, 3] * r, axis=1) / np.maximum(angle, 1e-12)
    return np.stack([angle, pitch], axis=1)


def _misfits(a, b, offsets, signal) -> tuple:
    """``(i, j, misfit per offset)``: b's 1 s motions (``i`` -> ``j`` in b's rows) and, at
    each offset, how far a's motion over the same instants differs in its invariants
    (:func:`_invariants`), each in units of its median misfit at the better offset and
    capped at 10 of them (a motion across the step or a gap fits no offset; NaN -> the
    cap); summed over the invariants, squared."""
    from simcalib.estimation.interpolation import interpolate_poses, max_hole_s
    from simcalib.estimation.speeds import as_time_poses
    ta, Ta = as_time_poses(a)
    tb, Tb = as_time_poses(b)
    m = max(1, int(round(1.0 / float(np.median(np.diff(tb))))))
    i = np.arange(tb.size - m)
    j = i + m
    own = _invariants(Tb, i, j, signal)
    out = []
    for o in offsets:
        T, valid = interpolate_poses(ta, Ta, tb - o, max_hole_s(ta))
        e = np.abs(_invariants(T, i, j, signal) - own)
        out.append(np.where((valid[i] & valid[j])[:, None], e, np.nan))
    e = np.stack(out)                                        # (offsets, motions, k)
    best = np.fmin(e[0], e[1])
    scale = np.array([np.median(c[np.isfinite(c)]) if np.isfinite(c).any() else 1.0
                      for c in best.T]) + 1e-15
    z = np.where(np.isfinite(e), np.minimum(e / scale, 10.0), 10.0)
    return i, j, np.sqrt(np.sum(z ** 2, axis=2))


def changepoint(a, b, o1, o2, signal="rotation") -> int | None:
    """b's row from which the offset is ``o2`` (``o1`` before): the one that minimises the
    squared misfits of the motions ending before it at ``o1`` plus those starting from it
    at ``o2`` (a motion across it fits neither and counts in no term); None on fewer than
    3 motions. A clock that steps back (``o2 < o1``) leaves the two stretches' rows
    interleaved over the step's length before the first row after it (the reader sorts
    them): the motions ending there fit neither and count in no term either, else they
    pull the row off (EuRoC -0.4 s: 3 rows late; a 20 Hz rig -0.43 s: 0.35 s early)."""
    from simcalib.estimation.speeds import as_time_poses
    i, j, e = _misfits(a, b, (o1, o2), signal)
    if i.size < 3:
        return None
    n = int(j[-1]) + 1
    before = np.bincount(j, e[0] ** 2, minlength=n + 1).cumsum()   # motions ending < k
    after = np.bincount(i, e[1] ** 2, minlength=n + 1)[::-1].cumsum()[::-1]  # from k on
    ks = np.arange(1, n)
    ends = ks
    if o2 < o1:                             # motions ending before the interleaved rows
        tb = as_time_poses(b)[0]
        ends = np.searchsorted(tb, tb[ks] - (o1 - o2), side="left")
    cost = np.concatenate([[0.0], before])[ends] + after[ks]
    return int(ks[int(np.argmin(cost))])


def _on_a(off, ref_b) -> tuple:
    """``(times on a's clock, offsets, sigmas)`` of ``off``'s split check's parts."""
    s = off.split
    t = np.asarray(s.times_s, np.float64) - (off.offset_s if ref_b else 0.0)
    return t, np.asarray(s.offsets_s, np.float64), np.asarray(s.sigmas_s, np.float64)


def _boundary(off, ref_b, half_s) -> float | None:
    """The a-clock instant between the parts the offset fits and those it does not: the
    middle between the last part of the first and the first of the second, where the parts
    at their bracket's edge (``half_s`` from the offset) or left out as flat
    (``flat_times_s``) are a run at one end of the recording (:func:`edge_run`), else the
    fitted parts' two levels (:func:`two_levels`); None: neither."""
    t, o, s = _on_a(off, ref_b)
    flat = np.asarray(_flat(off.split), np.float64) - (off.offset_s if ref_b else 0.0)
    every = np.r_[t, flat]
    order = np.argsort(every, kind="stable")
    edge = np.r_[np.abs(o - off.best_s) >= EDGE * half_s, np.ones(flat.size, dtype=bool)]
    cut = edge_run(edge[order])
    if cut is not None:
        return 0.5 * float(every[order][cut[0]] + every[order][cut[1]])
    cut = two_levels(t, o, s)
    return None if cut is None else 0.5 * float(t[cut[0]] + t[cut[1]])


def edge_run(edge) -> tuple | None:
    """``(last part of the first group, first of the second)`` where the parts at their
    bracket's edge (``edge``, a bool per part) are one run at the start or the end of the
    recording and some are not (a stretch the offset misses by more than the bracket);
    else None."""
    e = np.asarray(edge, dtype=bool)
    k = int(e.sum())
    if k == 0 or k == e.size:
        return None
    if e[:k].all():
        return k - 1, k
    if e[-k:].all():
        return e.size - k - 1, e.size - k
    return None


def find_step(a, b, off, **kw) -> ClockStep | None:
    """The clock step of the streams ``a``, ``b`` (read as the path reads them) whose one
    offset is ``off`` (:class:`~simcalib.estimation.alignment.TimeOffset`), where the
    data tell one (the module's docstring); else None. ``kw``: passed to
    :func:`~simcalib.estimation.alignment.estimate_time_offset` for each stretch
    (``alpha``, ``signal``)."""
    if not _may_step(off, _half_s(a, b)):
        return None
    mid = _boundary(off, _reference_is_b(a, b), _half_s(a, b))
    return None if mid is None else step_at(a, b, off, mid, **kw)


def step_at(a, b, off, mid: float, **kw) -> ClockStep | None:
    """:func:`find_step` with the stretches' boundary given: ``mid`` on a's clock (e.g.
    where X seemed to change: :func:`simcalib.estimation.mount.find_mount_change`)."""
    from simcalib.estimation.speeds import as_time_poses
    ref_b = _reference_is_b(a, b)
    tb = as_time_poses(b)[0]
    rough = [_stretch(a, b, tb - off.offset_s < mid, kw),
             _stretch(a, b, tb - off.offset_s >= mid, kw)]
    if None in rough:
        return None
    # the screw's invariants of a rig that turns (whichever speeds told the offset)
    k = changepoint(a, b, float(rough[0].offset_at(mid)), float(rough[1].offset_at(mid)),
                    "translation" if kw.get("signal") == "translation" else "rotation")
    if k is None:
        return None
    rows = np.arange(tb.size)
    parts = [_stretch(a, b, rows < k, kw), _stretch(a, b, rows >= k, kw)]
    return None if None in parts else _told(parts, ref_b, float(tb[k]), tb.size - k)


def _points(off, ref_b) -> tuple:
    """``(a-clock times, offsets, sigmas)`` of a stretch's offset: its split check's parts,
    or its own offset at its reference time where it is too short for 2 parts."""
    if off.split is not None and len(off.split.offsets_s) >= 2:
        return _on_a(off, ref_b)
    return np.array([off.t_ref_s]), np.array([off.offset_s]), np.array([off.uncertainty_s])


def _q_fit(columns, o, w) -> float:
    A = np.stack(columns, axis=1) * np.sqrt(w)[:, None]
    coef = np.linalg.lstsq(A, o * np.sqrt(w), rcond=None)[0]
    return float(np.sum((A @ coef - o * np.sqrt(w)) ** 2))


def _told(parts, ref_b, at_b_s, rows) -> ClockStep | None:
    """The :class:`ClockStep` of the stretches' offsets ``parts`` (before, after the step
    at b's ``at_b_s``; each with its drift where it tells one), where it stands
    :data:`STEP_Z` sigmas from 0 and the stretches' points (:func:`_points`, 4 or more in
    all) lie about a line with a jump at the step :data:`STEP_GAIN` times closer than about
    one line and about one offset; else None."""
    one, two = parts
    at_a = at_b_s - float(two.offset_at(at_b_s - two.offset_s))
    before, after = float(one.offset_at(at_a)), float(two.offset_at(at_a))
    sigma = math.hypot(one.uncertainty_s, two.uncertainty_s)
    if not abs(after - before) >= STEP_Z * sigma:
        return None
    (t1, o1, s1), (t2, o2, s2) = _points(one, ref_b), _points(two, ref_b)
    t, o, w = np.r_[t1, t2] - at_a, np.r_[o1, o2], 1.0 / np.r_[s1, s2] ** 2
    if not np.all(np.isfinite(w)):
        return None
    ones, later = np.ones_like(t), np.r_[np.zeros(t1.size), np.ones(t2.size)]
    q_step = _q_fit([ones, t, later], o, w)
    q_line, q_const = _q_fit([ones, t], o, w), _q_fit([ones], o, w)
    if t.size < 4:      # too few points to weigh a line: one needs a drift no clock has
        if not _drift_needed(t1, o1, t2, o2) >= MAX_DRIFT:
            return None
    elif not min(q_line, q_const) >= STEP_GAIN * q_step:
        return None
    return ClockStep(at_b_s, at_a, after - before, sigma, before, one.uncertainty_s, after,
                     two.uncertainty_s, q_step, q_line, q_const, rows)


def _drift_needed(t1, o1, t2, o2) -> float:
    """The drift (s/s) of the line through the two stretches' mean offsets."""
    dt = abs(float(np.mean(t2)) - float(np.mean(t1)))
    return abs(float(np.mean(o2)) - float(np.mean(o1))) / dt if dt > 0 else math.inf


def holds(step: ClockStep, off) -> bool:
    """Whether the offset ``off`` (a :class:`~simcalib.estimation.alignment.TimeOffset`)
    aligned on b's stamps with ``step`` removed is the first stretch's (``step.before_s``
    at the step): within :data:`HOLD_Z` of their joint sigma or :data:`HOLD_SHARE` of the
    step. Where it is not, the step explained nothing: removing it moved the whole
    alignment elsewhere (KITTI with b 30 s late: a "+152 s step" over its last 53 poses,
    then an offset of -238 s and X 179 deg off), and the streams are taken without it."""
    def fin(x):
        return float(x) if math.isfinite(x) else 0.0
    d = abs(float(off.offset_at(step.at_a_s)) - step.before_s)
    sigma = math.hypot(fin(off.uncertainty_s), fin(step.before_sigma_s))
    return bool(d <= max(HOLD_Z * sigma, HOLD_SHARE * abs(step.size_s)))


def shifted(stream, step: ClockStep):
    """``stream`` (b, PoseStreamData) with its stamps from ``step.at_b_s`` on moved by
    ``-step.size_s`` (its world jumps too), re-sorted, the count in its repairs
    (``clock_step_rows_shifted``)."""
    t = np.asarray(stream.timestamps_s, np.float64)
    after = t >= step.at_b_s
    t = np.where(after, t - step.size_s, t)
    order = np.argsort(t, kind="stable")
    jumps = tuple(float(j - step.size_s) if j >= step.at_b_s else float(j)
                  for j in getattr(stream, "world_jumps_s", ()))
    repairs = dict(stream.repairs)
    repairs["clock_step_rows_shifted"] = repairs.get("clock_step_rows_shifted", 0) + int(
        after.sum())
    return replace(stream, timestamps_s=t[order], T_world_sensor=stream.T_world_sensor[order],
                   repairs=repairs, world_jumps_s=jumps)
