"""Outlier-robust hand-eye estimation over motions: RANSAC + dqopt, and IRLS dqopt.

* :func:`screw_residuals` — per-motion residual of the screw constraint ``C_i X = X H_i`` in
  dual-quaternion form: ``r_i = sqrt(|q_C q_X - q_X q_H|^2 + alpha^2 |(q_C q_X)' - (q_X q_H)'|^2)``
  (the square root of motion i's term of the paper's cost (8), with the sign of ``q_H``
  chosen per motion). Units: rotation part ~ half the rotation error (rad), translation part
  ~ ``alpha`` x half the translation error (m).
* :func:`ransac` — hypotheses from minimal sets of motions (2 motions with non-parallel
  rotation axes, or translations where nothing rotates beyond the noise, solved all at
  once by ``simcalib.solve_batch`` with a DQ method), consensus
  by the per-motion residual, threshold given, from the noise level, or automatic (least
  median of squares scale); the best consensus is refined (dqopt on the inliers, re-scored,
  repeated until the inlier set is stable) — the final ``X`` is the plain solve (dqopt) on
  the inliers.
* :func:`irls` — iteratively re-weighted dqopt (Huber / Cauchy / Tukey weights on the
  per-motion residuals) through the plain solve with ``weights=w``; the cost is a sum
  over motions so the weighted S, W, M keep dqopt exact.
* :func:`robust_solve` — ``robust="none" | "ransac" | "irls"`` (registry :data:`ROBUST_METHODS`).

All return a :class:`RobustSolution` (``X``, the final ``Solution``, the inlier mask, the
weights, the residuals, the threshold). The plain solve is
:func:`simcalib.solvers.single.solve_single` (``simcalib.solve`` without ``robust``: the
same numbers), the layer below both this module and ``simcalib.solve(robust=...)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simcalib.errors import SolverError, unknown_choice
from simcalib.geometry import (check_transforms, dual_quat_from_transform, quat_left_matrix,
                               quat_right_matrix, rotvec_from_matrix)
from simcalib.solvers.batch_solve import solve_batch
from simcalib.solvers.single import solve_single

__all__ = ["RobustSolution", "screw_residuals", "screw_terms", "residuals_of_terms",
           "noise_threshold",
           "ransac", "irls", "robust_solve", "constraint_errors", "ROBUST_METHODS",
           "inlier_scores"]


@dataclass(frozen=True, eq=False)
class RobustSolution:
    """Result of a robust solve.

    ``X``: estimate of ``T_a_b``; ``solution``: the final :class:`simcalib.Solution` (dqopt on
    the inliers for RANSAC, the last weighted solve for IRLS, all motions for ``none``);
    ``inlier_mask`` (N,) bool; ``weights`` (N,) float (0/1 for RANSAC); ``residuals`` (N,)
    per-motion screw residuals at ``X`` (:func:`screw_residuals`); ``threshold``: the inlier
    threshold used (same units); ``method``; ``iterations``: hypotheses drawn (RANSAC) or
    re-weighting rounds (IRLS); ``message``.
    """
    X: np.ndarray
    solution: object
    inlier_mask: np.ndarray
    weights: np.ndarray
    residuals: np.ndarray
    threshold: float
    method: str
    iterations: int
    message: str = ""
    diagnostics: dict = field(default_factory=dict, repr=False)

    @property
    def n_inliers(self) -> int:
        return int(self.inlier_mask.sum())

    @property
    def inlier_fraction(self) -> float:
        return float(self.inlier_mask.mean()) if self.inlier_mask.size else float("nan")


# --------------------------------------------------------------------------- residuals
def _motion_dq(C, H):
    qC, qCd = dual_quat_from_transform(C)
    qH, qHd = dual_quat_from_transform(H)
    return qC, qCd, qH, qHd


def _motion_matrices(C, H) -> tuple:
    """``L(q_C), L(q_C'), R(q_H), R(q_H')`` (N, 4, 4) each: what :func:`screw_residuals`
    needs of the motions (computed once per robust fit, not per hypothesis)."""
    qC, qCd, qH, qHd = _motion_dq(C, H)
    return (quat_left_matrix(qC), quat_left_matrix(qCd), quat_right_matrix(qH),
            quat_right_matrix(qHd))


def screw_residuals(C, H, X, alpha: float = 1.0) -> np.ndarray:
    """Per-motion screw-constraint residuals ``(..., N)`` of ``C_i X = X H_i`` for one
    ``X`` (4, 4) or a batch ``(B, 4, 4)`` (result ``(B, N)``); see the module docstring."""
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    if C.ndim != 3 or C.shape[1:] != (4, 4) or H.shape != C.shape:
        raise ValueError(f"C and H must both have shape (N, 4, 4); received {C.shape}, {H.shape}")
    if X.shape[-2:] != (4, 4) or X.ndim not in (2, 3):
        raise ValueError(f"X must have shape (4, 4) or (B, 4, 4); received {X.shape}")
    return _residuals(_motion_matrices(C, H), X, alpha)


def screw_terms(C, H) -> tuple:
    """The motions' part of :func:`screw_residuals` (``L(q_C), L(q_C'), R(q_H), R(q_H')``,
    (N, 4, 4) each), for scoring many X's on subsets of the same motions without converting
    them again: ``residuals_of_terms(tuple(t[idx] for t in terms), X, alpha)``."""
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    if C.ndim != 3 or C.shape[1:] != (4, 4) or H.shape != C.shape:
        raise ValueError(f"C and H must both have shape (N, 4, 4); received {C.shape}, {H.shape}")
    return _motion_matrices(C, H)


def residuals_of_terms(terms: tuple, X, alpha: float = 1.0) -> np.ndarray:
    """:func:`screw_residuals` from the motions' :func:`screw_terms` (the same numbers)."""
    return _residuals(terms, X, alpha)


