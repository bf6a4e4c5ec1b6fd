"""Shared stamps that hide a clock offset.

Two streams with the same stamps are paired by stamp (:mod:`simcalib.estimation.sampling`),
and stamps alone cannot show a clock offset. Yet equal stamps do not prove equal clocks:

* a dense stream on a regular grid (a 200 Hz tracker) shares the stamps of a slower one
  on the same grid (a 10 Hz camera) whatever their offset, if it is a whole number of the
  dense stream's periods;
* a pose stream written at another stream's stamps (ground truth interpolated at the
  camera's frame times, a tracker stamped with the image it processed) carries the latency
  of whichever clock produced its poses.

Where both streams sample one continuous motion (:func:`continuous`: regular stamps, poses
that move a little from each to the next, not station data), the offset is therefore
estimated as for two clocks (:func:`simcalib.estimation.alignment.estimate_time_offset`:
used only when it beats offset 0 on the calibration cost by the evidence rule). When it
does, the streams are no longer paired by stamp: the faster one is interpolated at the
slower one's shifted stamps, and the run says why. Otherwise nothing changes (0, paired by
stamp), so stamps that agree with the motion cost only the check.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from simcalib.geometry import rotation_angle_rad

__all__ = ["continuous", "stamps_hide_offset", "REGULAR_SHARE", "SMOOTH_STEPS",
           "SMOOTH_GAIN"]

#: a stream is regularly sampled when this share of its stamp steps is within 25 % of the
#: median step (station data: seconds between stops, bursts of frames at each)
REGULAR_SHARE = 0.8
#: ... and samples one continuous motion when its poses SMOOTH_STEPS samples apart are at
#: least SMOOTH_GAIN times further apart (median) than consecutive ones (stations: ~1)
SMOOTH_STEPS = 4
SMOOTH_GAIN = 2.0


def continuous(t: np.ndarray, T: np.ndarray, signal: str = "rotation") -> bool:
    """Does the stream (stamps ``t`` (n,), poses ``T`` (n, 4, 4)) sample one continuous
    motion? Regular stamps (:data:`REGULAR_SHARE`) and a smooth path: its rotation angle
    (``signal`` ``rotation``) or distance (``translation``) over :data:`SMOOTH_STEPS`
    samples at least :data:`SMOOTH_GAIN` times that over one."""
    t = np.asarray(t, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    k = SMOOTH_STEPS
    if t.size < 4 * k:
        return False
    dt = np.diff(t)
    med = float(np.median(dt))
    if not med > 0 or np.mean(np.abs(dt - med) <= 0.25 * med) < REGULAR_SHARE:
        return False
    return bool(np.median(_apart(T, k, signal)) >= SMOOTH_GAIN * np.median(
        _apart(T, 1, signal)))


def _apart(T: np.ndarray, k: int, signal: str) -> np.ndarray:
    """The rotation angle (or distance) between poses ``k`` samples apart."""
    if signal == "translation":
        return np.linalg.norm(T[k:, :3, 3] - T[:-k, :3, 3], axis=1)
    return rotation_angle_rad(np.swapaxes(T[:-k, :3, :3], 1, 2) @ T[k:, :3, :3])


def stamps_hide_offset(sa, sb, sampling, off, *, alpha: float = 1.0, drift: bool = False,
                       signal: str = "rotation"):
    """``(Sampling, TimeOffset)`` to use for streams paired by stamp (``sampling``, ``off``:
    the shared stamps' offset): unpaired, with the estimated offset, when both sample a
    continuous motion and their motions line up at an offset that beats 0 (module doc);
    paired as before, with the check's outcome in their messages, when it does not; as given
    for station data, sample numbers and stamps shared after a shift (whose shift is the
    offset). ``sa``, ``sb``: the streams in their decided reading."""
    from simcalib.estimation.alignment import as_time_poses, estimate_time_offset
    from simcalib.estimation.offset_cost import EVIDENCE_MIN
    if sampling.kind != "shared_stamps" or sampling.shift_s != 0.0:
        return sampling, off
    ta, Ta = as_time_poses(sa, "stream_a")
    tb, Tb = as_time_poses(sb, "stream_b")
    if not (continuous(ta, Ta, signal) and continuous(tb, Tb, signal)):
        return sampling, off
    est = estimate_time_offset(sa, sb, drift=drift, alpha=alpha, signal=signal)
    shared = (f"{sampling.shared} of {min(sampling.n_a, sampling.n_b)} stamps are shared by "
              "both streams")
    if est.decision != "estimated":
        note = (f"{shared}: poses paired by stamp; both streams sample a continuous motion, "
                "and no offset of their motions beats 0 (" + (
                    f"evidence {est.evidence:.3g} <= {EVIDENCE_MIN:g}" if est.evidence is not None
                    else "the data do not tell one") + "), so 0 is used")
        return replace(sampling, reason=note), replace(off, message=note)
    reason = (f"{shared}, but their motions line up at t_b - t_a = {est.offset_s * 1e3:.2f} "
              f"+- {est.uncertainty_s * 1e3:.2f} ms (evidence {est.evidence:.3g} over "
              "offset 0): one stream's stamps carry a latency, so the faster stream is "
              "interpolated at the slower one's shifted stamps")
    return replace(sampling, kind="continuous", paired_by_stamp=False, reason=reason), est
