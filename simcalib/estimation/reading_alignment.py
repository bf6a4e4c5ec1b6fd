"""The reading of two streams and their clock offset, decided together
(:func:`align_and_read`, a stage of :mod:`simcalib.estimation.path`): the reading at an
offset the reading does not move (:func:`first_reading`), the offset refined with that
reading, the reading decided again at the final offset; then, apart, whether b is mirrored
(a left-handed file: :func:`simcalib.estimation.readings.mirror_ratio`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

__all__ = ["align_and_read", "first_reading"]


def align_and_read(sa, sb, sampling, *, time_offset="estimate", drift="auto", alpha=1.0,
                   seed=0, forced=None, signal="rotation", candidates=None):
    """:func:`_align_and_read` (the reading and the clock offset), then whether b is
    mirrored (a left-handed file: :func:`simcalib.estimation.readings.mirror_ratio`), decided
    apart and only where it wins by more than ``MIRROR_RATIO``: then the streams are read
    and aligned again with b mirrored, and the reading's message says so. ``forced``
    ``mirror_b`` (True / False) skips the check. Streams in other length units (b's
    pitches :data:`UNIT_SCALE` times a's or more: mm against m) are aligned and read with
    b's translations at a's scale, which the messages say; b is returned as given, its
    scale judged later. ``candidates``: the speeds' candidate offsets, where known
    (:func:`_offset_candidates`). Returns ``(stream_a, stream_b, ConventionReport,
    TimeOffset, Sampling)``."""
    from simcalib.estimation.readings import (MIRROR_RATIO, mirror_sentence,
                                              mirror_untold_sentence)
    if candidates is None and time_offset == "estimate" and not sampling.paired_by_stamp:
        candidates = _offset_candidates(sa, sb, signal)
    unit = _unit_scale(sa, sb, sampling, seed, signal, candidates) if candidates else 1.0
    if unit != 1.0:         # b in other length units: aligned and read at a's scale
        from simcalib.estimation.scale import scaled_stream
        sa, sb1, conv, off, sampling = align_and_read(
            sa, scaled_stream(sb, 1.0 / unit), sampling, time_offset=time_offset,
            drift=drift, alpha=alpha, seed=seed, forced=forced, signal=signal,
            candidates=candidates)
        note = (f"; aligned and read with b's translations divided by {unit:.4g} (b's "
                "pitches against a's: other length units)")
        return (sa, scaled_stream(sb1, unit), replace(conv, message=conv.message + note),
                replace(off, message=off.message + note), sampling)
    forced = dict(forced or {})
    given = forced.pop("mirror_b", None)
    kw = dict(time_offset=time_offset, drift=drift, alpha=alpha, seed=seed, signal=signal,
              candidates=candidates)
    *out, (first, first_off) = _align_and_read(sa, sb, sampling,
                                               forced=forced | {"mirror_b": bool(given)}, **kw)
    if given is not None:
        return tuple(out)
    ratio, X_mirrored = _handedness(sa, sb, first, first_off, sampling, out[3], out[4],
                                    out[2], alpha=alpha, seed=seed, signal=signal,
                                    forced=forced)
    if math.isnan(ratio):                   # b's pitches follow a's
        return tuple(out)
    if not ratio > MIRROR_RATIO:
        conv = replace(out[2], mirror_ratio=ratio)
        if not conv.mirror_told:    # the data cannot tell: the other handedness's X shown
            conv = replace(conv, mirror_X=X_mirrored,
                           message=f"{conv.message}; {mirror_untold_sentence(ratio)}")
        return (*out[:2], conv, *out[3:])
    *out, _ = _align_and_read(sa, sb, sampling, forced=forced | {"mirror_b": True}, **kw)
    conv = out[2]
    return (*out[:2], replace(conv, mirror_ratio=ratio,
                              message=f"{conv.message}; {mirror_sentence(ratio)}"), *out[3:])


#: the final offset lies this many of the slower stream's median periods or more from the
#: first decision's: it is another offset (the candidates' least spacing,
#: :func:`_offset_candidates`), and the handedness not told at the first is checked there
MOVED_PERIODS = 4.0


def _handedness(sa, sb, first, first_off, sampling, off, final_sampling, final, *, alpha,
                seed, signal, forced) -> tuple[float, np.ndarray | None]:
    """``(ratio, X)`` of :func:`~simcalib.estimation.readings.mirrored_fit` (NaN, None:
    b's pitches follow a's, :func:`~simcalib.estimation.readings.pitch_agreement`): at the
    first decision's offset ``first_off`` (one the reading does not move: a mirrored b read
    as written can pull a refined offset off, where neither reading fits); where that does
    not tell and the final offset ``off`` lies :data:`MOVED_PERIODS` or more from it (a
    stop-placed offset, b on another clock: the first was the speeds' correlation's, wrong
    there), again at ``off`` with the ``final`` reading, b with ``off``'s clock steps
    removed, and that is used."""
    from simcalib.estimation.clock_step import shifted
    kw = dict(alpha=alpha, seed=seed, signal=signal, forced=forced)
    ratio, X, told = _mirror_check(sa, sb, first, offset=first_off, sampling=sampling, **kw)
    first_s = float(getattr(first_off, "offset_s", first_off))
    if told or abs(off.offset_s - first_s) < MOVED_PERIODS * _slower_period(sa, sb):
        return ratio, X
    for step in off.steps:                  # b's stamps as the final offset reads them
        sb = shifted(sb, step)
    return _mirror_check(sa, sb, final, offset=off, sampling=final_sampling, **kw)[:2]


def _mirror_check(sa, sb, report, *, offset, sampling, alpha, seed, signal, forced):
    """``(ratio, X, told)``: :func:`~simcalib.estimation.readings.mirrored_fit` at
    ``offset`` under ``report``'s reading (NaN, None where b's pitches follow a's) and
    whether that tells b's handedness (the pitches follow a's, or one side wins by more
    than :data:`~simcalib.estimation.readings.MIRROR_RATIO`; not where too few motions
    were scored)."""
    from simcalib.estimation.readings import (MIRROR_RATIO, PITCH_AGREEMENT, mirrored_fit,
                                              pitch_agreement)
    at = dict(offset=offset, seed=seed, sampling=sampling, signal=signal)
    if pitch_agreement(sa, sb, report, **at) > PITCH_AGREEMENT:  # b's pitches follow a's
        return math.nan, None, True
    ratio, X = mirrored_fit(sa, sb, report, alpha=alpha, **at, **forced)
    return ratio, X, not 1.0 / MIRROR_RATIO <= ratio <= MIRROR_RATIO and math.isfinite(ratio)


def _slower_period(sa, sb) -> float:
    """The slower stream's median sample period (s)."""
    from simcalib.estimation.speeds import as_time_poses
    return max(float(np.median(np.diff(as_time_poses(s)[0]))) for s in (sa, sb))