def _residuals(mats: tuple, X, alpha: float) -> np.ndarray:
    """:func:`screw_residuals` from the motions' :func:`_motion_matrices`."""
    LC, LCd, RH, RHd = mats
    qX, qXd = dual_quat_from_transform(np.asarray(X, dtype=np.float64))
    # q_C (x) q_X and q_X (x) q_H as (..., N, 4)
    a = np.einsum("nij,...j->...ni", LC, qX)
    b = np.einsum("nij,...j->...ni", RH, qX)
    ad = np.einsum("nij,...j->...ni", LCd, qX) + np.einsum("nij,...j->...ni", LC, qXd)
    bd = np.einsum("nij,...j->...ni", RHd, qX) + np.einsum("nij,...j->...ni", RH, qXd)
    plus = np.sum((a - b) ** 2, -1) + alpha**2 * np.sum((ad - bd) ** 2, -1)
    minus = np.sum((a + b) ** 2, -1) + alpha**2 * np.sum((ad + bd) ** 2, -1)
    return np.sqrt(np.minimum(plus, minus))


def constraint_errors(C, H, X) -> tuple[np.ndarray, np.ndarray]:
    """Per-motion errors of ``C_i X = X H_i`` in plain units: rotation angle (rad) and
    translation norm (m) of ``(C_i X)^-1 (X H_i)`` (pose of b predicted from a vs. from b)."""
    from simcalib.geometry import invert_transform, rotation_angle_rad
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    E = invert_transform(C @ X) @ (X @ H)
    return rotation_angle_rad(E[..., :3, :3]), np.linalg.norm(E[..., :3, 3], axis=-1)


def noise_threshold(C, H, sigma_r_rad: float, sigma_t_m: float, alpha: float = 1.0,
                    k: float = 3.0) -> float:
    """Inlier threshold from the pose noise (paper eq. 38 on every pose of C and H): ``k``
    times the expected residual of a clean motion, first order:
    ``E r^2 ~ sigma_r^2/2 + alpha^2 (3 sigma_t^2/2 + sigma_r^2 mean(|t_C|^2+|t_H|^2)/16)``."""
    for name, v in (("sigma_r_rad", sigma_r_rad), ("sigma_t_m", sigma_t_m)):
        if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be finite and >= 0; received {v!r}")
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    t2 = float(np.mean(np.sum(C[:, :3, 3] ** 2, -1) + np.sum(H[:, :3, 3] ** 2, -1)))
    e2 = sigma_r_rad**2 / 2 + alpha**2 * (1.5 * sigma_t_m**2 + sigma_r_rad**2 * t2 / 16)
    return float(k * math.sqrt(e2))


def inlier_scores(inlier_mask, true_inliers) -> dict:
    """Precision and recall of an inlier mask against ground-truth labels."""
    m = np.asarray(inlier_mask, dtype=bool)
    g = np.asarray(true_inliers, dtype=bool)
    tp = int((m & g).sum())
    return {"precision": tp / max(int(m.sum()), 1), "recall": tp / max(int(g.sum()), 1),
            "true_positives": tp, "n_inliers": int(m.sum()), "n_true_inliers": int(g.sum())}


