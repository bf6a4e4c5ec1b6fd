"""Rows of two station files numbered by sample, where a file lost rows.

Station data are often written with the pose's number for a stamp (0, 1, 2, ...): the
robot's poses in one file, the camera's target poses in the other. When a detection fails,
the camera's file lacks that row, and a tool that numbers the rows it writes shifts every
later pose by one: pairing by number then pairs each later camera pose with the wrong robot
pose. On three public station sets with one camera row taken out and the rest renumbered,
every direction of X came out "undetermined", with the reading of the files named as the
doubt, and nothing said about the rows.

Both sensors of a rigid rig turn by the same angle between any two poses (whatever the
files' reading, X, the worlds or the scale). :func:`align_rows` pairs the rows by that rule:
a dynamic programme over the two files in order, each step from one pair of rows to the
next costing the misfit of their rotation angles (capped at :data:`CAP_DEG`), each row left
without a partner :data:`SKIP_DEG`, at most :data:`MAX_SKIP` rows skipped at once. The
pairing found replaces the pairing by number only where the pairs by number break the rule
:data:`GAIN` times more (median over every two pairs) and by :data:`MIN_DEG` or more;
the rows left without a partner are dropped, counted (``rows_without_a_partner``) and
named in a warning. Files whose rows all pair by number may have lost a row each, at
different places, each renumbered: the rows between are paired one off. They are searched
the same way (files of more than :data:`FEW_ROWS` rows only where some row breaks the rule
with its :data:`NEAR` neighbours either side :data:`GAIN` times more than paired a row off,
or than the median row: O(n)), and re-paired only where the rows given another partner
(those whose motions turn, breaking the rule by :data:`MIN_DEG` or more by number) break it
:data:`GAIN` times more by number than by the pairing found (median of each row's median
over every other pair).

Station data stamped by two clocks (the robot controller's and the camera computer's)
share no stamps: they were taken for continuous streams, interpolated between stations
seconds apart, and X came out 6-17 deg off with offset 0 and no warning (generated
stations, b's clock 1.7 s late with 50 ms of trigger jitter). :func:`pair_by_lag` pairs
such streams - both step by :data:`MIN_PERIOD_S` or more (a raster of stations a
second apart looks like a path sampled at 1 Hz: the poses cannot tell a stop; pose
sensors that sample a motion run at 5 Hz and more) - one-to-one after a constant shift:
the median stamp difference at each lag of the rows (:func:`simcalib.estimation.
sampling.lag_shifts`), partners within a quarter
of the smaller 10th-percentile spacing; the lag is the one that pairs :data:`PAIRED_SHARE` of the
sparser stream and whose pairs break the equal-angle rule :data:`LAG_GAIN` times less
than every other lag that pairs half as many (streams that do not turn: the only lag that
does; the angles of every two rows of each file are taken once, from their quaternions,
for every lag: 0.2 s at 1000 rows). Where the angles cannot tell the lag (a raster of
stations repeats its turns: a lag of a row of it keeps most angles), the other invariant of
AX = XB may: both sensors move alike along the turn's axis (the screw's pitch;
:func:`_pitch_lag`, b's scale fitted per lag). b's rows then take their partners' stamps
plus that shift, which is the offset
reported. Counters of one continuous motion a lag apart (a pairing that only shifts the
rows, both streams sampling a motion: :func:`simcalib.estimation.hidden_offset.continuous`)
are left to :mod:`~simcalib.estimation.hidden_offset`, which tells the lag to a fraction of
a sample. Streams that do not turn (a gantry) carry no angle to pair by, and are
left paired by number; so are files whose quaternion order is misread (their angles are
wrong until the reading is decided).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from simcalib.geometry import quat_from_matrix, rotation_angle_rad

__all__ = ["align_rows", "realign_rows", "pair_by_lag", "pair_angles_rad", "PAIRED_SHARE",
           "CAP_DEG", "SKIP_DEG", "MAX_SKIP", "GAIN", "MIN_DEG", "MAX_ROWS", "MIN_PERIOD_S",
           "LAG_GAIN", "moved_marks", "NEAR", "NEAR_GAIN", "FEW_ROWS", "PITCH_MIN_DEG",
           "PITCH_QUANTILE"]

#: a step's misfit counts at most this much (deg): a wrong pair costs about this
CAP_DEG = 10.0
#: a row without a partner costs this much (deg): more than a noisy pair's misfit
SKIP_DEG = 3.0
#: at most this many rows of a file skipped between two pairs
MAX_SKIP = 3
#: the pairing by number is replaced where it breaks the equal-angle rule this many times
#: more (median over every two pairs) than the pairing found ...
GAIN = 10.0
#: ... and by this much (median, deg)
MIN_DEG = 0.5
#: rows either side whose motions tell a row's partner in files whose rows all pair by
#: number (a row lost in each at different places)
NEAR = 2
#: ... where one row breaks the rule this many times more paired by number than a row off
#: (and :data:`GAIN` times more than the median row; noisy rows fit a row off up to ~4x
#: better: crwhe_tag0_cam1 row 177)
NEAR_GAIN = 5.0
#: ... searched for such stretches in full (:func:`align_rows`) up to this many rows, beyond
#: only where a row's neighbours tell it (:func:`_shifted_rows_fit`; ~3 ms at 250 rows)
FEW_ROWS = 50
#: files with more rows than this are not re-paired (the angles of every two rows)
MAX_ROWS = 1000
#: a lag's shift must pair this share of the sparser stream's rows
PAIRED_SHARE = 0.8
#: the lag whose pairs break the equal-angle rule this many times less than any other's
#: is the one (the public station sets on two clocks, ``two_clocks_b`` in
#: docs/real-perturbations.md: the right lag 5x (tabb: a grid of repeated orientations)
#: to 150x better than the next; a SCARA, turning about one axis, 1.1x (told by the pitch:
#: :data:`PITCH_QUANTILE`) and the crwhe sets, 0.4 deg a step, 1.2-1.6x cannot tell it and
#: stay two clocks; a wrong lag cannot beat
#: the right one's noise-level misfit, so a lower bar than :data:`GAIN` risks little)
LAG_GAIN = 3.0
#: where the angles cannot tell the lag, the screws' pitches are compared over the pairs
#: that turn this much (deg) in both files (the axis of a smaller turn is noise) ...
PITCH_MIN_DEG = 5.0
#: ... at this quantile of their misfit (a lag of a row or a column of a raster of stations
#: keeps most pairs' heights: the median cannot tell it; scara_handeye4dof under
#: ``two_clocks_b``: the right lag 5.5x less than the next; the crwhe sets 1.0-1.8x: stay
#: two clocks)
PITCH_QUANTILE = 0.9
#: streams on two clocks are taken for stations only where both step by this much or more
#: (median, s): a robot's moves between stops take a second or more
MIN_PERIOD_S = 0.5


def pair_angles_rad(T: np.ndarray) -> np.ndarray:
    """``(n, n)`` rotation angles (rad) between every two poses ``T`` (n, 4, 4): the
    motions' angles, which both sensors of a rigid rig share. From the poses' unit
    quaternions (``conj(q_i) q_j``: no ``(n, n, 3, 3)`` products of matrices; 7x faster at
    1000 poses; equal to rounding, exact at 0), symmetric to the bit."""
    x, y, z, w = quat_from_matrix(T[:, :3, :3]).T
    cos_half = np.abs(np.outer(w, w) + np.outer(x, x) + np.outer(y, y) + np.outer(z, z))
    sin2 = np.zeros_like(cos_half)
    for M in (np.outer(w, x) + np.outer(z, y), np.outer(w, y) + np.outer(x, z),
              np.outer(w, z) + np.outer(y, x)):      # conj(q_i) q_j's vector part: M - M^T
        sin2 += np.square(M - M.T)
    return 2.0 * np.arctan2(np.sqrt(sin2), cos_half)


def _angles(T: np.ndarray) -> np.ndarray:
    """:func:`pair_angles_rad` in degrees."""
    return np.degrees(pair_angles_rad(T))


def align_rows(T_a: np.ndarray, T_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(ia, ib)`` of the rows of ``T_a`` and ``T_b`` (file order) paired by the
    equal-angle rule (module doc), increasing."""
    Aa, Ab = _angles(T_a), _angles(T_b)
    na, nb = Aa.shape[0], Ab.shape[0]
    ii, jj = np.meshgrid(np.arange(na), np.arange(nb), indexing="ij")
    cost = SKIP_DEG * (ii + jj).astype(np.float64)          # rows skipped before the first
    back = np.full((na, nb, 2), -1, dtype=np.int64)
    diag = [np.diagonal(Ab, dj) for dj in range(min(MAX_SKIP + 2, nb))]   # Ab[j - dj, j]
    at = np.arange(nb)
    for i in range(1, na):
        for di in range(1, min(MAX_SKIP + 1, i) + 1):
            for dj in range(1, len(diag)):
                step = np.minimum(np.abs(Aa[i - di, i] - diag[dj]), CAP_DEG)
                c = cost[i - di, :nb - dj] + step + SKIP_DEG * (di + dj - 2)
                better = c < cost[i, dj:]                 # slices: views of row i
                cost[i, dj:][better] = c[better]
                back[i, dj:, 0][better] = i - di
                back[i, dj:, 1][better] = at[:nb - dj][better]
    end = cost + SKIP_DEG * ((na - 1 - ii) + (nb - 1 - jj))  # rows skipped after the last
    i, j = np.unravel_index(int(np.argmin(end)), end.shape)
    pairs = [(int(i), int(j))]
    while back[i, j, 0] >= 0:
        i, j = back[i, j]
        pairs.append((int(i), int(j)))
    ia, ib = np.asarray(pairs[::-1], dtype=np.int64).T
    return ia, ib


