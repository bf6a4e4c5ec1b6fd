"""The unit of one file's stamps, as far as the file alone can tell (the importers'
``stamps_unit`` option; both streams together: :mod:`simcalib.estimation.stamp_units`).

``auto`` (the default): stamps whose median is unix time in ms, us or ns (1.7e12, 1.7e15,
1.7e18 around 2024) are rescaled to seconds and counted as a repair; other stamps are read
as seconds (relative times, sample indices) unless their median period exceeds
:data:`MAX_PERIOD_S`, where no unit can be told and it is a DataError. ``pair``: the same,
but such stamps are left as they are for the caller, who judges them with the other
stream. A unit name (``s``, ``ms``, ``us``, ``ns``): the file's numbers are in that unit,
no detection.
"""

from __future__ import annotations

import numpy as np

from simcalib.errors import DataError

__all__ = ["UNIX_TIME_S", "STAMP_UNITS", "UNIT_FACTORS", "MAX_PERIOD_S", "STAMPS_UNIT_CHOICES",
           "stamps_in_seconds", "unix_unit", "longest_recording", "recording_runs",
           "RESTART_PERIODS", "RESTART_MAX", "RESTART_MIN_ROWS"]

#: unix time in seconds of a plausible recording (1990-01-01 .. 2100-01-01): stamps of that
#: magnitude in another unit are rescaled (:func:`stamps_in_seconds`)
UNIX_TIME_S = (6.3e8, 4.11e9)
STAMP_UNITS = (("s", 1.0), ("ms", 1e3), ("us", 1e6), ("ns", 1e9))
UNIT_FACTORS = dict(STAMP_UNITS)
#: the longest median period (s) of any pose sensor (one pose in 2.8 h)
MAX_PERIOD_S = 1e4
#: the values of the ``stamps_unit`` reading option
STAMPS_UNIT_CHOICES = ("auto", "pair", "s", "ms", "us", "ns")


def _period(t: np.ndarray) -> float:
    return float(np.median(np.diff(t))) if t.size >= 2 else 0.0


def unix_unit(t) -> str | None:
    """The unit in which stamps ``t`` are unix time (``s``, ``ms``, ``us``, ``ns``: their
    median a date of 1990..2100 and their period at most :data:`MAX_PERIOD_S` in that
    unit), else None."""
    t = np.asarray(t, dtype=np.float64)
    mid, period = float(np.median(t)), _period(t)
    for unit, factor in STAMP_UNITS:
        if UNIX_TIME_S[0] <= mid / factor <= UNIX_TIME_S[1] and period / factor <= MAX_PERIOD_S:
            return unit
    return None


def stamps_in_seconds(t: np.ndarray, label: str, repairs: dict,
                      stamps_unit: str = "auto") -> tuple[np.ndarray, str, str]:
    """``(t in seconds, note, unit)`` of one file's stamps under ``stamps_unit`` (module
    doc); ``unit`` is the unit decided (``""``: read as seconds, not told). A rescale of
    unix time is counted in ``repairs`` (``stamps_ns_to_s``, ...) and named in the note."""
    if stamps_unit not in STAMPS_UNIT_CHOICES:
        raise ValueError(f"stamps_unit must be one of {', '.join(STAMPS_UNIT_CHOICES)}; "
                         f"received {stamps_unit!r}")
    if stamps_unit in UNIT_FACTORS:
        note = "" if stamps_unit == "s" else f"stamps in {stamps_unit} (given), read as seconds"
        return t / UNIT_FACTORS[stamps_unit], note, stamps_unit
    unit = unix_unit(t)
    if unit == "s":
        return t, "", "s"
    if unit is not None:
        repairs[f"stamps_{unit}_to_s"] = int(t.size)
        note = (f"stamps read as unix time in {unit} (median {float(np.median(t)):.6g}) and "
                "rescaled to seconds")
        return t / UNIT_FACTORS[unit], note, unit
    period = _period(t)
    if period <= MAX_PERIOD_S or stamps_unit == "pair":
        return t, "", ""
    raise DataError(
        f"{label}: the stamps step by {period:.4g} per pose (median; first {t[0]:.6g}, "
        f"last {t[-1]:.6g}): read as seconds that is a pose every {period / 3600:.3g} h, "
        f"beyond any pose sensor (at most {MAX_PERIOD_S:g} s), and the unit cannot be told "
        f"(ms, us and ns would give {period / 1e3:.3g}, {period / 1e6:.3g} and "
        f"{period / 1e9:.3g} s); allowed: stamps in seconds, or unix time in s, ms, us or "
        "ns (told by its magnitude)")


