"""Do the two streams measure translation in the same unit? A check that needs no X.

A motion's screw has two invariants under ``C X = X H``: its rotation angle and its
translation along the rotation axis (the pitch ``d = n . t``, with ``n`` the unit axis).
From ``n_C = R_X n_H`` and ``t_C = R_X t_H + (I - R_C) t_X``, and ``n_C^T (I - R_C) = 0``,
``d_C = d_H`` for every motion, whatever X is. Streams in different units (mm and m, or a
monocular SLAM stream of unknown scale) give ``d_H = s d_C`` with ``s`` far from 1.

:func:`check_translation_units` estimates ``s`` (the weighted median of ``d_H / d_C``,
weights ``d_C^2``: the least-squares weights, robust to outlier motions) and refuses the
data (DataError, exit 3) only when both hold: ``s`` is beyond MAX_SCALE_RATIO from 1 (no
two units of length people use are closer, feet and metres being 3.28 apart), and the
pitches fit ``s`` clearly better than 1 (median residual at least FIT_GAIN times smaller).
Motions whose axes carry no pitch (planar driving: vertical axes, horizontal travel) say
nothing either way, and then nothing is refused. A motion that does not turn (below 1 deg,
pose noise: a rig that only translates) is pitch alone: ``t_C = R_X t_H``, so ``|t_C| =
|t_H|`` and its translation norms are compared.
"""

from __future__ import annotations

import math

import numpy as np

from simcalib.geometry import rotvec_from_matrix

__all__ = ["check_translation_units", "pitch_scale", "MAX_SCALE_RATIO", "FIT_GAIN",
           "MIN_MOTIONS"]

#: a scale between 1 / MAX_SCALE_RATIO and MAX_SCALE_RATIO is never called a unit mismatch
MAX_SCALE_RATIO = 3.0
#: ... and outside it, only when the scale fits the pitches this many times better than 1
FIT_GAIN = 3.0
#: fewer motions than this (with rotation between 2 and 170 deg) are not judged
MIN_MOTIONS = 5


def _pitches(C: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(d_C, d_H)``: translation along the rotation axis of each motion whose rotation is
    between 2 and 170 deg (near 180 deg the axis' sign is not defined)."""
    rv_c = rotvec_from_matrix(C[:, :3, :3])
    rv_h = rotvec_from_matrix(H[:, :3, :3])
    ang_c = np.linalg.norm(rv_c, axis=1)
    ang_h = np.linalg.norm(rv_h, axis=1)
    ok = (np.minimum(ang_c, ang_h) > math.radians(2.0)) & (
        np.maximum(ang_c, ang_h) < math.radians(170.0))
    d_c = np.einsum("ni,ni->n", rv_c[ok] / ang_c[ok, None], C[ok, :3, 3])
    d_h = np.einsum("ni,ni->n", rv_h[ok] / ang_h[ok, None], H[ok, :3, 3])
    # a motion that does not turn (both below 1 deg: pose noise) is all pitch: t_C = R_X t_H,
    # so |t_C| = |t_H| whatever X is (up to the noise's (I - R_C) t_X)
    still = np.maximum(ang_c, ang_h) < math.radians(1.0)
    if still.any():
        d_c = np.concatenate([d_c, np.linalg.norm(C[still, :3, 3], axis=1)])
        d_h = np.concatenate([d_h, np.linalg.norm(H[still, :3, 3], axis=1)])
    return d_c, d_h


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(x)
    cw = np.cumsum(w[order])
    return float(x[order][np.searchsorted(cw, 0.5 * cw[-1])])


def pitch_scale(C, H) -> tuple[float, float, float, int]:
    """``(s, residual_at_1, residual_at_s, n)``: the scale ``s`` with ``d_H = s d_C``, the
    median |d_H - d_C| and |d_H - s d_C| (in b's unit), and the motions used; ``s`` NaN
    when no motion carries pitch."""
    d_c, d_h = _pitches(np.asarray(C, dtype=np.float64), np.asarray(H, dtype=np.float64))
    use = np.abs(d_c) > 0.0
    if not use.any():
        return math.nan, math.nan, math.nan, int(d_c.size)
    s = _weighted_median(d_h[use] / d_c[use], d_c[use] ** 2)
    return (s, float(np.median(np.abs(d_h - d_c))), float(np.median(np.abs(d_h - s * d_c))),
            int(d_c.size))


def check_translation_units(C, H, hint: str = "write both in metres") -> float:
    """Raise :class:`simcalib.errors.DataError` when the motions ``C`` (stream a) and ``H``
    (stream b), ``(N, 4, 4)``, measure translation in different units (module doc; ``hint``:
    what the message offers). Returns the scale ``s`` (NaN when the motions cannot tell)."""
    s, r1, rs, n = pitch_scale(C, H)
    if n < MIN_MOTIONS or not math.isfinite(s) or s == 0.0:
        return s
    far = abs(math.log(abs(s))) > math.log(MAX_SCALE_RATIO)
    if far and r1 > FIT_GAIN * rs:
        from simcalib.errors import DataError
        raise DataError(
            f"the streams measure translation in different units: along each motion's "
            f"rotation axis stream b moves {s:.3g} times as far as stream a (median over "
            f"{n} motions; equal units give 1: the residual is {r1:.3g} with 1 and {rs:.3g} "
            f"with {s:.3g}); the files' units differ (mm, cm, m, inches?) or one stream has "
            f"no metric scale (monocular SLAM): {hint}")
    return s