def moved_marks(stream, old_t: np.ndarray, new_t: np.ndarray) -> tuple:
    """``stream``'s world-jump marks (``world_jumps_s``: the stamp of the first pose of
    each later stretch, :mod:`simcalib.estimation.world_jumps`) on its rows' new stamps:
    each moves to the new stamp of the first kept row (old stamps ``old_t``) at or after
    it; a mark after the last kept row is dropped."""
    k = np.searchsorted(old_t, np.asarray(getattr(stream, "world_jumps_s", ()), float))
    return tuple(sorted({float(new_t[i]) for i in k if i < new_t.size}))


def _misfit_deg(T_a: np.ndarray, T_b: np.ndarray) -> float:
    """Median |angle of a's motion - angle of b's| over every two paired poses (deg)."""
    n = T_a.shape[0]
    return float(np.median(np.abs(_angles(T_a) - _angles(T_b))[np.triu_indices(n, 1)]))


def _near_angles_deg(T: np.ndarray) -> np.ndarray:
    """``(n, 2 * NEAR)`` rotation angles (deg) from each pose to the poses ``1..NEAR`` rows
    before and after it (NaN past the ends)."""
    n, R = T.shape[0], T[:, :3, :3]
    out = np.full((n, 2 * NEAR), np.nan)
    for d in range(1, min(NEAR, n - 1) + 1):
        ang = np.degrees(rotation_angle_rad(np.swapaxes(R[:-d], 1, 2) @ R[d:]))
        out[:-d, NEAR + d - 1], out[d:, NEAR - d] = ang, ang
    return out