#: b's pitches this many times a's, or a's b's: streams in other length units (mm against
#: m: 1000), which the speeds' correlation does not see but the readings' scores and the
#: offset's cost do (they add both streams' translations); the scale itself is judged after
#: the offset (:mod:`simcalib.estimation.scale`)
UNIT_SCALE = 10.0


def _unit_scale(sa, sb, sampling, seed, signal, candidates) -> float:
    """b's length scale against a's (:func:`~simcalib.estimation.readings.
    pitch_magnitudes_scale`) at the ``candidates`` offset (:func:`_offset_candidates`)
    where the pitches agree best, where it lies beyond :data:`UNIT_SCALE` either way;
    else 1."""
    from simcalib.estimation.readings import pitch_magnitudes_scale
    fits = [pitch_magnitudes_scale(sa, sb, offset=c, seed=seed, sampling=sampling,
                                   signal=signal) for c in candidates]
    fits = [f for f in fits if np.isfinite(f[1])]
    if not fits:
        return 1.0
    s = min(fits, key=lambda f: f[1])[0]
    return float(s) if s > 0.0 and abs(np.log(s)) > np.log(UNIT_SCALE) else 1.0


def _align_and_read(sa, sb, sampling, *, time_offset="estimate", drift="auto", alpha=1.0,
                    seed=0, forced=None, signal="rotation", candidates=None, steps=()):
    """The streams' reading and their clock offset, decided in that order and checked
    again: the reading at the correlation's (reading-free) offset, the offset refined with
    that reading, then the reading decided again at the final offset (it is what the run
    reports). ``signal`` (:func:`~simcalib.estimation.stillness.check_streams_move`):
    ``rotation`` correlates angular speeds, ``translation`` (a rig that does not turn)
    translation speeds, and scores the readings on motions that translate. Streams paired
    by equal stamps that both sample a continuous motion are checked for an offset the stamps hide
    (:mod:`simcalib.estimation.hidden_offset`), which unpairs them. Returns ``(stream_a,
    stream_b, ConventionReport, TimeOffset, Sampling, first)``, ``first`` the report and the
    offset of :func:`first_reading`."""
    from simcalib.estimation.readings import apply_conventions
    from simcalib.estimation.alignment import estimate_time_offset
    from simcalib.estimation.clock_step import find_step, holds
    detect = _detector(sa, sb, sampling, alpha=alpha, seed=seed, forced=forced, signal=signal)
    conv, off = first = _first(sa, sb, sampling, detect, time_offset, signal, candidates)
    if time_offset != "estimate":
        return (*apply_conventions(sa, sb, conv), conv, off, sampling, first)
    again = dict(time_offset=time_offset, drift=drift, alpha=alpha, seed=seed, forced=forced,
                 signal=signal)
    if sampling.paired_by_stamp:            # equal stamps, or equal after a constant shift
        return _stamp_paired(sa, sb, sampling, detect, conv, off, again, steps, first)
    a1, b1 = apply_conventions(sa, sb, conv)
    # a rotating rig: "auto" (the same rule as check_streams_move) consults the
    # translation speeds too where the angular ones leave the offset in doubt
    by = "auto" if signal == "rotation" else signal
    off = replace(estimate_time_offset(a1, b1, drift=drift, alpha=alpha, signal=by),
                  steps=steps)       # the steps removed from b's stamps before
    final = detect(off)
    if (final.invert_a, final.invert_b, final.swap_scalar_a, final.swap_scalar_b) != (
            conv.invert_a, conv.invert_b, conv.swap_scalar_a, conv.swap_scalar_b):
        a1, b1 = apply_conventions(sa, sb, final)       # the reading changed: once more
        off = replace(estimate_time_offset(a1, b1, drift=drift, alpha=alpha, signal=by),
                      steps=steps)
        final = detect(off)
    step = find_step(a1, b1, off, alpha=alpha, signal=by)
    if step is not None:                    # b's clock steps: shifted, aligned again
        out = _shifted_again(sa, sb, step, again, steps, sampling=sampling)
        if holds(step, out[3]):             # else removing it explained nothing
            return out
    return (*apply_conventions(sa, sb, final), final, off, sampling, first)


