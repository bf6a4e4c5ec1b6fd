"""Does the data's own consistency support the model's sigma? A delete-a-block jackknife.

The covariance of :func:`simcalib.solve` assumes that each pose's error is white (the
residuals estimate its size). Real recordings are not white: a robot's kinematic error and
a target's calibration error vary smoothly over the workspace, SLAM drifts, interpolation
correlates neighbours. Their effect on X shows when the estimate is repeated on parts of
the data: the poses are split into ``G`` contiguous blocks (in recording order), X is
re-estimated without each block's poses (every motion touching one of them is dropped), and

    Sigma_jack = (G - 1) / G * sum_g (d_g - mean d)(d_g - mean d)^T,   d_g = pose_error(X_-g, X)

is the jackknife covariance (Efron & Stein): it sees every error that differs between
blocks, whatever its correlation within a block. :func:`combine` keeps the model's
covariance where it is the larger and raises it to the jackknife's where the data are less
consistent than the model says (per eigen-direction of the model-whitened jackknife), on
the directions the motions determine; the undetermined ones stay undetermined.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Consistency", "block_jackknife", "combine", "MIN_BLOCKS", "MAX_BLOCKS"]

MIN_BLOCKS = 5          # fewer usable blocks: the data are too few to check themselves
MAX_BLOCKS = 12


@dataclass(frozen=True, eq=False)
class Consistency:
    """The jackknife check. ``checked``: enough blocks were usable; ``blocks``: how many;
    ``covariance``: the jackknife's 6x6 (wx, wy, wz, vx, vy, vz; rad, m; frame a) or None;
    ``ratio``: the largest (jackknife / model) variance ratio over the determined
    directions (> 1: the model's sigma is too small there); ``message``: one line."""
    checked: bool
    blocks: int
    covariance: np.ndarray | None = field(default=None, repr=False)
    ratio: float = float("nan")
    message: str = ""

    def to_dict(self) -> dict:
        return {"checked": self.checked, "blocks": self.blocks,
                "variance_ratio": None if not math.isfinite(self.ratio) else self.ratio,
                "method": "delete-a-block jackknife over the poses (recording order)",
                "message": self.message}


def _block_of(n_poses: int, G: int) -> np.ndarray:
    return np.minimum((np.arange(n_poses) * G) // n_poses, G - 1)


def block_jackknife(motions, n_poses: int, solve_fn, X: np.ndarray) -> Consistency:
    """The jackknife of ``X`` over blocks of the ``n_poses`` synchronised poses that
    ``motions`` (:class:`simcalib.estimation.motions.MotionSet`) join. ``solve_fn(C, H)``
    returns the X of a subset (the same estimator as X)."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    G = int(min(MAX_BLOCKS, n_poses))
    if G < MIN_BLOCKS:
        return Consistency(False, 0, message=f"{n_poses} poses are too few for the data to "
                           f"check their own consistency (>= {MIN_BLOCKS} needed): sigma is "
                           "the model's alone")
    block = _block_of(n_poses, G)
    bi, bj = block[motions.i], block[motions.j]
    deltas = []
    for g in range(G):
        keep = (bi != g) & (bj != g)
        if keep.sum() < 3:
            continue
        try:
            Xg = solve_fn(motions.C[keep], motions.H[keep])
        except (ValueError, RuntimeError):
            continue
        if np.isfinite(Xg).all():
            deltas.append(pose_error(Xg, X))
    if len(deltas) < MIN_BLOCKS:
        return Consistency(False, len(deltas), message=f"only {len(deltas)} of {G} blocks "
                           "could be left out and re-solved: no consistency check")
    D = np.asarray(deltas)
    D = D - D.mean(axis=0)
    k = D.shape[0]
    cov = (k - 1) / k * (D.T @ D)
    return Consistency(True, k, cov, message=f"X re-estimated without each of {k} blocks "
                       "of poses")


def combine(uncertainty, check: Consistency) -> tuple[np.ndarray, np.ndarray, float]:
    """``(covariance, covariance_determined, ratio)``: the model's (``uncertainty``, a
    :class:`simcalib.solvers.diagnostics.uncertainty.Uncertainty`) raised to the
    jackknife's variance along every determined direction where the jackknife is larger
    (eigen-directions of the model-whitened jackknife on the determined basis); ``ratio``
    the largest variance ratio (NaN: no check). The axes the model leaves undetermined keep
    their ``inf``."""
    cov, cov_det = np.asarray(uncertainty.covariance), np.asarray(
        uncertainty.covariance_determined)
    B = np.asarray(uncertainty.determined_basis)
    if not check.checked or B.shape[1] == 0:
        return cov, cov_det, float("nan")
    S_m = B.T @ cov_det @ B
    w, V = np.linalg.eigh(0.5 * (S_m + S_m.T))
    w = np.maximum(w, 1e-30 * max(float(w.max()), 1e-300))
    Wh = V / np.sqrt(w)                              # whitening: Wh^T S_m Wh = I
    S_j = Wh.T @ (B.T @ check.covariance @ B) @ Wh
    lam, U = np.linalg.eigh(0.5 * (S_j + S_j.T))
    ratio = float(lam.max())
    Dh = V * np.sqrt(w)                              # de-whitening
    extra = Dh @ U @ np.diag(np.maximum(lam - 1.0, 0.0)) @ U.T @ Dh.T
    add = B @ extra @ B.T
    add = 0.5 * (add + add.T)
    out = cov.copy()
    fin = np.isfinite(out)
    out[fin] = out[fin] + add[fin]
    return out, cov_det + add, ratio