def _shifted_rows_fit(T_a: np.ndarray, T_b: np.ndarray) -> bool:
    """Whether rows of ``T_a`` break the equal-angle rule with their neighbours (:data:`NEAR`
    rows either side, median) paired by number by :data:`MIN_DEG` or more, and either two
    rows in a row :data:`GAIN` times more than paired with the rows of b one before or
    after, or one row :data:`GAIN` times more than the median row and :data:`NEAR_GAIN`
    times more than paired a row off (a row lost in each file at different places: the
    rows between are paired one off; in a raster of stations only the rows at its turns
    show it). O(n): files whose rows all pair by number are searched for such stretches
    only where this holds."""
    Na, Nb = _near_angles_deg(T_a), _near_angles_deg(T_b)
    n = Na.shape[0]
    with np.errstate(all="ignore"):
        by_number = np.nanmedian(np.abs(Na - Nb), axis=1)
        off = [np.nanmedian(np.abs(Na[max(s, 0):n + min(s, 0)] - Nb[max(-s, 0):n + min(-s, 0)]),
                            axis=1) for s in (1, -1)]                # a's row i, b's i -+ 1
        best = np.full(n, np.inf)
        best[1:] = np.fmin(best[1:], off[0])
        best[:-1] = np.fmin(best[:-1], off[1])
        typical = np.nanmedian(by_number)
    breaks = (by_number >= MIN_DEG) & (by_number >= GAIN * best)
    odd = (by_number >= MIN_DEG) & (by_number >= GAIN * typical) & (by_number >= NEAR_GAIN * best)
    return bool(np.any(breaks[1:] & breaks[:-1]) or np.any(odd))