def _stamp_paired(sa, sb, sampling, detect, conv, off, kw, steps, first):
    """:func:`_align_and_read` of streams paired by stamp: :func:`_paired_by_stamp`; where
    the stamps hid a clock step, b's stamps shifted and aligned again, unless the step
    does not hold (:func:`~simcalib.estimation.clock_step.holds`): then as without it."""
    from simcalib.estimation.clock_step import holds

    def paired(search):
        return _paired_by_stamp(sa, sb, sampling, detect, conv, replace(off, steps=steps),
                                drift=kw["drift"], alpha=kw["alpha"], signal=kw["signal"],
                                step_search=search)
    a1, b1, conv1, off1, sampling1 = paired(True)
    if len(off1.steps) > len(steps):        # the stamps hid a clock step: shifted, again
        out = _shifted_again(sa, sb, off1.steps[-1], kw, steps, reclassify=True)
        if holds(off1.steps[-1], out[3]):
            return out
        a1, b1, conv1, off1, sampling1 = paired(False)
    return a1, b1, conv1, replace(off1, steps=steps), sampling1, first


def _shifted_again(sa, sb, step, kw, steps, sampling=None, reclassify=False):
    """:func:`_align_and_read` of b with its stamps from the clock ``step``
    (:mod:`simcalib.estimation.clock_step`) on shifted back (``reclassify``: its sampling
    decided again, for streams paired by stamp), the step added to the offset's
    ``steps`` and named first in its message."""
    from simcalib.estimation.clock_step import shifted
    from simcalib.estimation.sampling import classify_sampling
    sb = shifted(sb, step)
    if reclassify:
        sampling = classify_sampling(sa, sb)
    *out, off, sampling, first = _align_and_read(sa, sb, sampling, **kw,
                                                 steps=(*steps, step))
    return (*out, replace(off, message=f"{step.line()}; {off.message}"), sampling, first)


