"""A linear clock drift, told by the offsets of contiguous parts of the recording.

Two free-running clocks drift apart by their rates' difference: 20-100 ppm for crystal
oscillators, so 6-30 ms over a 5-minute recording, far beyond what the motions resolve
(~0.1 ms on a moving rig). Fitted as one constant offset, a drift shows in the split
check (:func:`simcalib.estimation.offset_cost.split_check`): the offsets of the parts of
the overlap climb steadily, and their spread raised the offset's sigma while the motions
at the recording's ends stayed misaligned (a generated 100 Hz / 30 Hz recording of 300 s
at 100 ppm: the parts at -145, -138, -130, -124 ms, sigma raised from 0.07 to 4.8 ms, X's
sigma 10x what the poses' noise gives).

:func:`drift_line` fits a line through the parts' offsets (weighted by their sigmas)
and :meth:`DriftLine.tells` decides, for ``drift="auto"``, whether the data tell a drift:
the parts disperse about one offset beyond chance (the split check raised), the line
leaves at most 1 / :data:`DRIFT_GAIN` of that dispersion, and the drift stands
:data:`DRIFT_Z` of its sigmas from 0 (its sigma scaled by the dispersion about the line
where that is beyond chance: ``F = (q_const - q_line) / (q_line / (n - 2)) >= 100``, which
four points of a wander that is not linear in time pass by chance ~1 % of the time) - with
at least :data:`DRIFT_MIN_PARTS` parts. Errors that wander but are not linear in time (a
tracker's drift, a target's systematic error) keep the raised sigma of one offset. Where
a drift is fitted, the offset's sigma is the line's at the reference time, scaled by the
dispersion about the line where that is beyond chance (the parts' offsets are the
averages of their motions, whose weight is not spread evenly over a part's time: at
100 ppm that leaves them ~0.5 ms off a line). :func:`drift_from_halves` is the
estimate for ``drift=True`` on an overlap too short for :data:`DRIFT_MIN_PARTS` parts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DriftLine", "drift_line", "fitted_line", "drift_applied", "drift_from_halves",
           "check_drift", "DRIFT_GAIN", "DRIFT_Z", "DRIFT_MIN_PARTS", "DRIFT_MODES"]

#: the line through the parts leaves at most this fraction's inverse of their dispersion
#: about one offset
DRIFT_GAIN = 10.0
#: the drift stands this many of its (scaled) sigmas from 0
DRIFT_Z = 10.0
#: parts needed to tell a drift (a line through them leaves two dof to test it)
DRIFT_MIN_PARTS = 4
#: the values of ``drift``: fitted where the data tell it, always, never
DRIFT_MODES = ("auto", True, False)


def check_drift(drift) -> bool | str:
    """``drift`` as given, or ValueError naming what was received and what is allowed."""
    if isinstance(drift, (bool, np.bool_)):
        return bool(drift)
    if drift == "auto":
        return "auto"
    raise ValueError(f"drift must be 'auto', true or false; received {drift!r}")


@dataclass(frozen=True)
class DriftLine:
    """The weighted line ``offset(t) = offset_s + drift (t - t_ref)`` through the split
    check's parts: ``drift`` (s/s) and ``drift_sigma``, ``offset_s`` at the reference
    time and ``sigma_s`` (both sigmas scaled by the dispersion about the line where that
    is beyond 1), ``q_line`` / ``q_const`` the parts' chi-square about the line / about
    one offset, ``n`` parts, ``raised`` the
    split check's verdict on one offset."""
    drift: float
    drift_sigma: float
    offset_s: float
    sigma_s: float
    q_line: float
    q_const: float
    n: int
    raised: bool

    @property
    def tells(self) -> bool:
        """The data tell a drift (``drift="auto"``; see the module's docstring)."""
        return (self.n >= DRIFT_MIN_PARTS and self.raised
                and self.q_const >= DRIFT_GAIN * self.q_line
                and abs(self.drift) >= DRIFT_Z * self.drift_sigma)

    def note(self) -> str:
        """What the parts say about a drift, for the offset's message."""
        return (f"; the parts lie on a line: drift {self.drift * 1e6:.1f} +- "
                f"{self.drift_sigma * 1e6:.1f} ppm (dispersion about it "
                f"{self.q_line / max(self.n - 2, 1):.3g}x chance, about one offset "
                f"{self.q_const / max(self.n - 1, 1):.3g}x)")


