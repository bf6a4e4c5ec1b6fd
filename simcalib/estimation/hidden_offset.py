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
slower one's shifted stamps, and the run says why. Otherwise the streams stay paired by
stamp at offset 0, but the offset keeps the 1-sigma the check found (:func:`kept_at_zero`:
the estimate's sigma and its distance from 0), which X's covariance carries: the stamps
do not prove 0, and the motions bound it only that well. Sample numbers of two
streams that sample one continuous motion (frame counters, a file without a time column)
are checked alike for a lag between the counters, in samples (:func:`_counter_lag`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from simcalib.estimation.speeds import above_noise, apart

__all__ = ["continuous", "stamps_hide_offset", "kept_at_zero", "motion_stride",
           "REGULAR_SHARE", "SMOOTH_STEPS", "SMOOTH_GAIN", "STRIDE_TURN_DEG", "STRIDE_NOISE_GAIN",
           "STRIDES_MIN"]

#: a stream is regularly sampled when this share of its stamp steps is within 25 % of the
#: median step (station data: seconds between stops, bursts of frames at each)
REGULAR_SHARE = 0.8
#: ... and samples one continuous motion when its poses SMOOTH_STEPS samples apart are at
#: least SMOOTH_GAIN times further apart (median) than consecutive ones (stations: ~1)
SMOOTH_STEPS = 4
SMOOTH_GAIN = 2.0


#: sample-number stamps of a continuous motion: the motions' base stride is the smallest
#: power of 2 samples over which the median motion turns by this much (deg) ...
STRIDE_TURN_DEG = 5.0
#: ... and by this many times its turn (or distance, a rig that does not turn) between
#: consecutive samples (beyond the pose noise) ...
STRIDE_NOISE_GAIN = 4.0
#: ... within a stream of at least this many strides: the offset cost's split check needs
#: 4 parts of 4 strides (16) in the overlap, which a lag of up to half the stream halves
STRIDES_MIN = 32


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
    return bool(np.median(apart(T, k, signal)) >= SMOOTH_GAIN * np.median(
        apart(T, 1, signal)))


def stamps_hide_offset(sa, sb, sampling, off, *, alpha: float = 1.0, drift="auto",
                       signal: str = "rotation", step_search: bool = True):
    """``(Sampling, TimeOffset)`` to use for streams paired by stamp (``sampling``, ``off``:
    the shared stamps' offset): unpaired, with the estimated offset, when both sample a
    continuous motion and their motions line up at an offset that beats 0 (module doc);
    paired as before, at offset 0 with the check's 1-sigma (:func:`kept_at_zero`) and its
    outcome in their messages, when it does not; with a clock step in its ``steps`` where
    the motions show one (:func:`simcalib.estimation.clock_step.find_step`: the caller
    shifts b's stamps and pairs the streams again; ``step_search=False``: not looked
    for); as given
    for station data and stamps shared after a shift (whose shift is the offset). Sample
    numbers of a continuous motion: :func:`_counter_lag`. ``sa``, ``sb``: the streams in
    their decided reading."""
    from simcalib.estimation.alignment import estimate_time_offset
    from simcalib.estimation.clock_step import find_step
    from simcalib.estimation.speeds import as_time_poses
    from simcalib.estimation.offset_cost import EVIDENCE_MIN
    if sampling.kind == "index_stamps":
        return _counter_lag(sa, sb, sampling, off, alpha=alpha, drift=drift, signal=signal)
    if sampling.kind != "shared_stamps" or sampling.shift_s != 0.0:
        return sampling, off
    ta, Ta = as_time_poses(sa, "stream_a")
    tb, Tb = as_time_poses(sb, "stream_b")
    if not (continuous(ta, Ta, signal) and continuous(tb, Tb, signal)):
        return sampling, off
    by = "auto" if signal == "rotation" else signal     # as align_and_read: both speeds
    est = estimate_time_offset(sa, sb, drift=drift, alpha=alpha, signal=by)
    step = (find_step(sa, sb, replace(est, steps=off.steps), alpha=alpha, signal=by)
            if step_search else None)
    if step is not None:        # b's clock steps: the caller shifts b's stamps, pairs again
        return sampling, replace(est, steps=(*off.steps, step))
    shared = (f"{sampling.shared} of {min(sampling.n_a, sampling.n_b)} stamps are shared by "
              "both streams")
    if est.decision != "estimated":
        note = (f"{shared}: poses paired by stamp; both streams sample a continuous motion, "
                "and no offset of their motions beats 0 (" + (
                    f"evidence {est.evidence:.3g} <= {EVIDENCE_MIN:g}"
                    if math.isfinite(est.evidence) else "the data do not tell one")
                + "), so 0 is used" + _bound_words(est, 1e3, "ms"))
        return replace(sampling, reason=note), kept_at_zero(off, est, note)
    reason = (f"{shared}, but their motions line up at t_b - t_a = {est.offset_s * 1e3:.2f} "
              f"+- {est.uncertainty_s * 1e3:.2f} ms (evidence {est.evidence:.3g} over "
              "offset 0): one stream's stamps carry a latency, so the faster stream is "
              "interpolated at the slower one's shifted stamps")
    return replace(sampling, kind="continuous", paired_by_stamp=False, reason=reason), est


def kept_at_zero(off, est, note: str):
    """The shared stamps' offset ``off`` (0: the streams stay paired by stamp) carrying
    what the check ``est`` (a :class:`~simcalib.estimation.alignment.TimeOffset` not told
    from 0) found: its 1-sigma, ``evidence`` and best offset, and ``note`` as its message.

    Which 1-sigma: the check's ``uncertainty_s``, which for an offset not told from 0 is
    the root sum of squares of the estimate's sigma and its distance from 0
    (:func:`~simcalib.estimation.alignment.estimate_time_offset`, decision ``zero``), not
    the estimate's sigma alone. Offset 0 is used where the motions put the offset at ``e
    +- s``: the error of using 0 is the true offset, whose spread about 0 given the data
    is ``sqrt(e^2 + s^2)``. The sigma alone would describe the error of using ``e``, not
    0 (KITTI: 1.8 ms against 4.2 ms from 0), ``|e|`` alone would ignore that ``e`` is
    itself uncertain; and as the evidence rule leaves ``|e|`` within ~3 ``s``, the bound
    is at most ~3.2 ``s``. It is the rule of every offset not told from 0, so a recording
    gets the same sigma whether its streams share their stamps or not. NaN where the
    check could not bound an offset (its cost could not be built or kept falling): the
    sigma is unknown, and nothing is added to X's covariance."""
    return replace(off, uncertainty_s=float(est.uncertainty_s), evidence=est.evidence,
                   best_s=est.best_s, message=note)


def _bound_words(est, scale: float, unit: str) -> str:
    """The check's bound on the offset kept at 0, in words (``scale``: to ``unit``)."""
    if not math.isfinite(est.uncertainty_s):
        return "; the motions do not bound an offset: its sigma is unknown"
    best = (f"the motions put it at {est.best_s * scale:.3g} {unit}, "
            if math.isfinite(est.best_s) else "")
    return (f"; {best}1-sigma {est.uncertainty_s * scale:.3g} {unit} (the check's sigma "
            "and its estimate's distance from 0), carried into X's sigma")


def motion_stride(T: np.ndarray, signal: str = "rotation") -> tuple[int, bool]:
    """``(stride, reached)``: the smallest power of 2 samples over which the median motion
    of poses ``T`` turns by :data:`STRIDE_TURN_DEG` (``signal`` ``rotation``) and by
    :data:`STRIDE_NOISE_GAIN` times its motion over one sample; at most the largest power
    of 2 that fits :data:`STRIDES_MIN` times into the stream (``reached`` False: capped
    there)."""
    T = np.asarray(T, dtype=np.float64)
    cap = max(1, 2 ** int(np.floor(np.log2(max(T.shape[0] // STRIDES_MIN, 1)))))
    k = 1
    while k <= cap:
        m = float(np.median(apart(T, k, signal)))
        turns = signal != "rotation" or m >= np.radians(STRIDE_TURN_DEG)
        if turns and above_noise(m, T, signal, STRIDE_NOISE_GAIN):
            return k, True
        k *= 2
    return cap, False


def _in_samples(est, k: int):
    """The :class:`~simcalib.estimation.alignment.TimeOffset` ``est`` of stamps counted in
    units of ``k`` samples, in samples."""
    return replace(est, offset_s=est.offset_s * k, uncertainty_s=est.uncertainty_s * k,
                   best_s=est.best_s * k,
                   coarse_offset_s=est.coarse_offset_s * k, lags_s=est.lags_s * k,
                   cost_offsets_s=est.cost_offsets_s * k, drift=est.drift,
                   t_ref_s=est.t_ref_s * k,
                   window_s=(est.window_s[0] * k, est.window_s[1] * k))


def _counter_lag(sa, sb, sampling, off, *, alpha, drift, signal):
    """``(Sampling, TimeOffset)`` for sample-number stamps: as given unless both streams
    sample one continuous motion (:func:`continuous`). Then the motions' base stride is
    chosen from the motion (:func:`motion_stride`, ``Sampling.motion_step``), and the lag
    between the two counters is estimated as for two clocks on stamps counted in units of
    that stride (the offset cost's 1-unit motions then turn, its 2-unit brackets span
    strides, not single samples), in samples; used, unpairing the streams, only where it
    beats lag 0 by the evidence rule. Streams whose motion does not reach the stride's
    turn within :data:`STRIDES_MIN` strides of their length (noisy stations in a row, too
    few samples to tell a lag) stay as given."""
    from simcalib.estimation.alignment import estimate_time_offset
    from simcalib.estimation.offset_cost import EVIDENCE_MIN
    from simcalib.estimation.speeds import as_time_poses
    ta, Ta = as_time_poses(sa, "stream_a")
    tb, Tb = as_time_poses(sb, "stream_b")
    if not (continuous(ta, Ta, signal) and continuous(tb, Tb, signal)):
        return sampling, off
    (ka, ra), (kb, rb) = motion_stride(Ta, signal), motion_stride(Tb, signal)
    if not (ra and rb):             # noisy stations in a row (a sweep of stops), too short
        return sampling, off
    k = max(ka, kb)
    stride = (f"both streams sample a continuous motion: motions over {k} samples and "
              "multiples (the smallest power of 2 over which the median motion turns by "
              f">= {STRIDE_TURN_DEG:g} deg and {STRIDE_NOISE_GAIN:g}x its turn over one)")
    by = "auto" if signal == "rotation" else signal
    est = estimate_time_offset((ta / k, Ta), (tb / k, Tb), drift=drift, alpha=alpha,
                               signal=by)
    est = _in_samples(est, k)
    sampling = replace(sampling, motion_step=int(k))
    if est.decision != "estimated":
        note = (f"{sampling.reason}; {stride}; no lag between the two counters beats 0 ("
                + (f"evidence {est.evidence:.3g} <= {EVIDENCE_MIN:g}"
                   if math.isfinite(est.evidence) else "the data do not tell one")
                + f"; best {est.coarse_offset_s:.4g} samples), so 0 is used"
                + _bound_words(est, 1.0, "samples"))
        return replace(sampling, reason=note), kept_at_zero(off, est, note)
    note = (f"sample-number stamps, {stride}; their counters lag: t_b - t_a = "
            f"{est.offset_s:.3f} +- {est.uncertainty_s:.2g} samples (evidence "
            f"{est.evidence:.3g} over lag 0), so the faster stream is interpolated at the "
            "other's shifted sample numbers")
    return (replace(sampling, kind="continuous", paired_by_stamp=False, reason=note),
            replace(est, message=note))
