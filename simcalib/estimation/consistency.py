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
covariance when the jackknife's spread is what chance gives with the model right (its
model-whitened largest eigenvalue below the Wishart 95 % quantile); otherwise it raises
the model's covariance to the jackknife's, widened for having been estimated from few
blocks (:func:`estimated_covariance_factor`), per eigen-direction, on the directions the
motions determine; the undetermined ones stay undetermined.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Consistency", "block_jackknife", "combine", "MIN_BLOCKS", "MAX_BLOCKS",
           "CONTIGUOUS_BLOCKS", "estimated_covariance_factor",
           "WeightingCheck", "weighting_check"]

MIN_BLOCKS = 8          # fewer usable blocks: the data are too few to check themselves
MAX_BLOCKS = 64         # stop-and-go data: one pose a block up to this many poses
CONTIGUOUS_BLOCKS = 40  # continuous recordings: long contiguous blocks (serial correlation)


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
    #: one pose a block (independent measurements): the spread is widened for having been
    #: estimated from few blocks; contiguous blocks of a continuous recording are not (the
    #: delete-a-block jackknife is conservative there already: Efron-Stein)
    single_poses: bool = False
    #: the reported covariance was raised to the jackknife's (set by the path after
    #: :func:`combine`; False when the spread was within chance)
    raised: bool = False

    def to_dict(self) -> dict:
        return {"checked": self.checked, "blocks": self.blocks, "raised": self.raised,
                "variance_ratio": None if not math.isfinite(self.ratio) else self.ratio,
                "method": "delete-a-block jackknife over the poses (recording order)",
                "message": self.message}


def _block_of(n_poses: int, G: int) -> np.ndarray:
    return np.minimum((np.arange(n_poses) * G) // n_poses, G - 1)


def block_jackknife(motions, n_poses: int, solve_fn, X: np.ndarray,
                    blocks: int | None = None) -> Consistency:
    """The jackknife of ``X`` over blocks of the ``n_poses`` synchronised poses that
    ``motions`` (:class:`simcalib.estimation.motions.MotionSet`) join. ``solve_fn(C, H)``
    returns the X of a subset (the same estimator as X). ``blocks``: how many (default:
    one pose a block up to :data:`MAX_BLOCKS` for ``stations`` motions, where every pose is
    its own measurement; :data:`CONTIGUOUS_BLOCKS` contiguous blocks otherwise, long
    against the serial correlation of a continuous recording)."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    if blocks is None:
        blocks = MAX_BLOCKS if motions.policy == "stations" else CONTIGUOUS_BLOCKS
    G = int(min(blocks, n_poses))

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
    single = G == n_poses
    return Consistency(True, k, cov, single_poses=single, message=(
        f"X re-estimated without each of {k} " + ("poses" if single else "blocks of poses")
        + (f" (the spread widened x{estimated_covariance_factor(k):.2f} for its own "
           "uncertainty)" if single else "")))


@functools.lru_cache(maxsize=64)
def wishart_max_quantile(p: int, dof: int, level: float = 0.95, draws: int = 4000) -> float:
    """The ``level`` quantile of the largest eigenvalue of ``W / dof``, ``W ~ Wishart_p(I,
    dof)``: how large the jackknife's whitened spread gets by chance when the model's
    covariance is right (a fixed table: drawn once from ``default_rng(0)``)."""
    rng = np.random.default_rng(0)
    Z = rng.standard_normal((draws, dof, p))
    lam = np.linalg.eigvalsh(np.einsum("nkp,nkq->npq", Z, Z) / dof)[:, -1]
    return float(np.quantile(lam, level))


def estimated_covariance_factor(blocks: int, dof: int = 6, level: float = 0.95) -> float:
    """How much wider a covariance estimated from ``blocks`` jackknife replicates must be
    for its ``level`` region to hold ``level`` of the estimates: the Hotelling T^2 quantile
    ``p (n - 1) / (n - p) F(p, n - p)`` over the chi-square one (p = ``dof``, n = blocks);
    1 for many blocks, ~1.3 for 40, ~1.8 for 20."""
    # scipy.special, not scipy.stats: the same quantiles without ~1 s of import per process
    from scipy.special import chdtri, fdtri
    n, p = int(blocks), int(dof)
    if n <= p + 1:
        return float("inf")
    return float(p * (n - 1) / (n - p) * fdtri(p, n - p, level) / chdtri(p, 1.0 - level))


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
    factor = estimated_covariance_factor(check.blocks, B.shape[1]) if check.single_poses \
        else 1.0
    if not np.isfinite(factor):
        return cov, cov_det, float("nan")
    S_j = factor * (Wh.T @ (B.T @ check.covariance @ B) @ Wh)
    lam, U = np.linalg.eigh(0.5 * (S_j + S_j.T))
    ratio = float(lam.max())
    if ratio / factor <= wishart_max_quantile(B.shape[1], check.blocks - 1):
        return cov, cov_det, ratio        # the spread is what the model's sigma predicts
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
