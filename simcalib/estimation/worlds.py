"""Which world an instant lies in, where a stream's world frame jumps.

A stream whose world frame jumps (:mod:`simcalib.estimation.world_jumps`) carries the
stamps of the first pose of each later stretch (``world_jumps_s``). Every stretch is its own
world: :func:`instant_worlds` numbers the pair of stretches (one per stream) each
synchronised instant lies in, and says which instants mix two worlds (interpolated or
smoothed across a jump). Used by the pairing of both kinds (:func:`simcalib.estimation.
alignment.synchronise`, :func:`simcalib.estimation.sampling.pair_by_stamp`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["instant_worlds"]


def _stream_worlds(stream, t: np.ndarray, interpolated: bool, smooth_s) -> tuple:
    """``(stretch of each instant t, usable)``: an instant whose pose of ``stream`` is
    interpolated between two samples a jump separates (or smoothed within 3 bandwidths of
    one) mixes two worlds: not usable."""
    jumps = np.asarray(getattr(stream, "world_jumps_s", ()), dtype=np.float64)
    label = np.searchsorted(jumps, t, side="right")
    ok = np.ones(t.shape, dtype=bool)
    if not interpolated and smooth_s is None:
        return label, ok
    ts = np.asarray(stream.timestamps_s, dtype=np.float64)
    for J in jumps:
        k = int(np.searchsorted(ts, J, side="left"))
        lo, hi = ts[max(k - 1, 0)], ts[min(k, ts.size - 1)]
        if interpolated:
            ok &= ~((t > lo) & (t < hi))
        if smooth_s is not None:
            ok &= np.abs(t - J) > 3.0 * float(smooth_s)
    return label, ok


def instant_worlds(sa, sb, t_a: np.ndarray, t_b: np.ndarray, reference: str,
                   smooth_s=None) -> tuple:
    """``(world, usable)`` of synchronised instants at a's stamps ``t_a`` and b's ``t_b``
    (each stream's own clock; ``reference``: the stream not interpolated, ``"a"``, ``"b"``
    or ``"both"`` (paired by stamp)): ``world`` numbers the pair of stretches (one per
    stream, between its ``world_jumps_s``) an instant lies in; ``(None, None)`` when
    neither stream has a jump."""
    na = len(getattr(sa, "world_jumps_s", ()))
    nb = len(getattr(sb, "world_jumps_s", ()))
    if na == 0 and nb == 0:
        return None, None
    la, oa = _stream_worlds(sa, np.asarray(t_a, np.float64), reference == "b", smooth_s)
    lb, ob = _stream_worlds(sb, np.asarray(t_b, np.float64), reference == "a", smooth_s)
    return (la * (nb + 1) + lb).astype(np.int64), oa & ob
