"""Does the data's own consistency support the reported sigma?

Without a prior (the default), X's covariance comes from the poses' own errors
(:func:`pose_consistency`, the model of :mod:`simcalib.estimation.pose_errors`): the
per-pose residuals, X's exact sensitivity to each pose (for ``bursts`` motions whose
stations' poses share their error - :func:`stations_share_errors` - per station: the mean
residual of its poses and their summed sensitivity), white or - when neighbouring poses'
residuals correlate beyond chance - white plus parts correlated over the pose space and
along the recording, widened for having been estimated from few poses, plus the clock
offset's uncertainty; directions only the pose errors determine (errors in the variables)
are undetermined. It is checked without any reference by the recording's two halves
(:class:`SplitCheck`): X of the first half against X of the second, their difference
against the covariance the model predicts for it; beyond the chi-square 95 % bound the
covariance is scaled by NEES / bound.

With a prior, a delete-a-block jackknife (:func:`block_jackknife`, :func:`combine`): the
poses are split into ``G`` contiguous blocks (in recording order), X is re-estimated
without each block's poses (every motion touching one of them is dropped), and

    Sigma_jack = (G - 1) / G * sum_g (d_g - mean d)(d_g - mean d)^T,   d_g = pose_error(X_-g, X)

is the jackknife covariance (Efron & Stein). :func:`combine` keeps the model's covariance
when the jackknife's spread is what chance gives with the model right (its model-whitened
largest eigenvalue below the Wishart 95 % quantile); otherwise it raises the model's
covariance to the jackknife's, widened for having been estimated from few blocks
(:func:`estimated_covariance_factor`), per eigen-direction, on the directions the motions
determine; the undetermined ones stay undetermined.

In both cases :func:`weighting_check` re-estimates X with the rotation equations weighted
over the translation ones and adds a move beyond the sigma to the covariance.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Consistency", "block_jackknife", "combine", "MIN_BLOCKS", "MAX_BLOCKS",
           "stations_share_errors", "STATION_LEVEL",
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

    def notes(self) -> list[str]:
        """Sentences for the verdict."""
        if self.checked and self.raised:
            return [f"sigma raised to the data's own consistency (block jackknife over "
                    f"{self.blocks} blocks of poses: its spread up to "
                    f"{math.sqrt(self.ratio):.3g}x the model's 1-sigma)"]
        if self.checked:
            return [f"the model's sigma agrees with the data's own consistency (block "
                    f"jackknife over {self.blocks} blocks: its spread within chance)"]
        return ["UNVERIFIED: " + self.message]

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
    its own measurement, and one station a block for ``bursts``; :data:`CONTIGUOUS_BLOCKS`
    contiguous blocks otherwise, long against the serial correlation of a continuous
    recording)."""
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    runs = getattr(motions, "stations", None)
    units = n_poses if runs is None else int(runs[-1]) + 1   # poses, or stations (bursts)
    if blocks is None:
        blocks = MAX_BLOCKS if motions.policy in ("stations", "bursts") else CONTIGUOUS_BLOCKS
    G = int(min(blocks, units))

    if G < MIN_BLOCKS:
        return Consistency(False, 0, message=f"{units} {'poses' if runs is None else 'stations'}"
                           " are too few for the data to check their own consistency (>= "
                           f"{MIN_BLOCKS} needed): sigma is the model's alone")
    block = _block_of(n_poses, G) if runs is None else _block_of(units, G)[runs]
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
    single = G == units
    what = "poses" if runs is None else "stations"
    return Consistency(True, k, cov, single_poses=single, message=(
        f"X re-estimated without each of {k} " + (what if single else f"blocks of {what}")
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
    finite part ``covariance_determined`` on the determined basis of ``uncertainty``.
    None where it does not apply: nothing determined, or no motion rotating beyond the
    pose noise (pure translation: X's rotation comes from the translation equations alone,
    and weighting the rotation ones, which hold only noise, would fit that noise)."""
    from scipy.special import chdtri

    from simcalib.solvers.diagnostics.uncertainty import pose_error
    from simcalib.solvers.problem import ALPHA_MIN, rotation_shortfall
    B = np.asarray(uncertainty.determined_basis)
    if B.shape[1] == 0 or rotation_shortfall(C, H) is not None:
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


# ------------------------------------------------------------ pose-level uncertainty
#: the neighbour correlations' standard score (the larger of the pose-space and the
#: recording-order one) above which pose errors count as correlated: one-sided 5 % each,
#: ~10 % for the pair of tests. The costs are not symmetric: a correlated error taken as
#: white gives a sigma too small (measured on the generated robot-error recordings: 2.5 %
#: each, coverage 0.85 on 40 seeds; 5 % each, 0.875), white errors taken as correlated a
#: sigma too large (the stations' coverage stays 0.925 on the same seeds)
NEIGHBOUR_Z = 1.645
#: fewer poses: the residuals cannot estimate their own covariance at all
MIN_POSES = 3
#: fewer poses: no correlated parts are fitted, and the sigma is reported unverified
MIN_CHECKED_POSES = 8


@dataclass(frozen=True, eq=False)
class SplitCheck:
    """X estimated on the first and on the second half of the recording (poses in
    recording order; each half's own motions): ``d = pose_error(X_1, X_2)``, its predicted
    covariance ``covariance`` under the pose-error model (the halves share every error
    common to all poses, which the difference cancels), ``nees`` over the determined
    ``dof`` and its chi-square 95 % ``bound``."""
    d: np.ndarray = field(repr=False)
    covariance: np.ndarray = field(repr=False)
    nees: float
    dof: int
    bound: float

    @property
    def within(self) -> bool:
        return self.nees <= self.bound

    def to_dict(self) -> dict:
        return {"rotation_diff_deg": float(np.degrees(np.linalg.norm(self.d[:3]))),
                "translation_diff_m": float(np.linalg.norm(self.d[3:])),
                "nees": self.nees, "dof": self.dof, "bound_95": self.bound,
                "within": self.within}


@dataclass(frozen=True, eq=False)
class PoseConsistency:
    """The uncertainty of X from the poses' own errors (:mod:`simcalib.estimation.
    pose_errors`), checked by the recording's two halves. ``checked``: enough poses and a
    split check that could run; ``covariance``: X's 6x6 before the determined-basis
    projection; ``white_covariance``: what white pose errors alone give; ``ratio``: the
    largest variance ratio of the two (> 1: correlated errors that do not average down);
    ``widening``: the factor for the covariance's own estimation error (few poses);
    ``split``: :class:`SplitCheck` or None; ``raised``: the split check's disagreement
    scaled the covariance by ``split_factor``."""
    checked: bool
    n_poses: int
    covariance: np.ndarray | None = field(default=None, repr=False)
    white_covariance: np.ndarray | None = field(default=None, repr=False)
    model: object = None
    ratio: float = float("nan")
    widening: float = 1.0
    split: SplitCheck | None = None
    split_factor: float = 1.0
    message: str = ""
    #: the directions the data determine (6, k: the model's less the noise-determined
    #: ones) and the noise-determined ones (6, u; :func:`simcalib.estimation.pose_errors.
    #: noise_determined`), unit columns in delta coordinates; None: the model's
    basis: np.ndarray | None = field(default=None, repr=False)
    undetermined: np.ndarray | None = field(default=None, repr=False)

    @property
    def raised(self) -> bool:
        return self.split_factor > 1.0

    @property
    def blocks(self) -> int:
        return self.n_poses

    def notes(self) -> list[str]:
        """Sentences for the verdict."""
        if not self.checked:
            return ["UNVERIFIED: " + self.message]
        out = [self.message]
        if self.undetermined is not None and self.undetermined.shape[1]:
            out.append(f"{self.undetermined.shape[1]} direction(s) the model counted as "
                       "determined are determined only by the pose errors themselves "
                       "(errors in the variables): undetermined")
        if self.split is not None and self.split.within:
            out.append(f"the recording's two halves agree within it (NEES "
                       f"{self.split.nees:.3g} on {self.split.dof} dof, 95 % bound "
                       f"{self.split.bound:.3g})")
        elif self.split is not None:
            out.append(f"the recording's two halves disagree beyond it (NEES "
                       f"{self.split.nees:.3g} on {self.split.dof} dof, 95 % bound "
                       f"{self.split.bound:.3g}): sigma raised x{math.sqrt(self.split_factor):.3g}")
        return out

    def to_dict(self) -> dict:
        shares = None if self.model is None else self.model.shares()
        m = self.model
        return {"checked": self.checked, "method": "pose-level error model (white + "
                "correlated over the workspace and the recording), split-half check",
                "n_poses": self.n_poses, "raised": self.raised,
                "variance_ratio": None if not math.isfinite(self.ratio) else self.ratio,
                "widening": self.widening, "split_factor": self.split_factor,
                "shares": shares,
                "pose_range": None if m is None else m.ell_pose,
                "time_range_poses": None if m is None else m.ell_time,
                "split": None if self.split is None else self.split.to_dict(),
                "noise_determined_directions": None if self.undetermined is None else
                self.undetermined.T.tolist(),
                "message": self.message}


def widening_factor(n_poses: int, dof: int = 6, level: float = 0.95) -> float:
    """How much wider a covariance estimated from the residuals of ``n_poses`` poses must
    be for its ``level`` region to hold ``level`` of the estimates: ``p F(p, nu) /
    chi2_p`` at ``level`` (one scale estimated with ``nu = n_poses - 2`` degrees of freedom:
    X and the world-to-world transform take two poses' worth); inf below 3 poses."""
    from scipy.special import chdtri, fdtri
    nu = int(n_poses) - 2
    if nu < 1:
        return float("inf")
    return float(dof * fdtri(dof, nu, level) / chdtri(dof, 1.0 - level))


def _halves(motions, n_all: int, idx, alpha: float, solve_fn):
    """``(d, G_1 - G_2)``: the difference of the estimates on the recording's first and
    second half of poses (each half's own motions) and of their sensitivities at the
    poses ``idx``; None when a half has fewer than 3 motions or does not solve."""
    from simcalib.estimation import pose_errors as pe
    from simcalib.solvers.diagnostics.uncertainty import pose_error
    half = idx[idx.size // 2]
    out = []
    for sel in (motions.j < half, motions.i >= half):
        if int(sel.sum()) < 3:
            return None
        try:
            Xh = solve_fn(motions.C[sel], motions.H[sel])
        except (ValueError, RuntimeError):
            return None
        if not np.isfinite(Xh).all():
            return None
        out.append((Xh, pe.pose_sensitivity(motions.C[sel], motions.H[sel], Xh, alpha,
                                            motions.pose_pairs[sel], n_all)[idx]))
    return pose_error(out[0][0], out[1][0]), out[0][1] - out[1][1]


def _model_covariance(r, Gs, T_a, idx, level_z: float = NEIGHBOUR_Z):
    """``(covariance, white, model, z)``: the joint covariance of ``sum_i Gs_i r_i`` under
    the fitted pose-error model when neighbouring poses' residuals correlate beyond chance
    (:func:`simcalib.estimation.pose_errors.neighbour_correlation` over the pose-space
    or the recording-order neighbours: the larger standard score ``z`` above ``level_z``),
    else under white pose errors (the residuals' covariance on every
    pose; ``model`` then None)."""
    from simcalib.estimation import pose_errors as pe
    S = r.T @ r / max(r.shape[0] - 2, 1)
    white = np.einsum("nij,jk,nlk->il", Gs, S, Gs)
    z = max(pe.neighbour_correlation(r, pairs)[1]
            for pairs in pe.neighbour_pairs(T_a).values())
    if z <= level_z:
        return white, white, None, z
    model = pe.fit_error_model(r, pe.pair_design(T_a, idx))
    return pe.model_covariance(Gs, model, T_a, idx), white, model, z


def _nees(d, S, B) -> tuple[float, int]:
    c = B.T @ d
    Sb = B.T @ S @ B
    return float(c @ np.linalg.lstsq(0.5 * (Sb + Sb.T), c, rcond=None)[0]), B.shape[1]


def _variance_ratio(C, W, B) -> float:
    """The largest generalised eigenvalue of ``C`` over ``W`` on the basis ``B``."""
    Wb, Cb = B.T @ W @ B, B.T @ C @ B
    lam, V = np.linalg.eigh(0.5 * (Wb + Wb.T))
    keep = lam > 1e-12 * max(float(lam.max()), 1e-300)
    if not keep.any():
        return float("nan")
    Wh = V[:, keep] / np.sqrt(lam[keep])
    return float(np.linalg.eigvalsh(Wh.T @ Cb @ Wh).max())


def _covariances(r, Gs, T_a, idx, few: bool):
    """``(C, W, model)``: the joint covariance of ``sum_i Gs_i r_i`` (the model's, or white
    with few poses) and the white-only one, widened for their estimation from ``n``
    poses."""
    n = r.shape[0]
    if few:
        S = r.T @ r / (n - 2)
        C = W = np.einsum("nij,jk,nlk->il", Gs, S, Gs)
        model = None
    else:
        C, W, model, _ = _model_covariance(r, Gs, T_a, idx)
    f = widening_factor(n)
    return f * C, f * W, model


def _message(what, f, ratio, few, split, offset_ratio) -> str:
    msg = (f"sigma from the errors of {what}" + (
        f" (widened x{math.sqrt(f):.3g} for being estimated from them)" if f > 1.1 else "")
        + (f"; errors correlated over the workspace or the recording raise X's variance up "
           f"to {ratio:.3g}x what independent pose errors give" if ratio > 1.1 else
           "; their errors look independent"))
    if few:
        msg += (f"; {what} are too few to check it (>= {MIN_CHECKED_POSES} needed for the "
                "correlated errors and the split-half check)")
    elif split is None:
        msg += "; the recording's halves could not be compared (too few motions each)"
    if offset_ratio > 0.1:
        msg += (f"; the clock offset's uncertainty adds up to {offset_ratio:.3g}x that "
                "variance")
    return msg


def pose_consistency(motions, synced, X, alpha: float, basis, solve_fn,
                     offset_sigma_s: float = 0.0) -> PoseConsistency:
    """:class:`PoseConsistency` of ``X`` estimated (the alpha-cost minimiser) from
    ``motions`` (:class:`simcalib.estimation.motions.MotionSet`, the inliers) between the
    ``synced`` poses; ``basis`` the determined directions (6, k); ``solve_fn(C, H)`` the
    same estimator on a subset (the split check); ``offset_sigma_s``: the 1-sigma of the
    clock offset the streams were synchronised with (its error shifts every pose of b by
    its velocity times the error: one error common to the recording, added to X's
    covariance through the sensitivities)."""
    from scipy.special import chdtri

    from simcalib.estimation import pose_errors as pe
    used = np.zeros(synced.n, dtype=bool)
    used[motions.i] = used[motions.j] = True
    idx = np.flatnonzero(used)
    n = int(idx.size)
    if n < MIN_POSES:
        return PoseConsistency(False, n, message=(
            f"{n} poses are too few for their residuals to estimate their own errors "
            f"(>= {MIN_POSES} needed): sigma is the solver's model alone"))
    T_a = np.asarray(synced.T_a)[idx]
    world = getattr(synced, "world", None)
    r, _ = pe.pose_residuals(T_a, np.asarray(synced.T_b)[idx], X,
                             world=None if world is None else world[idx])
    runs = getattr(motions, "stations", None)
    runs = runs if runs is not None and stations_share_errors(runs[idx], r) else None
    units = n if runs is None else int(np.unique(runs[idx]).size)
    few = units < MIN_CHECKED_POSES
    U = pe.noise_determined(motions.C, motions.H, X, alpha, motions.pose_pairs, r, idx,
                            basis)
    B = _reduced_basis(np.asarray(basis), U)
    G = pe.pose_sensitivity(motions.C, motions.H, X, alpha, motions.pose_pairs,
                            synced.n)[idx]
    halves = None if few else _halves(motions, synced.n, idx, alpha, solve_fn)
    Gs = G if halves is None else np.concatenate([G, halves[1]], axis=1)
    s_off = offset_sigma_s if math.isfinite(offset_sigma_s) else 0.0
    V = pe.body_velocities(synced.T_b, synced.time_s, world)[idx]
    if s_off > 0:
        r = _without_offset(r, V)
    offset_g = np.einsum("nij,nj->i", Gs, V) * s_off
    C, W, model = _covariances(*((r, Gs, T_a, idx) if runs is None else
                                 _by_station(runs[idx], r, Gs, T_a)), few)
    ratio = _variance_ratio(C[:6, :6], W[:6, :6], B) if B.shape[1] else float("nan")
    off = np.outer(offset_g, offset_g)
    off_ratio = _variance_ratio(C[:6, :6] + off[:6, :6], C[:6, :6], B) - 1.0 \
        if B.shape[1] else 0.0
    C = C + off
    split, factor = None, 1.0
    if halves is not None and B.shape[1]:
        m2, k = _nees(halves[0], C[6:, 6:], B)
        split = SplitCheck(halves[0], C[6:, 6:], m2, k, float(chdtri(k, 0.05)))
        factor = max(1.0, m2 / split.bound)
    f = widening_factor(units)
    what = f"{n} poses" if runs is None else f"{units} stations ({n} poses)"
    return PoseConsistency(split is not None, n, factor * C[:6, :6], W[:6, :6], model, ratio,
                           f, split, factor, _message(what, f, ratio, few, split, off_ratio),
                           B, U)


#: the poses of a station share one error when their mean residuals spread beyond what
#: their own scatter gives at this level (:func:`stations_share_errors`)
STATION_LEVEL = 0.05


def stations_share_errors(station, r) -> bool:
    """Do the poses of one station (``station``: each pose's) share their error? The
    one-way analysis of variance of the residuals ``r`` (n, 6), whitened by their scatter
    within the stations: the stations' means spread beyond what that scatter gives (the F
    test at :data:`STATION_LEVEL`), or there is no scatter within a station to tell
    (one pose a station, or frames that repeat one pose)."""
    from scipy.special import fdtri
    _, inv, counts, means = _station_means(station, r)
    k, n = counts.size, r.shape[0]
    if k < 2 or n - k < 6:
        return True
    dev = r - means[inv]
    within = dev.T @ dev / (n - k)
    d = means - counts @ means / n
    between = (d * counts[:, None]).T @ d / (k - 1)
    if np.trace(within) <= 1e-12 * np.trace(between):
        return True
    f = float(np.trace(np.linalg.pinv(within) @ between)) / r.shape[1]
    return f > float(fdtri(r.shape[1] * (k - 1), r.shape[1] * (n - k), 1.0 - STATION_LEVEL))


def _station_means(station, r):
    """``(first pose, station of each pose (0..k-1), poses a station, mean residual)``."""
    _, first, inv, counts = np.unique(station, return_index=True, return_inverse=True,
                                      return_counts=True)
    means = np.zeros((first.size, r.shape[1]))
    np.add.at(means, inv, r)
    return first, inv, counts, means / counts[:, None]


def _by_station(station, r, Gs, T_a):
    """``(r, Gs, T_a, index)`` per station (the runs of ``bursts``: poses that stand still
    together, whose errors are largely one - a still target seen from one viewpoint): the
    mean residual of each station's poses, their summed sensitivities, the first pose and
    the station's ordinal. An error common to a station moves X by the summed
    sensitivities; one per pose by each pose's, whose share the mean residual carries at
    its variance over the station's size - exact where a station's poses weigh alike."""
    first, inv, _, means = _station_means(station, r)
    G_s = np.zeros((first.size,) + Gs.shape[1:])
    np.add.at(G_s, inv, Gs)
    return means, G_s, T_a[first], np.arange(first.size)


def _without_offset(r, V) -> np.ndarray:
    """The residuals ``r`` less their part along b's velocities ``V`` (n, 6): the clock
    offset's error, whose uncertainty is added on its own (weighted least squares with the
    residuals' covariance)."""
    Si = np.linalg.pinv(r.T @ r / max(r.shape[0] - 2, 1))
    den = float(np.einsum("ni,ij,nj->", V, Si, V))
    if den <= 0:
        return r
    return r - V * (float(np.einsum("ni,ij,nj->", V, Si, r)) / den)


def _reduced_basis(B, U) -> np.ndarray:
    """The part of the basis ``B`` (6, k) orthogonal to ``U`` (6, u), orthonormal."""
    if U.shape[1] == 0:
        return B
    R = B - U @ np.linalg.lstsq(U, B, rcond=None)[0]
    Uo, s, _ = np.linalg.svd(R, full_matrices=False)
    return Uo[:, : max(B.shape[1] - U.shape[1], 0)] if s.size else np.zeros((6, 0))
