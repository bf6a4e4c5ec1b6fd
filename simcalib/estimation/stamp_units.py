"""Are both streams' stamps in seconds? Their unit, told from both streams where the data can
tell it: :func:`stamps_to_seconds`.

A file's stamps are read as seconds unless their magnitude shows unix time in ms, us or ns
(:mod:`simcalib.importers._stamps`). Stamps relative to the recording's start in ms, us or
ns show no such magnitude; they show in what they imply:

* **motion** (:func:`motion_units`): a stream that moves densely - where it moves (the
  half of its samples turning most over the next 4), the rotation over 4 samples at
  least :data:`DENSE_GROWTH` times the rotation over one (a motion, not noise) and
  at most :data:`DENSE_SHARE` of the rotation between poses half the recording apart (small
  steps, not stations) - while its stamps step by :data:`MIN_SUSPECT_PERIOD` or more: read
  as seconds, a continuous motion sampled every 2 s or slower. Its unit is the one that
  puts the period within :data:`DENSE_PERIOD_S` and the angular speed within
  :data:`SPEED_DEG_S` (a 100 Hz stream in ms steps by 10: 10 ms and ~20 deg/s, where us
  would give 10 us and 20,000 deg/s);
* **the pair**: two streams of one recording span about the same time, so spans a factor
  near 1e3, 1e6 or 1e9 apart (within :data:`SPAN_SLACK`) are a unit apart. The stream of
  larger stamps is rescaled when the other's unit is known (given, unix time, or told by
  its motion), or when its rescaled stamps are then shared by both streams (stations).

A unit told is applied (stamps divided) and counted as a repair (``stamps_ms_to_s``, ...,
named in the stream's ``detection``), which the console and ``calibration.json`` list.
Where the stamps are suspect (a factor near 1e3 between the spans, a dense stream stepping
by seconds, a step beyond any pose sensor) but the data cannot tell the unit, a one-line
:class:`simcalib.errors.DataError` names the spans and steps received and the keys that say
it (``stamps_unit_a=ms``, ...). Stamps that are sample numbers (0, 1, 2, ...) are not times
and are never rescaled; station recordings whose stamps share one unit are left alone (the
unit changes nothing there: they are paired by stamp). Stamps that count by 1 are sample
numbers or a 1 kHz stream written in whole ms, alike on their own; the pair tells them
apart: beside a stream whose stamps are times, a counting stream of
:data:`MIN_DENSE_POSES` or more poses spanning 1e3 times as long is the 1 kHz stream, read
as ms (``stamps_ms_to_s``, the reason named); two counting streams stay sample numbers.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from simcalib.errors import DataError
from simcalib.estimation.sampling import is_sample_numbers, median_period
from simcalib.importers._stamps import MAX_PERIOD_S, UNIT_FACTORS

__all__ = ["stamps_to_seconds", "motion_units", "MIN_SUSPECT_PERIOD", "DENSE_GROWTH",
           "DENSE_SHARE", "DENSE_PERIOD_S", "SPEED_DEG_S", "SPAN_SLACK", "MIN_DENSE_POSES"]

#: a stream whose stamps step by less than this (median) is never suspected of another unit
#: by its motion (sample numbers step by 1)
MIN_SUSPECT_PERIOD = 2.0
#: dense motion: the rotation over 4 samples at least this many times that over 1 ...
DENSE_GROWTH = 2.5
#: ... and at most this share of the rotation between poses half the recording apart
DENSE_SHARE = 0.25
#: fewer poses than this are not judged by their motion
MIN_DENSE_POSES = 50
#: the periods (s) of a densely sampling pose sensor (5 kHz .. 1 Hz)
DENSE_PERIOD_S = (2e-4, 1.0)
#: the median angular speeds (deg/s) of a moving rig, over its samples
SPEED_DEG_S = (0.5, 2000.0)
#: spans a factor 10^(3k +- SPAN_SLACK) apart are k units of 1e3 apart
SPAN_SLACK = 0.75
_UNIT_OF = {1e3: "ms", 1e6: "us", 1e9: "ns"}


def _rotation_deg(R, lag: int) -> np.ndarray:
    from simcalib.geometry import rotation_angle_rad
    return np.degrees(rotation_angle_rad(np.swapaxes(R[:-lag], 1, 2) @ R[lag:]))


def motion_units(stream) -> tuple[list[str], str] | None:
    """``(units, why)``: the stamp units (``ms``, ``us``, ``ns``) that make ``stream`` a
    dense pose sensor when its motion shows it samples densely while its stamps step by
    :data:`MIN_SUSPECT_PERIOD` or more (module doc); ``units`` empty when none fits. None
    when the motion says nothing (steps shorter, too few poses, stations, noise)."""
    t = np.asarray(stream.timestamps_s, dtype=np.float64)
    p = median_period(t)
    if t.size < MIN_DENSE_POSES or not p >= MIN_SUSPECT_PERIOD or is_sample_numbers(t) \
            or getattr(stream, "synthetic_time", False):
        return None
    R = np.asarray(stream.T_world_sensor, dtype=np.float64)[:, :3, :3]
    r1, r4 = _rotation_deg(R, 1)[:-3], _rotation_deg(R, 4)
    moving = r4 >= np.median(r4)                      # not the stops of a stop-and-go
    th1, th4 = float(np.median(r1[moving])), float(np.median(r4[moving]))
    spread = float(np.median(_rotation_deg(R, t.size // 2)))
    if not (th1 > 0 and th4 >= DENSE_GROWTH * th1 and th4 <= DENSE_SHARE * spread):
        return None
    speed = th4 / (4.0 * p)                           # deg per stamp unit
    units = [u for u, f in UNIT_FACTORS.items()
             if DENSE_PERIOD_S[0] <= p / f <= DENSE_PERIOD_S[1]
             and SPEED_DEG_S[0] <= speed * f <= SPEED_DEG_S[1]]
    why = (f"its poses move densely ({th1:.2g} deg a step, {th4:.2g} over 4, "
           f"{spread:.2g} across the recording) while its stamps step by {p:.4g}")
    return units, why


def _span(s) -> float:
    t = np.asarray(s.timestamps_s, dtype=np.float64)
    return float(t[-1] - t[0]) if t.size >= 2 else 0.0


def _unit_factor(ratio: float) -> float | None:
    """The factor 1, 1e3, 1e6 or 1e9 within :data:`SPAN_SLACK` decades of ``ratio``."""
    if not (ratio > 0 and math.isfinite(ratio)):
        return None
    k = round(math.log10(ratio) / 3.0)
    if 0 <= k <= 3 and abs(math.log10(ratio) - 3 * k) <= SPAN_SLACK:
        return 10.0 ** (3 * k)
    return None


def _rescaled(s, unit: str, why: str):
    """``s`` with its stamps divided by ``unit``'s factor, counted as a repair."""
    f = UNIT_FACTORS[unit]
    t = np.asarray(s.timestamps_s, dtype=np.float64) / f
    t.setflags(write=False)
    note = f"stamps read as {unit} relative to the recording ({why}) and rescaled to seconds"
    return dataclasses.replace(
        s, timestamps_s=t, stamps_unit=unit,
        repairs={**s.repairs, f"stamps_{unit}_to_s": int(t.size)},
        detection=f"{s.detection}; {note}" if s.detection else note)


