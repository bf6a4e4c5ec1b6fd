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

__all__ = ["Consistency", "block_jackknife", "combine", "MIN_BLOCKS", "MAX_BLOCKS",
           "WeightingCheck", "weighting_check"]

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


@dataclass(frozen=True, eq=False)
class WeightingCheck:
    """Does X move when the rotation equations are weighted over the translation ones?

    Both weightings estimate the same X; when the data are consistent the two agree within
    the sigma. Systematic translation errors (a SLAM scale or drift, a target's size) pull
    the translation-weighted rotation away: then ``d`` (``pose_error(X_rot, X)``, the move)
    beyond its sigma (``mahalanobis2`` > chi-square 95 % on the determined dof) is added to
    the covariance as ``covariance`` (``d d^T`` on the determined directions)."""
    alpha_rotation: float
    d: np.ndarray = field(repr=False)
    mahalanobis2: float
    dof: int
    significant: bool
    covariance: np.ndarray | None = field(default=None, repr=False)
    message: str = ""

    def to_dict(self) -> dict:
        return {"alpha_rotation_weighted": self.alpha_rotation,
                "rotation_move_deg": float(np.degrees(np.linalg.norm(self.d[:3]))),
                "translation_move_m": float(np.linalg.norm(self.d[3:])),
                "mahalanobis2": self.mahalanobis2, "dof": self.dof,
                "significant": self.significant, "message": self.message}


def weighting_check(C, H, X, uncertainty, covariance_determined, solve_fn, alpha: float,
                    ratio: float = 100.0) -> WeightingCheck | None:
    """:class:`WeightingCheck` of ``X`` (estimated at ``alpha``) against the estimate at
    ``alpha / ratio`` (``solve_fn(C, H, alpha)`` returns X), with the reported covariance's
    finite part ``covariance_determined`` on the determined basis of ``uncertainty``."""
    from scipy.special import chdtri

    from simcalib.solvers.diagnostics.uncertainty import pose_error
    from simcalib.solvers.problem import ALPHA_MIN
    B = np.asarray(uncertainty.determined_basis)
    if B.shape[1] == 0:
        return None
    a_rot = max(alpha / ratio, ALPHA_MIN)
    try:
        X_rot = solve_fn(C, H, a_rot)
    except (ValueError, RuntimeError):
        return None
    if not np.isfinite(X_rot).all():
        return None
    d = B @ (B.T @ pose_error(X_rot, X))
    c = B.T @ d
    S = B.T @ covariance_determined @ B
    m2 = float(c @ np.linalg.lstsq(S, c, rcond=None)[0])
    k = B.shape[1]
    bound = float(chdtri(k, 0.05))
    sig = m2 > bound
    msg = (f"weighting rotation {1 / (a_rot / alpha):.0f}x more moves X by "
           f"{np.degrees(np.linalg.norm(d[:3])):.3g} deg / {1e3 * np.linalg.norm(d[3:]):.3g} mm"
           f" ({m2:.3g} on {k} dof, 95 % bound {bound:.3g}): ")
    msg += ("beyond the sigma, so the translation equations carry systematic errors; the move "
            "is added to the covariance" if sig else "within the sigma")
    return WeightingCheck(a_rot, d, m2, k, sig, np.outer(d, d) if sig else None, msg)