def _stretch_misfits_deg(T_a, T_b, ia, ib) -> tuple[float, float]:
    """``(by number, by the pairs)``: over the rows of a that the pairs ``(ia, ib)`` give
    another partner and that break the equal-angle rule by :data:`MIN_DEG` or more paired by
    number, the median of each row's median |angle of a's motion - angle of b's| (deg) to
    every other pair of the same pairing (0, inf: no such row; rows whose motions do not
    turn cannot tell their partner and are left out)."""
    Ra, Rb = T_a[:, :3, :3], T_b[:, :3, :3]

    def row_misfits(ka, kb, pa, pb):
        ang_a = rotation_angle_rad(np.swapaxes(Ra[ka], 1, 2)[:, None] @ Ra[pa][None])
        ang_b = rotation_angle_rad(np.swapaxes(Rb[kb], 1, 2)[:, None] @ Rb[pb][None])
        m = np.where(ka[:, None] != pa[None], np.abs(ang_a - ang_b), np.nan)
        return np.degrees(np.nanmedian(m, axis=1))

    moved = ia != ib
    n = np.arange(T_a.shape[0])
    before = row_misfits(ia[moved], ia[moved], n, n)
    breaks = before >= MIN_DEG
    if not breaks.any():
        return 0.0, math.inf
    after = row_misfits(ia[moved][breaks], ib[moved][breaks], ia, ib)
    return float(np.median(before[breaks])), float(np.median(after))


def _paired_misfit_deg(A_a: np.ndarray, A_b: np.ndarray, ia: np.ndarray, ib: np.ndarray
                       ) -> float:
    """:func:`_misfit_deg` of the rows ``ia`` of a paired with ``ib`` of b, from the angles
    of every two rows of each file (:func:`_angles`, ``A_a``, ``A_b``): the same number,
    without the angles of every two pairs computed again for each pairing."""
    r, c = np.triu_indices(ia.size, 1)
    return float(np.median(np.abs(A_a[ia[r], ia[c]] - A_b[ib[r], ib[c]])))


def realign_rows(sa, sb, sampling):
    """``(stream_a, stream_b, sampling, notes)``: streams paired by sample-number stamps
    whose pairing by number breaks the equal-angle rule, re-stamped so that pairing by
    stamp pairs them by that rule (b's rows take their partners' stamps; rows without one
    dropped and counted; the sampling classified again); streams on two clocks by
    :func:`pair_by_lag`; other streams as they are (``notes`` empty)."""
    from simcalib.estimation.hidden_offset import continuous
    from simcalib.estimation.sampling import pair_by_stamp
    ta, tb = np.asarray(sa.timestamps_s), np.asarray(sb.timestamps_s)
    if not sampling.paired_by_stamp:
        return pair_by_lag(sa, sb, sampling)
    if not (sampling.paired_by_stamp and _numbered(ta) and _numbered(tb)
            and 6 <= min(ta.size, tb.size) and max(ta.size, tb.size) <= MAX_ROWS):
        return sa, sb, sampling, []
    Ta, Tb = np.asarray(sa.T_world_sensor), np.asarray(sb.T_world_sensor)
    crossed = sampling.shared == ta.size == tb.size     # every row paired by number
    if crossed and ta.size > FEW_ROWS and not _shifted_rows_fit(Ta, Tb):
        return sa, sb, sampling, []     # no row fits a neighbour's partner better
    ia, ib = align_rows(Ta, Tb)
    if np.all(ia - ib == ia[0] - ib[0]) and continuous(ta, Ta) and continuous(tb, Tb):
        return sa, sb, sampling, []     # counters of one motion a lag apart: hidden_offset's
    if crossed:
        before, after = _stretch_misfits_deg(Ta, Tb, ia, ib)
    else:
        by_number = pair_by_stamp(sa, sb, sampling, sampling.shift_s)
        if by_number.n < 3 or ia.size < 3:
            return sa, sb, sampling, []
        before, after = _misfit_deg(by_number.T_a, by_number.T_b), _misfit_deg(Ta[ia], Tb[ib])
    if not (before >= GAIN * after and before >= MIN_DEG):
        return sa, sb, sampling, []
    return _repaired(sa, sb, sampling, (ia, ib), (before, after), crossed)


def _numbered(t: np.ndarray) -> bool:
    """Rows a file may number wrong: stamps that are sample numbers, or stations seconds
    apart (every step :data:`MIN_PERIOD_S` or more: a script that writes the camera's
    rows with the robot's stamps, one list zipped with the other, shifts them alike)."""
    from simcalib.estimation.sampling import is_sample_numbers
    return is_sample_numbers(t) or (t.size >= 2 and float(np.min(np.diff(t))) >= MIN_PERIOD_S)