# ------------------------------------------------------------------------------ RANSAC
def _check_problem(C, H):
    C = check_transforms(C, "C", min_count=2)
    H = check_transforms(H, "H", min_count=2)
    if C.shape != H.shape:
        raise ValueError(f"C and H must have the same shape (N, 4, 4); received {C.shape} "
                         f"and {H.shape}")
    return C, H


def _draw_minimal_sets(rng, axes, n_sets, sample_size, min_axis_angle_rad):
    N = axes.shape[0]
    keys = rng.random((n_sets, N))
    sets = _two_smallest(keys) if sample_size == 2 else None
    if sets is None:
        sets = np.argpartition(keys, sample_size - 1, axis=1)[:, :sample_size]
    if sample_size >= 2:
        a0, a1 = axes[sets[:, 0]], axes[sets[:, 1]]
        ok = np.linalg.norm(np.cross(a0, a1), axis=-1) > math.sin(min_axis_angle_rad)
        sets = sets[ok]
    return sets


def _two_smallest(keys: np.ndarray) -> np.ndarray | None:
    """``np.argpartition(keys, 1, axis=1)[:, :2]`` (each row's smallest key's position,
    then the second smallest's) by two passes of ``argmin`` (``argpartition`` costs ~10x
    more on a few hundred keys a row); None when a row's two smallest keys are not unique
    (a tie: which position ``argpartition`` puts first is its own)."""
    rows = np.arange(keys.shape[0])
    k0 = np.argmin(keys, axis=1)
    rest = keys.copy()
    rest[rows, k0] = np.inf
    k1 = np.argmin(rest, axis=1)
    second = rest[rows, k1]
    if not (bool(np.all(keys[rows, k0] < second))
            and bool(np.all(np.sum(keys <= second[:, None], axis=1) == 2))):
        return None
    return np.stack([k0, k1], axis=1)


def _auto_threshold(r: np.ndarray, p: int, k: float = 2.5) -> float:
    """Robust scale (LMedS, Rousseeuw) of the residuals of a good hypothesis, times ``k``."""
    n = r.size
    s0 = 1.4826 * (1.0 + 5.0 / max(n - p, 1)) * float(np.median(r))
    return k * s0


def ransac(C, H, *, alpha: float = 1.0, threshold: float | None = None,
           noise: tuple | None = None, minimal_method: str = "dqopt",
           final_method: str = "dqopt", max_iterations: int = 1000, confidence: float = 0.999,
           sample_size: int = 2, min_axis_angle_deg: float = 10.0,
           rng: np.random.Generator | None = None) -> RobustSolution:
    """RANSAC over motions, then ``final_method`` (dqopt) on the inliers.

    ``threshold``: inlier threshold on :func:`screw_residuals`; else ``noise=(sigma_r_rad,
    sigma_t_m)`` gives it (:func:`noise_threshold`); else automatic: hypotheses are scored by
    the median residual (least median of squares) and the threshold is 2.5 robust sigmas of
    the best one. Minimal sets: ``sample_size`` motions (2 = minimal) whose first two rotation
    axes differ by more than ``min_axis_angle_deg``, solved in one ``solve_batch`` call
    (``minimal_method``). Iterations adapt to the inlier ratio (``confidence``), at most
    ``max_iterations``. The best consensus is refined (dqopt on its inliers, re-thresholded)
    until stable. ``rng``: Generator (default ``default_rng(0)``).
    """
    C, H, rng = _check_ransac_inputs(C, H, rng, sample_size)
    _check_ransac_options(threshold, noise, max_iterations, confidence, min_axis_angle_deg)
    given = threshold is not None
    threshold = _ransac_threshold(C, H, threshold, noise, alpha)
    auto = threshold is None
    axes, kind = _set_axes(C, H)
    sample_size, min_axis, note = _minimal_set_plan(rng, axes, sample_size, min_axis_angle_deg,
                                                    kind)
    mats = _motion_matrices(C, H)
    best_X, iters = _best_hypothesis(C, H, mats, rng, axes, sample_size, min_axis, threshold,
                                     alpha, minimal_method, max_iterations, confidence)
    X, final, mask, r, thr = _refine_consensus(C, H, mats, best_X, threshold, alpha,
                                               final_method)
    msg = _ransac_message(mask, thr, auto, noise is not None and not given, iters,
                          sample_size, final_method, note)
    return RobustSolution(X=X, solution=final, inlier_mask=mask,
                          weights=mask.astype(np.float64), residuals=r, threshold=float(thr),
                          method="ransac", iterations=iters, message=msg)