#: another recording in the same file: stamps that go back (:func:`longest_recording`)
RESTART_PERIODS, RESTART_MAX, RESTART_MIN_ROWS = 10.0, 3, 10


def recording_runs(t: np.ndarray, T: np.ndarray) -> list[tuple[int, int]] | None:
    """``[(first row, end row)]`` of each recording in a file whose stamps, in file order,
    go back by more than RESTART_PERIODS median periods at 1..RESTART_MAX rows, are in
    order elsewhere, and whose runs (RESTART_MIN_ROWS rows or more each) overlap in time,
    the shorter mostly at stamps the other does not have or holding other poses at the
    stamps they share, in one block (a logger restarted, numbering its rows from 0 again);
    None for one recording. Rows shuffled, a few out of order, or re-published at their
    stamps are not recordings."""
    d = np.diff(t)
    if t.size < 2 * RESTART_MIN_ROWS or not np.any(d < 0) or not np.any(d > 0):
        return None
    back = np.flatnonzero(d < -RESTART_PERIODS * np.median(d[d > 0]))
    if back.size == 0 or np.count_nonzero(d < 0) > RESTART_MAX:
        return None
    edges = np.concatenate([[0], back + 1, [t.size]])
    runs = list(zip(edges[:-1].tolist(), edges[1:].tolist()))
    if min(e1 - e0 for e0, e1 in runs) < RESTART_MIN_ROWS or not any(
            _other_recording(t, T, r, q) for i, r in enumerate(runs) for q in runs[i + 1:]):
        return None
    return runs


def _other_recording(t, T, r, q) -> bool:
    """Runs ``r`` and ``q`` (row ranges) overlap in time, and the shorter lies mostly at
    stamps the other does not have, or shares a block of the other's consecutive stamps
    and holds other poses at half of them."""
    (s0, s1), (l0, l1) = sorted((r, q), key=lambda e: e[1] - e[0])
    ts, tl = t[s0:s1], t[l0:l1]
    if min(ts[-1], tl[-1]) <= max(ts[0], tl[0]):
        return False
    shared = np.isin(ts, tl)
    if shared.mean() < 0.5:
        return True
    order = np.argsort(tl, kind="stable")
    k = order[np.searchsorted(tl[order], ts[shared])]
    if not np.all(np.diff(k) == 1):         # rows re-published here and there: not a run
        return False
    return bool((np.abs(T[s0:s1][shared] - T[l0 + k]).max(axis=(1, 2)) > 1e-9).mean() >= 0.5)


def longest_recording(t: np.ndarray, T: np.ndarray, repairs: dict,
                      recording: int | None = None) -> tuple:
    """``(t, T)`` of the longest recording (by duration; ``recording``: the one of that
    number, from 1 in file order) of a file that holds several (:func:`recording_runs`),
    which sorting would interleave. The others are dropped and counted
    (``stamps_restarted``, ``rows_of_other_recordings_dropped``; ``recordings_in_file``,
    ``recording_kept``)."""
    runs = recording_runs(t, T)
    if runs is None:
        return t, T
    if recording is None:
        recording = 1 + max(range(len(runs)), key=lambda k: (t[runs[k][1] - 1]
                                                              - t[runs[k][0]], k))
    elif not 1 <= recording <= len(runs):
        raise DataError(f"recording {recording} asked of a file holding {len(runs)} "
                        f"recordings; allowed: 1..{len(runs)}")
    e0, e1 = runs[recording - 1]
    repairs["stamps_restarted"] = len(runs) - 1
    repairs["rows_of_other_recordings_dropped"] = int(t.size - (e1 - e0))
    repairs["recordings_in_file"], repairs["recording_kept"] = len(runs), int(recording)
    return t[e0:e1], T[e0:e1]