def _repaired(sa, sb, sampling, pairs, misfits, crossed: bool):
    """:func:`realign_rows`'s streams re-stamped by the pairs ``(ia, ib)`` found, its note
    (``misfits``: the rule's misfit by number and by the pairs, deg)."""
    from simcalib.estimation.sampling import classify_sampling
    ta, tb = np.asarray(sa.timestamps_s), np.asarray(sb.timestamps_s)
    Ta, Tb = np.asarray(sa.T_world_sensor), np.asarray(sb.T_world_sensor)
    (ia, ib), (before, after) = pairs, misfits
    lost_a, lost_b = np.setdiff1d(np.arange(ta.size), ia), np.setdiff1d(np.arange(tb.size), ib)
    out_a = replace(sa, timestamps_s=ta[ia], T_world_sensor=Ta[ia], repairs=dict(
        sa.repairs, rows_without_a_partner=int(lost_a.size)))
    out_b = replace(sb, timestamps_s=ta[ia] + sampling.shift_s, T_world_sensor=Tb[ib],
                    repairs=dict(sb.repairs, rows_without_a_partner=int(lost_b.size),
                                 rows_paired_by_motion=int(ib.size)),
                    world_jumps_s=moved_marks(sb, tb[ib], ta[ia] + sampling.shift_s))
    rows = lambda lost, t: ", ".join(f"{x:g}" for x in t[lost][:8]) or "none"  # noqa: E731
    how = ("pair by number, but rows numbered "
           + ", ".join(f"{x:g}" for x in ta[np.setdiff1d(np.arange(ta.size), ia[ia == ib])][:8])
           + " of a break the rule both sensors turn alike: the rotation angles of their "
           "motions to the other rows" if crossed else
           "do not pair by number: the rotation angles of the motions between them break the "
           "rule both sensors turn alike")
    note = (f"the rows stamped {ta[0]:g}..{ta[-1]:g} in a ({ta.size}) and {tb[0]:g}..{tb[-1]:g} "
            f"in b ({tb.size}) {how} by {before:.2g} deg "
            f"(median), {after:.2g} deg paired by that rule; rows of a without a partner: "
            f"{rows(lost_a, ta)}; of b: {rows(lost_b, tb)} (a failed detection, with the later "
            "rows renumbered? where poses in a row do not turn, the angles cannot tell which "
            "of them lost its partner); the rows are paired by the rule")
    return out_a, out_b, classify_sampling(out_a, out_b), [note]


def _pitch_matrix(T: np.ndarray) -> np.ndarray:
    """``(n, n)`` |translation along the rotation axis| of the motion from each pose to each
    other (the screw's pitch times its angle; NaN where a pose does not turn)."""
    x, y, z, w = quat_from_matrix(T[:, :3, :3]).T
    axis = [M - M.T for M in (np.outer(w, x) + np.outer(z, y), np.outer(w, y) + np.outer(x, z),
                              np.outer(w, z) + np.outer(y, x))]      # conj(q_i) q_j, frame i
    R, t = T[:, :3, :3], T[:, :3, 3]
    move = [R[:, :, k] @ t.T - np.sum(R[:, :, k] * t, axis=1)[:, None] for k in range(3)]
    with np.errstate(all="ignore"):
        return np.abs(sum(u * m for u, m in zip(axis, move))) / np.sqrt(
            sum(u * u for u in axis))


