"""Poses between samples: interpolation of a pose stream at other instants.

:func:`interpolate_poses` (translation linear, rotation SLERP between the bracketing
samples, not across gaps), its validity mask alone (:func:`interpolation_valid`) and
:func:`smooth_poses` (Gaussian kernel regression, whose noise does not depend on where a
query falls between samples: the offset refinement's poses). Used by the synchronisation
(:mod:`simcalib.estimation.alignment`) and the offset cost
(:mod:`simcalib.estimation.offset_cost`).
"""

from __future__ import annotations

import math

import numpy as np

from simcalib.geometry import (matrix_from_quat, quat_from_matrix,
                               transform_from_rotation_translation)

__all__ = ["interpolate_poses", "interpolation_valid", "smooth_poses", "max_hole_s"]

#: a hole up to this many median periods is bridged in any stream ...
HOLE_PERIODS = 2.5
#: ... and up to twice the period this share of the stream's steps reach: a stream that
#: drops frames often has holes of several periods everywhere, and a gap is a hole beyond
#: what the stream usually has
HOLE_QUANTILE = 0.99


def max_hole_s(t: np.ndarray) -> float:
    """The longest hole between stamps ``t`` that interpolation bridges (longer ones are
    gaps): ``HOLE_PERIODS`` median periods, or twice the ``HOLE_QUANTILE`` quantile of the
    periods when frames drop often (a 100 Hz stream losing 20 % of its frames at random
    has 30-40 ms holes every second or so; bridging them costs nothing on a smooth
    motion, refusing them loses most motions that span a second)."""
    dt = np.diff(np.asarray(t, dtype=np.float64))
    if dt.size == 0:
        return 0.0
    return float(max(HOLE_PERIODS * np.median(dt), 2.0 * np.quantile(dt, HOLE_QUANTILE)))


def _slerp(q0: np.ndarray, q1: np.ndarray, u: np.ndarray) -> np.ndarray:
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where(dot[..., None] < 0, -q1, q1)
    dot = np.abs(dot).clip(max=1.0)
    theta = np.arccos(dot)
    s = np.sin(theta)
    small = s < 1e-9
    safe = np.where(small, 1.0, s)
    w0 = np.where(small, 1.0 - u, np.sin((1.0 - u) * theta) / safe)
    w1 = np.where(small, u, np.sin(u * theta) / safe)
    q = w0[..., None] * q0 + w1[..., None] * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def interpolation_valid(t: np.ndarray, t_query: np.ndarray, max_gap_s: float | None = None
                        ) -> np.ndarray:
    """The ``valid`` mask of :func:`interpolate_poses` alone (no poses computed)."""
    k = np.clip(np.searchsorted(t, t_query, side="right") - 1, 0, t.size - 2)
    valid = (t_query >= t[0]) & (t_query <= t[-1])
    if max_gap_s is not None:
        valid &= (t[k + 1] - t[k]) <= max_gap_s
    return valid


def interpolate_poses(t: np.ndarray, T: np.ndarray, t_query: np.ndarray,
                      max_gap_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Poses at ``t_query``: translation linear, rotation SLERP between the bracketing
    samples. Returns ``(T_query (M,4,4), valid (M,))``; queries outside ``[t0, t_end]`` or
    inside a gap longer than ``max_gap_s`` are invalid (their pose is the nearest sample)."""
    t_query = np.asarray(t_query, dtype=np.float64)
    k = np.clip(np.searchsorted(t, t_query, side="right") - 1, 0, t.size - 2)
    t0, t1 = t[k], t[k + 1]
    u = ((t_query - t0) / (t1 - t0))
    valid = (t_query >= t[0]) & (t_query <= t[-1])
    if max_gap_s is not None:
        valid &= (t1 - t0) <= max_gap_s
    u = u.clip(0.0, 1.0)
    q = quat_from_matrix(T[:, :3, :3])
    qi = _slerp(q[k], q[k + 1], u)
    p = T[k, :3, 3] * (1.0 - u)[:, None] + T[k + 1, :3, 3] * u[:, None]
    return transform_from_rotation_translation(matrix_from_quat(qi), p), valid


def smooth_poses(t: np.ndarray, T: np.ndarray, t_query: np.ndarray, sigma_s: float,
                 q: np.ndarray | None = None) -> np.ndarray:
    """Poses at ``t_query`` by Gaussian kernel regression over the samples (bandwidth
    ``sigma_s``): weighted mean translation and weighted, sign-aligned, renormalised
    quaternion mean over the samples (weights below exp(-10) are negligible; the support is
    symmetric about each query, so a truncated kernel cannot shift the timing).

    Why (time alignment): plain interpolation of NOISY poses has a noise level that depends
    on where the query falls between two samples (halfway, two samples are averaged), so a
    cost compared over offsets prefers offsets that put the queries between samples -- a
    bias of up to half a sample period when the two streams are sampled on commensurate
    clocks (e.g. 30 Hz and 15 Hz from one trigger). With ``sigma_s`` >= one sample period
    the kernel's weight sums are the same for every query position (to ~1e-8), so the noise
    no longer depends on the offset; the kernel is symmetric, so the smoothing does not
    shift the timing. ``q``: the samples' quaternions (x, y, z, w) when already known."""
    t_query = np.asarray(t_query, dtype=np.float64)
    n = t.size
    dt = float(np.median(np.diff(t)))
    k = max(1, int(math.ceil(4.5 * sigma_s / dt))) + 1      # symmetric: both sides >= 4.5 sigma
    c = np.searchsorted(t, t_query)
    idx = c[:, None] + np.arange(-k, k + 1)[None, :]
    inside = (idx >= 0) & (idx < n)
    idx = idx.clip(0, n - 1)
    w = np.exp(-0.5 * ((t[idx] - t_query[:, None]) / sigma_s) ** 2) * inside
    empty = w.sum(axis=1) <= 0          # far outside the samples (invalid anyway): nearest
    w[empty, k] = 1.0
    w /= w.sum(axis=1, keepdims=True)
    p = np.einsum("mk,mkj->mj", w, T[idx, :3, 3])
    q = quat_from_matrix(T[:, :3, :3]) if q is None else q
    qk = q[idx]
    q0 = q[c.clip(0, n - 1)]
    sign = np.where(np.sum(qk * q0[:, None, :], axis=-1) < 0, -1.0, 1.0)
    qm = np.einsum("mk,mkj->mj", w * sign, qk)
    qm /= np.linalg.norm(qm, axis=-1, keepdims=True)
    return transform_from_rotation_translation(matrix_from_quat(qm), p)