def _detector(sa, sb, sampling, *, alpha, seed, forced, signal):
    """``detect(offset, sampling=sampling)``: the reading of ``sa``, ``sb`` at an offset."""
    from simcalib.estimation.readings import detect_conventions
    forced = forced or {}
    return lambda off, smp=sampling: detect_conventions(
        sa, sb, offset=off, alpha=alpha, seed=seed, sampling=smp, signal=signal, **forced)


def first_reading(sa, sb, sampling, *, time_offset="estimate", alpha=1.0, seed=0,
                  forced=None, signal="rotation"):
    """``(ConventionReport, offset)``: the reading decided at an offset the reading does
    not move: the given one, the stamps' (stamp-paired streams), else the best of the
    speed correlation's candidate offsets (:func:`_offset_candidates`)."""
    detect = _detector(sa, sb, sampling, alpha=alpha, seed=seed, forced=forced, signal=signal)
    return _first(sa, sb, sampling, detect, time_offset, signal)


def _first(sa, sb, sampling, detect, time_offset, signal, candidates=None):
    from simcalib.estimation.alignment import TimeOffset, _as_offset
    if time_offset != "estimate":
        off = _as_offset(time_offset)
        return detect(off), off
    if sampling.paired_by_stamp:
        shift = float(getattr(sampling, "shift_s", 0.0))
        off = TimeOffset(shift, 0.0, shift, float("nan"), np.zeros(0), np.zeros(0),
                         refined=False, decision="shared_stamps", message=sampling.reason)
        return detect(off), off
    candidates = candidates or _offset_candidates(sa, sb, signal)
    conv = min((detect(c) for c in candidates), key=_best_score)
    return conv, conv.offset_s


def _paired_by_stamp(sa, sb, sampling, detect, conv, off, *, drift, alpha, signal,
                     step_search=True):
    """:func:`align_and_read` for stamp-paired streams read ``conv`` at the stamps' offset
    ``off`` (the shift, 0 for equal stamps): that offset, unless the motions show one the
    stamps hide (or a clock step, where ``step_search``)."""
    from simcalib.estimation.readings import apply_conventions
    from simcalib.estimation.hidden_offset import stamps_hide_offset
    a1, b1 = apply_conventions(sa, sb, conv)
    sampling, off = stamps_hide_offset(a1, b1, sampling, off, alpha=alpha, drift=drift,
                                       signal=signal, step_search=step_search)
    if sampling.paired_by_stamp:
        return a1, b1, conv, off, sampling
    final = detect(off, sampling)
    return (*apply_conventions(sa, sb, final), final, off, sampling)


def _best_score(conv) -> float:
    return min(conv.scores.values()) if conv.scores else float("inf")


def _offset_candidates(sa, sb, signal="rotation") -> list[float]:
    """Offsets at which to decide the reading: the angular- (or translation-) speed
    correlation's peak (it does not depend on the reading), its other peaks of similar
    height (a periodic motion) and 0."""
    from simcalib.estimation.alignment import _other_peaks, estimate_time_offset
    from simcalib.estimation.speeds import as_time_poses
    coarse = estimate_time_offset(sa, sb, refine=False, signal=signal)
    ta, tb = as_time_poses(sa)[0], as_time_poses(sb)[0]
    slow = max(float(np.median(np.diff(ta))), float(np.median(np.diff(tb))))
    cands = [coarse.offset_s] + _other_peaks(coarse.lags_s, coarse.correlation,
                                             coarse.peak_correlation, coarse.offset_s,
                                             4 * slow)
    lo, hi = coarse.window_s
    if lo <= 0.0 <= hi and all(abs(c) > 2 * slow for c in cands):
        cands.append(0.0)
    return cands