def _pitch_lag(T_a, T_b, angles, fits, n: int):
    """``((shift, ia, ib), why)`` of the lag told by the screws' pitches where the angles do
    not tell it (``fits``: pair_by_lag's, best first), or None. The other invariant of
    AX = XB: both sensors move alike along the turn's axis. Over the pairs that turn
    :data:`PITCH_MIN_DEG` or more in both files, b's scale fitted per lag (least squares:
    the files' units need not agree), the :data:`PITCH_QUANTILE` quantile of the pitches'
    misfit over b's median pitch; the lag whose misfit is :data:`LAG_GAIN` times less than
    every other's, pairing :data:`PAIRED_SHARE` of the rows, and not ruled out by the angles
    (within :data:`LAG_GAIN` of the best) is the one (a raster of stations repeats its
    turns: a lag of a row or a column of it keeps most angles, not the heights)."""
    D_a, D_b = _pitch_matrix(T_a), _pitch_matrix(T_b)
    out = []
    for misfit, _, shift, ia, ib in fits:
        r, c = np.triu_indices(ia.size, 1)
        turn = (angles[0][ia[r], ia[c]] >= PITCH_MIN_DEG) & (angles[1][ib[r], ib[c]]
                                                            >= PITCH_MIN_DEG)
        da, db = D_a[ia[r], ia[c]][turn], D_b[ib[r], ib[c]][turn]
        if da.size < 10 or not np.dot(da, da) > 0 or not np.median(db) > 0:
            continue
        scale = np.dot(da, db) / np.dot(da, da)
        out.append((float(np.quantile(np.abs(scale * da - db), PITCH_QUANTILE)
                          / np.median(db)), misfit, shift, ia, ib))
    out.sort(key=lambda f: f[0])
    if len(out) < 2 or not out[1][0] >= LAG_GAIN * out[0][0]:
        return None
    pitch, misfit, shift, ia, ib = out[0]
    if ia.size < PAIRED_SHARE * n or misfit >= LAG_GAIN * fits[0][0]:
        return None
    return (shift, ia, ib), (
        f"the shift whose pairs move alike along their turns' axes best (the screws' pitch, "
        f"b's scale fitted: misfit {pitch:.2g} of b's median, the next {out[1][0]:.2g}; the "
        f"rotation angles could not tell it: {misfit:.2g} deg, median, the least "
        f"{fits[0][0]:.2g} deg)")


def pair_by_lag(sa, sb, sampling):
    """:func:`realign_rows` for station streams on two clocks (module doc): b's rows take
    their partners' stamps plus the shift, and the sampling is stamps shared after that
    shift (decided by the motions: stations a regular second apart pair at any shift of a
    second by their stamps alone)."""
    from simcalib.estimation.sampling import Sampling, lag_shifts, median_period
    ta, tb = np.asarray(sa.timestamps_s), np.asarray(sb.timestamps_s)
    Ta, Tb = np.asarray(sa.T_world_sensor), np.asarray(sb.T_world_sensor)
    n = min(ta.size, tb.size)
    if (n < 3 or max(ta.size, tb.size) > MAX_ROWS
            or min(sampling.period_a_s, sampling.period_b_s) < MIN_PERIOD_S):
        return sa, sb, sampling, []
    tol = 0.25 * min(float(np.quantile(np.diff(ta), 0.1)), float(np.quantile(np.diff(tb), 0.1)))
    lags = [x for x in lag_shifts(ta, tb, tol) if x[1].size >= 0.5 * n]
    Aa, Ab = (_angles(Ta), _angles(Tb)) if lags else (None, None)
    fits = sorted((_paired_misfit_deg(Aa, Ab, ia, ib), k, shift, ia, ib)
                  for k, (shift, ia, ib) in enumerate(lags))
    if not fits or fits[0][3].size < PAIRED_SHARE * n:
        return sa, sb, sampling, []
    best, _, shift, ia, ib = fits[0]
    runner = fits[1][0] if len(fits) > 1 else math.inf
    why = (f"the shift whose pairs break the rule both sensors turn alike least ({best:.2g} "
           f"deg, median; the next {runner:.2g} deg)")
    if not (runner > 0 and runner >= LAG_GAIN * best):       # none turns: every lag fits
        pick = _pitch_lag(Ta, Tb, (Aa, Ab), fits, n)
        if pick is None:
            return sa, sb, sampling, []
        (shift, ia, ib), why = pick
    out_a = replace(sa, timestamps_s=ta[ia], T_world_sensor=Ta[ia], repairs=dict(
        sa.repairs, rows_without_a_partner=int(ta.size - ia.size)))
    out_b = replace(sb, timestamps_s=ta[ia] + shift, T_world_sensor=Tb[ib], repairs=dict(
        sb.repairs, rows_without_a_partner=int(tb.size - ib.size),
        rows_paired_by_motion=int(ib.size)),
        world_jumps_s=moved_marks(sb, tb[ib], ta[ia] + shift))
    spread = float(np.max(np.abs(tb[ib] - ta[ia] - shift)))
    note = (f"the stations of a ({ta.size}) and b ({tb.size}) carry two clocks: paired one to "
            f"one with b {shift:.6g} s later (the offset used; stamps within {spread:.3g} s "
            f"of it), {why}")
    period = median_period(ta[ia])
    paired = Sampling("shared_stamps", True, 1e-3 * period + 1e-9, int(ia.size), int(ia.size),
                      int(ib.size), period, period, reason=note + ": poses paired by station",
                      shift_s=shift, resolution_s=sampling.resolution_s)
    return out_a, out_b, paired, [note]