#: rescaling must bring the two streams' periods this many decades closer to count
PERIOD_GAIN_DECADES = 1.5


def _given(s, unit: str):
    """``s`` under a unit the caller gave (``auto``: as read). A stream whose unit was
    already decided where it was read (given there, or unix time) keeps it."""
    if unit in (None, "auto") or s.stamps_unit:
        return s
    f = UNIT_FACTORS[unit]
    if f == 1.0:
        return dataclasses.replace(s, stamps_unit="s")
    t = np.asarray(s.timestamps_s, dtype=np.float64) / f
    t.setflags(write=False)
    note = f"stamps in {unit} (given), read as seconds"
    return dataclasses.replace(s, timestamps_s=t, stamps_unit=unit,
                               detection=f"{s.detection}; {note}" if s.detection else note)


def _describe(k, s) -> str:
    t = np.asarray(s.timestamps_s, dtype=np.float64)
    return (f"{k} spans {_span(s):.6g} from {t[0]:.6g} in {t.size} poses, a step of "
            f"{median_period(t):.4g}")


def _counts(s) -> bool:
    """Stamps that count by 1 (:func:`simcalib.estimation.sampling.is_sample_numbers`):
    sample numbers, or a 1 kHz stream in whole ms (a 1 Hz one in whole s), whose unit was
    not told where it was read."""
    return not s.stamps_unit and is_sample_numbers(np.asarray(s.timestamps_s))


def _ms_counter(st: dict, big: str, small: str, f: float) -> str | None:
    """Why stream ``big``, whose stamps count by 1, is a 1 kHz stream in whole ms and not
    sample numbers (None when the pair does not show it): the other stream's stamps are
    times (they do not count by 1) and ``big`` spans 1e3 times as long, a dense stream's
    :data:`MIN_DENSE_POSES` or more poses (sample numbers span as many samples as the
    stream holds, which against seconds is a factor near 1e3 only at 1 kHz: the same
    stamps)."""
    if f != 1e3 or _counts(st[small]) or st[big].n < MIN_DENSE_POSES:
        return None
    return (f"its stamps count by 1 like sample numbers, but it spans "
            f"{_span(st[big]) / _span(st[small]):.4g} times stream {small}'s stamps in "
            f"time: a {st[big].n}-pose stream at 1 kHz in whole ms")