def drift_line(split, t_ref: float) -> DriftLine | None:
    """The line through ``split``'s parts (:class:`~simcalib.estimation.offset_cost.
    SplitCheck`, with their times in the clock of ``t_ref``), or None below 3 parts."""
    n = len(split.offsets_s)
    if n < 3 or len(split.times_s) != n:
        return None
    t = np.asarray(split.times_s, dtype=np.float64) - t_ref
    o = np.asarray(split.offsets_s, dtype=np.float64)
    w = 1.0 / np.asarray(split.sigmas_s, dtype=np.float64) ** 2
    A = np.array([[w.sum(), (w * t).sum()], [(w * t).sum(), (w * t * t).sum()]])
    cov = np.linalg.inv(A)
    c, d = cov @ np.array([(w * o).sum(), (w * t * o).sum()])
    q_line = float(np.sum(w * (o - c - d * t) ** 2))
    q_const = float(np.sum(w * (o - np.sum(w * o) / w.sum()) ** 2))
    scale = max(1.0, q_line / (n - 2))
    return DriftLine(float(d), math.sqrt(cov[1, 1] * scale), float(c),
                     math.sqrt(cov[0, 0] * scale), q_line, q_const, n, bool(split.raised))


def drift_from_halves(ta, Ta, tb, Tb, best, half, kw) -> tuple[float, float, str]:
    """``(drift, offset at the halves' mid-time, note)``: the offset refined on each half
    of the overlap (:class:`~simcalib.estimation.offset_cost.OffsetCost` ``part`` 0 / 1)
    and the line through the two."""
    from simcalib.estimation.offset_cost import OffsetCost, _refine
    halves = []
    for part in (0, 1):
        cost = OffsetCost(ta, Ta, tb, Tb, (best - half, best + half), part=part, **kw)
        halves.append((_refine(cost, best, half)[0], cost.window))
    (o1, w1), (o2, w2) = halves
    span = 0.5 * (w2[0] + w2[1]) - 0.5 * (w1[0] + w1[1])
    d = (o2 - o1) / span if span > 0 else 0.0
    return d, 0.5 * (o1 + o2), f"; drift {d * 1e6:.1f} ppm from two windows"


def fitted_line(split, t_ref: float, drift) -> DriftLine | None:
    """The parts' line where a drift is to be fitted: always for ``drift=True`` (None on
    an overlap too short for 3 parts), for ``"auto"`` where it tells a drift."""
    line = drift_line(split, t_ref) if drift else None
    return line if line is not None and (drift is True or line.tells) else None


def drift_applied(streams, line, t_ref, sigma, half, kw, window) -> tuple:
    """``(offset, sigma, drift, drift_sigma, note)`` with the parts' ``line``: the offset
    refined again on b's stamps mapped onto a's clock by its drift (the parts' offsets
    are their motions' averages, not the line's value at their middles). Its sigma, for
    the recording as a whole (X's covariance carries one): that refinement's (raised to
    its split check's where beyond chance) and the drift's sigma over the overlap (the rms
    of ``drift_sigma (t - t_ref)``, ``span / sqrt(12)``); the line's offset and ``sigma``
    where the refinement fails or has no curvature."""
    from simcalib.estimation import offset_cost as oc
    ta, Ta, tb, Tb = streams
    # b's stamps on a's clock by the line (TimeOffset.a_from_b), plus its offset: only
    # the offset is left to refine
    tb_a = (np.asarray(tb, np.float64) - line.offset_s + line.drift * t_ref) / (
        1.0 + line.drift) + line.offset_s
    again = oc._refine_candidates(ta, Ta, tb_a, Tb, [line.offset_s], half / 2, kw,
                                  window=window)
    if not again or again[0].unbounded:
        return line.offset_s, sigma, line.drift, line.drift_sigma, ""
    best, own = oc._offset_and_sigma(again[0])
    if not math.isfinite(own):                      # no curvature: the line's values
        return line.offset_s, sigma, line.drift, line.drift_sigma, ""
    split = oc.split_check(ta, Ta, tb_a, Tb, best, half, kw, again[0].cost.window)
    own = max(own, split.sigma_s if split.raised else own)
    span = again[0].cost.window[1] - again[0].cost.window[0]
    sigma = math.hypot(own, line.drift_sigma * span / math.sqrt(12.0))
    return best, sigma, line.drift, line.drift_sigma, (
        f"; refined again with b's stamps corrected for the drift: {best * 1e3:.2f} +- "
        f"{own * 1e3:.2f} ms (its parts disperse {split.ratio:.3g}x"
        + (", beyond chance" if split.raised else "") + "), with the drift's sigma over "
        f"the {span:.0f} s: +- {sigma * 1e3:.2f} ms")