def _check_ransac_inputs(C, H, rng, sample_size) -> tuple:
    """The checked ``(C, H, rng)`` (rng default ``default_rng(0)``), ``sample_size`` checked."""
    C, H = _check_problem(C, H)
    N = C.shape[0]
    if rng is None:
        rng = np.random.default_rng(0)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    if N < 4:
        raise ValueError(f"RANSAC needs at least 4 motions; received {N}")
    if isinstance(sample_size, bool) or not isinstance(sample_size, (int, np.integer)) \
            or not 2 <= sample_size < N:
        raise ValueError(f"sample_size must be an integer in [2, N-1] (N = {N}); "
                         f"received {sample_size!r}")
    return C, H, rng


def _is_real(v) -> bool:
    """A real number (not a bool)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _check_ransac_options(threshold, noise, max_iterations, confidence, min_axis_angle_deg):
    """Raise on a threshold, noise, iteration budget, confidence or axis angle out of range."""
    if threshold is not None and not _is_real(threshold):
        raise TypeError(f"threshold must be a number or None; received "
                        f"{type(threshold).__name__}")
    if noise is not None and not (isinstance(noise, (tuple, list, np.ndarray))
                                  and len(noise) == 2):
        raise ValueError(f"noise must be (sigma_r_rad, sigma_t_m) or None; received {noise!r}")
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)) \
            or max_iterations < 1:
        raise ValueError(f"max_iterations must be an integer >= 1; received {max_iterations!r}")
    if not (_is_real(confidence) and 0 < confidence < 1):
        raise ValueError(f"confidence must be in (0, 1); received {confidence!r}")
    if not (_is_real(min_axis_angle_deg) and 0 <= min_axis_angle_deg < 90):
        raise ValueError(f"min_axis_angle_deg must be in [0, 90); received "
                         f"{min_axis_angle_deg!r}")


def _ransac_threshold(C, H, threshold, noise, alpha) -> float | None:
    """The inlier threshold: given, else from ``noise``, else None (automatic)."""
    if threshold is None and noise is not None:
        threshold = noise_threshold(C, H, *noise, alpha=alpha)
    if threshold is not None and not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold must be finite and > 0; received {threshold!r}")
    return threshold


def _rotation_axes(C) -> np.ndarray:
    """Unit rotation axes ``(N, 3)`` of the motions ``C`` (zero rotations: the zero vector)."""
    rv = rotvec_from_matrix(C[:, :3, :3])
    ang = np.linalg.norm(rv, axis=-1)
    return rv / np.where(ang > 1e-12, ang, 1.0)[:, None]


def _set_axes(C, H) -> tuple[np.ndarray, str]:
    """``(axes, kind)``: the directions the minimal sets must spread: the motions' rotation
    axes (``kind`` "rotation"), or, where no motion rotates beyond the pose noise (pure
    translation, :func:`simcalib.solvers.problem.rotation_shortfall`: the axes are noise),
    their translation directions ("translation": two non-parallel translations fix X's
    rotation, ``t_C = R_X t_H``)."""
    from simcalib.solvers.problem import rotation_shortfall
    if rotation_shortfall(C, H) is None:
        return _rotation_axes(C), "rotation"
    t = C[:, :3, 3]
    d = np.linalg.norm(t, axis=-1)
    return t / np.where(d > 0, d, 1.0)[:, None], "translation"


def _minimal_set_plan(rng, axes, sample_size, min_axis_angle_deg, kind="rotation") -> tuple:
    """``(sample_size, min_axis_rad, note)`` of the minimal sets, from a probe of 256 pairs
    (``kind``: what ``axes`` are, rotation axes or translation directions)."""
    N = axes.shape[0]
    min_axis = math.radians(min_axis_angle_deg)
    note = ""
    probe = _draw_minimal_sets(rng, axes, 256, 2, min_axis)
    if probe.shape[0] < 0.05 * 256:
        # nearly parallel rotation axes everywhere: 2-motion sets are (close to) degenerate;
        # use larger unfiltered sets so that each hypothesis is determined
        sample_size = max(sample_size, min(6, N - 1))
        min_axis = 0.0
        note = (f"; only {probe.shape[0]}/256 motion pairs have {kind} "
                f"{'axes' if kind == 'rotation' else 'directions'} > "
                f"{min_axis_angle_deg:g} deg apart (near-degenerate motion): minimal sets of "
                f"{sample_size} motions, axis filter off")
    elif kind == "translation":
        note = ("; no motion rotates beyond the noise (pure translation): minimal sets of "
                "motions with translations apart")
    return sample_size, min_axis, note


def _best_hypothesis(C, H, mats, rng, axes, sample_size, min_axis, threshold, alpha,
                     minimal_method, max_iterations, confidence) -> tuple:
    """``(X, hypotheses drawn)`` of the best-scoring minimal-set solve (threshold None: LMedS)."""
    N = C.shape[0]
    best_score, best_X, iters, needed = -math.inf, None, 0, max_iterations
    batch = 64
    while iters < min(needed, max_iterations):
        sets = _draw_minimal_sets(rng, axes, batch, sample_size, min_axis)
        iters += batch
        if sets.shape[0] == 0:
            continue
        sol = solve_batch(C[sets], H[sets], method=minimal_method, alpha=alpha)
        Xs = sol.X[sol.success]
        if Xs.shape[0] == 0:
            continue
        r = _chunked_residuals(mats, Xs, alpha)                      # (B, N)
        score = _hypothesis_scores(r, threshold)
        k = int(np.argmax(score))
        if score[k] > best_score:
            best_score, best_X = float(score[k]), Xs[k]
            needed = _hypotheses_needed(r[k], threshold, N, sample_size, confidence, batch)
    if best_X is None:
        raise SolverError("RANSAC found no usable minimal set (are all rotation axes "
                         "parallel? such motions do not determine X)")
    return best_X, iters


def _chunked_residuals(mats: tuple, Xs: np.ndarray, alpha: float) -> np.ndarray:
    """:func:`_residuals` of hypotheses ``Xs (B, 4, 4)``, a few at a time when the motions
    are many (each hypothesis' temporaries hold ~24 numbers per motion: 64 hypotheses of
    140,000 motions would take ~2 GB at once)."""
    step = max(1, _RESIDUAL_BLOCK // max(mats[0].shape[0], 1))
    if step >= Xs.shape[0]:
        return _residuals(mats, Xs, alpha)
    return np.concatenate([_residuals(mats, Xs[i:i + step], alpha)
                           for i in range(0, Xs.shape[0], step)])


#: motions x hypotheses whose residuals RANSAC computes at once
_RESIDUAL_BLOCK = 2_000_000


def _hypothesis_scores(r: np.ndarray, threshold) -> np.ndarray:
    """Score per hypothesis from residuals ``(B, N)``: -median (threshold None), else inliers."""
    if threshold is None:
        return -np.median(r, axis=1)
    return (r < threshold).sum(axis=1) - 1e-9 * np.minimum(r, threshold).sum(axis=1)


def _hypotheses_needed(r: np.ndarray, threshold, N: int, sample_size, confidence: float,
                       batch: int) -> int:
    """Hypotheses needed for ``confidence`` at the inlier ratio of residuals ``r`` (N,)."""
    if threshold is None:
        w = 0.5     # LMedS: plan for the 50 % breakdown point
    else:
        w = max(float((r < threshold).mean()), 1.0 / N)
    p_good = w ** sample_size
    if not 0 < p_good < 1:
        return batch
    den = math.log(1 - p_good)
    if den == 0.0:              # 1 - p_good rounds to 1: log1p keeps the tiny p_good
        den = math.log1p(-p_good)
    return int(min(math.ceil(math.log(1 - confidence) / den), 2**62))


def _refine_consensus(C, H, mats, X, threshold, alpha, final_method) -> tuple:
    """``(X, Solution, inliers, residuals, threshold)`` of ``final_method`` on stable inliers."""
    auto = threshold is None
    # local optimisation: dqopt on the inliers until the set is stable
    r = _residuals(mats, X, alpha)
    thr = _auto_threshold(r, 6) if auto else threshold
    mask = r < thr
    final = None
    for _ in range(10):
        if mask.sum() < 3:
            break
        final = solve_single(C[mask], H[mask], method=final_method, alpha=alpha)
        X = final.X
        r = _residuals(mats, X, alpha)
        if auto:
            thr = _auto_threshold(r[mask], 6)
        new = r < thr
        if np.array_equal(new, mask):
            break
        mask = new
    if final is None or mask.sum() < 3:
        raise SolverError(f"RANSAC consensus has only {int(mask.sum())} motions "
                         f"(threshold {thr:.3g}); give a larger threshold or check the data")
    return X, final, mask, r, thr


def _ransac_message(mask, thr, auto, from_noise, iters, sample_size, final_method,
                    note) -> str:
    """The one-line summary of a RANSAC result (``from_noise``: threshold from the noise)."""
    N = mask.size
    msg = (f"RANSAC: {int(mask.sum())}/{N} inliers ({mask.mean():.0%}), threshold "
           f"{thr:.3g} ({'auto, LMedS scale' if auto else ('from noise' if from_noise else 'given')}), "
           f"{iters} hypotheses of {sample_size} motions; {final_method} on the inliers{note}")
    return msg


# -------------------------------------------------------------------------------- IRLS
_LOSSES = {
    "huber": (1.345, lambda z, c: np.minimum(1.0, c / np.maximum(z, 1e-300))),
    "cauchy": (2.385, lambda z, c: 1.0 / (1.0 + (z / c) ** 2)),
    "tukey": (4.685, lambda z, c: np.where(z < c, (1 - (z / c) ** 2) ** 2, 0.0)),
}


def irls(C, H, *, alpha: float = 1.0, loss: str = "cauchy", scale: float | None = None,
         method: str = "dqopt", init="ransac", max_iterations: int = 50, tol: float = 1e-10,
         inlier_weight: float = 0.5, rng: np.random.Generator | None = None) -> RobustSolution:
    """Iteratively re-weighted dqopt: ``w_i = rho'(r_i/s)/(r_i/s)`` for ``loss`` (``huber``,
    ``cauchy``, ``tukey``, standard tuning constants) with ``s`` = ``scale`` or 1.4826 x the
    weighted median residual, re-solved with ``solve_single(C, H, method, alpha,
    weights=w)`` until ``X`` changes by less than ``tol``. ``init``: ``"ransac"`` (default;
    re-weighting from a least-squares start can lock onto the outliers),
    ``"none"`` (unweighted start) or a 4x4 ``X``. Inliers: ``w >= inlier_weight``.
    """
    if loss not in _LOSSES:
        raise unknown_choice("IRLS loss", loss, _LOSSES, key="loss")
    C, H = _check_problem(C, H)
    c, wfun = _LOSSES[loss]
    if isinstance(init, str) and init == "ransac":
        X = ransac(C, H, alpha=alpha, rng=rng).X
    elif isinstance(init, str) and init == "none":
        X = solve_single(C, H, method=method, alpha=alpha).X
    else:
        X = check_transforms(init, "init")
        if X.shape != (4, 4):
            raise ValueError(f"init must be 'ransac', 'none' or one 4x4 X; received {X.shape}")
    sol = None
    mats = _motion_matrices(C, H)
    w = np.ones(C.shape[0])
    it = 0
    for it in range(1, max_iterations + 1):
        r = _residuals(mats, X, alpha)
        s = scale if scale is not None else 1.4826 * float(np.median(r[w > 0.5 * w.max()]))
        s = max(s, 1e-15)
        w = wfun(r / s, c)
        sol = solve_single(C, H, method=method, alpha=alpha, weights=w)
        dX = float(np.abs(sol.X - X).max())
        X = sol.X
        if dX < tol:
            break
    r = _residuals(mats, X, alpha)
    mask = w >= inlier_weight
    return RobustSolution(X=X, solution=sol, inlier_mask=mask, weights=w, residuals=r,
                          threshold=float(s * c), method="irls", iterations=it,
                          message=f"IRLS ({loss}, scale {s:.3g}): {it} rounds, "
                                  f"{int(mask.sum())}/{C.shape[0]} motions with weight >= "
                                  f"{inlier_weight}")


# ---------------------------------------------------------------------------- registry
def _none(C, H, *, alpha: float = 1.0, method: str = "dqopt", **_):
    C, H = _check_problem(C, H)
    sol = solve_single(C, H, method=method, alpha=alpha)
    r = screw_residuals(C, H, sol.X, alpha)
    n = C.shape[0]
    return RobustSolution(X=sol.X, solution=sol, inlier_mask=np.ones(n, bool),
                          weights=np.ones(n), residuals=r, threshold=math.inf, method="none",
                          iterations=0, message=f"no outlier rejection ({method} on all {n})")


ROBUST_METHODS = {"none": _none, "ransac": ransac, "irls": irls}


def robust_solve(C, H, robust: str = "ransac", **options) -> RobustSolution:
    """Dispatch to a robust method by name (``none``, ``ransac``, ``irls``)."""
    if robust not in ROBUST_METHODS:
        raise unknown_choice("robust method", robust, ROBUST_METHODS, key="robust")
    return ROBUST_METHODS[robust](C, H, **options)