def _by_pair(st: dict, motion: dict) -> dict:
    """Rescale the stream of larger stamps when both spans and periods show the two
    streams a unit apart (module doc); DataError when that contradicts its motion. Stamps
    that count by 1 are sample numbers unless the pair shows them a 1 kHz stream in whole
    ms (:func:`_ms_counter`)."""
    if any(s.synthetic_time for s in st.values()):
        return st
    big, small = sorted(st, key=lambda k: -_span(st[k]))
    f = _unit_factor(_span(st[big]) / max(_span(st[small]), 1e-300))
    if f is None or f == 1.0 or st[big].stamps_unit:
        return st
    if _counts(st[big]) or _counts(st[small]):
        why = _ms_counter(st, big, small, f) if _counts(st[big]) else None
        return st if why is None else {**st, big: _rescaled(st[big], "ms", why)}
    pb, ps = (median_period(np.asarray(st[k].timestamps_s)) for k in (big, small))
    if not (pb > 0 and ps > 0) or abs(math.log10(pb / f / ps)) > \
            abs(math.log10(pb / ps)) - PERIOD_GAIN_DECADES:
        return st
    unit = _UNIT_OF[f]
    if motion.get(big) is not None and unit not in motion[big][0]:
        raise DataError(
            f"the streams' stamps disagree: {_describe('a', st['a'])}; "
            f"{_describe('b', st['b'])}: {big}'s look {unit} against {small}'s, but "
            f"{big}'s motion says {' or '.join(motion[big][0]) or 'no unit'} "
            f"({motion[big][1]}); give the units: stamps_unit_a / stamps_unit_b = s, ms, us "
            "or ns")
    why = (f"its span is {_span(st[big]) / _span(st[small]):.3g} times stream {small}'s and "
           f"its step {pb / ps:.3g} times")
    return {**st, big: _rescaled(st[big], unit, why)}


def _check_told(st: dict, motion: dict) -> None:
    """DataError for a stream whose stamps are still suspect: a dense motion stepping by
    seconds, or a step beyond any pose sensor."""
    for k, s in st.items():
        if s.stamps_unit:
            continue
        p = median_period(np.asarray(s.timestamps_s))
        other = "b" if k == "a" else "a"
        if motion.get(k) is not None:
            units, why = motion[k]
            told = ("no unit makes it a pose sensor" if not units else
                    f"{' and '.join(units)} fit alike")
            raise DataError(
                f"stream {k} ({s.source}): {why}: read as seconds a continuous motion "
                f"sampled every {p:.3g} s, and {told}; {_describe(other, st[other])}. Give "
                f"the unit: stamps_unit_{k}=ms (us, ns), or stamps_unit_{k}=s to read the "
                "stamps as seconds")
        if p > MAX_PERIOD_S:
            raise DataError(
                f"stream {k} ({s.source}): the stamps step by {p:.4g} per pose (median; "
                f"{_describe(k, s)}): read as seconds a pose every {p / 3600:.3g} h, beyond "
                f"any pose sensor (at most {MAX_PERIOD_S:g} s), and the unit cannot be told "
                f"(ms, us and ns would give {p / 1e3:.3g}, {p / 1e6:.3g} and {p / 1e9:.3g} "
                f"s; {_describe(other, st[other])}); allowed: stamps in seconds, unix time "
                f"in s, ms, us or ns, or the unit given: stamps_unit_{k}=ms (us, ns)")


def stamps_to_seconds(sa, sb, unit_a: str = "auto", unit_b: str = "auto"):
    """``(stream_a, stream_b)`` with their stamps in seconds where the data tell the unit
    (module doc); ``unit_a`` / ``unit_b``: ``auto`` or the unit given (``s``, ``ms``,
    ``us``, ``ns``) for streams whose unit was not decided where they were read. Raises
    :class:`simcalib.errors.DataError` for stamps whose unit is suspect but cannot be
    told."""
    st = {"a": _given(sa, unit_a), "b": _given(sb, unit_b)}
    motion = {k: None if s.stamps_unit else motion_units(s) for k, s in st.items()}
    for k, m in motion.items():
        if m is not None and len(m[0]) == 1:
            st[k] = _rescaled(st[k], m[0][0], m[1])
    st = _by_pair(st, motion)
    _check_told(st, motion)
    return st["a"], st["b"]
