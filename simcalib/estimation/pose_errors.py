"""The covariance of X from the errors of the POSES, white or correlated, as the residuals
show them.

Why. The solver's covariance treats the motions' errors as white. Motions formed from a
recording share its poses (every pair of 30 stations: 435 motions from 30 poses' errors),
and real pose errors are neither white nor independent: a robot's kinematic error and a
target's calibration error vary smoothly over the workspace, SLAM drifts, interpolation
correlates neighbours. Here the error model lives where the errors arise, on the poses.

Residuals. With X and the fixed transform between the two worlds ``Y = T_wa_wb``
(:func:`fit_world`; one per stretch of the worlds where a world frame jumps:
:func:`world_transforms`, :mod:`simcalib.estimation.world_jumps`), pose ``i`` of b
predicted from a is ``Y^-1 T_a[i] X``; the residual is the right-multiplied error of b
that explains the measurement,
``r_i = (rotvec, t)`` of ``(Y^-1 T_a[i] X)^-1 T_b[i]`` (b's frame). Errors of a enter the
motions only through the same combination, so ``r`` carries both streams' errors.

Sensitivity. X is the minimiser of the alpha cost of the motions; to first order its
change under pose errors ``r`` is ``delta X = sum_i G_i r_i`` (:func:`pose_sensitivity`,
``G_i`` 6x6, exact derivative of the Gauss-Newton step of the cost, for whatever motions
were formed: all pairs of stations, consecutive motions, keyframes).

Error model (:func:`fit_error_model`). ``Cov(r_i, r_j) = W [i = j] + P rho(d_ij / l_p) +
T rho(|i - j| / l_t)``: a white part ``W``, a part correlated over the pose space ``P``
(``d_ij``: rotation angle in rad plus translation in units of the workspace's RMS radius,
of a's poses) and a part correlated along the recording ``T`` (index distance), ``rho(x)
= exp(-x^2 / 2)``; ``W, P, T`` (6x6) and the ranges are fitted to the residuals' matrix
variogram ``E[(r_i - r_j)(r_i - r_j)^T] / 2`` (which an error common to every pose does not
change). Then

    Cov(X) = sum_i G_i W G_i^T + sum_ij rho_ij G_i P G_j^T + ...

which keeps the correlated parts' share that does not average down with the number of
poses: an error common to all poses moves X and leaves no residual; the fitted correlation
says how large it is likely to be (the stationary model's extrapolation, bounded: the
ranges are searched up to the data's own extent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import (chordal_mean_rotation, dual_quat_from_transform,
                               invert_transform, quat_conjugate, quat_from_matrix,
                               rotvec_from_matrix)

__all__ = ["fit_world", "world_transforms", "pose_residuals", "pose_sensitivity",
           "body_velocities", "noise_determined", "pose_coordinates", "pose_distances",
           "PairDesign", "pair_design",
           "ErrorModel", "fit_error_model", "model_covariance", "psd", "neighbour_pairs",
           "neighbour_correlation", "MAX_PAIRS_POSES", "TIME_LAGS", "KERNEL_BLOCKS",
           "ALL_DISTANCES_POSES"]

#: poses whose every pair enters the variogram fit (beyond: an even subsample of them)
MAX_PAIRS_POSES = 150
#: recording lags whose every pair enters the fit as well (the short range)
TIME_LAGS = 16
_N_GRID = 8


def _log6(T) -> np.ndarray:
    return np.concatenate([rotvec_from_matrix(T[..., :3, :3]), T[..., :3, 3]], axis=-1)


def fit_world(T_a, T_b, X) -> np.ndarray:
    """``Y = T_wa_wb`` that best maps b's world into a's given ``X``: the chordal mean of
    the per-pose ``T_a X T_b^-1`` rotations and the mean of their translations."""
    Yi = T_a @ X[None] @ invert_transform(T_b)
    Y = np.eye(4)
    Y[:3, :3] = chordal_mean_rotation(Yi[:, :3, :3])
    Y[:3, 3] = Yi[:, :3, 3].mean(axis=0)
    return Y


def pose_residuals(T_a, T_b, X, Y=None, world=None) -> tuple[np.ndarray, np.ndarray]:
    """``(r, Y)``: the per-pose residuals ``(n, 6)`` (rotvec rad, translation m; b's frame;
    module doc) and the world-to-world transform used (fitted when ``Y`` is None).
    ``world`` (n,): the stretch of the streams' worlds of each pose
    (:mod:`simcalib.estimation.world_jumps`): ``Y`` is fitted per stretch and returned per
    pose ``(n, 4, 4)``; None: one world."""
    T_a, T_b = np.asarray(T_a, np.float64), np.asarray(T_b, np.float64)
    if world is not None and Y is None:
        Y = world_transforms(T_a, T_b, X, world)
    if Y is None:
        Y = fit_world(T_a, T_b, X)
    predicted = invert_transform(Y) @ T_a @ X[None] if Y.ndim == 3 else \
        invert_transform(Y)[None] @ T_a @ X[None]
    return _log6(invert_transform(predicted) @ T_b), Y


def world_transforms(T_a, T_b, X, world) -> np.ndarray:
    """``(n, 4, 4)``: each pose's ``T_wa_wb`` (:func:`fit_world`), fitted on the poses of
    its stretch of the worlds (``world`` (n,): one int per pose)."""
    Y = np.empty((np.asarray(T_a).shape[0], 4, 4))
    for w in np.unique(world):
        m = world == w
        Y[m] = fit_world(T_a[m], T_b[m], X)
    return Y


def _signed_dq(C, H, X):
    from simcalib.geometry import quat_multiply as qm
    qC, qCd = dual_quat_from_transform(C)
    qH, qHd = dual_quat_from_transform(H)
    qX, _ = dual_quat_from_transform(X)
    fit = np.sum(qm(qC, np.broadcast_to(qX, qC.shape)) * qm(np.broadcast_to(qX, qH.shape), qH),
                 axis=-1)
    s = np.where(fit < 0, -1.0, 1.0)[:, None]
    return qC, qCd, qH * s, qHd * s


def pose_sensitivity(C, H, X, alpha: float, pose_pairs, n_poses: int,
                     weights=None, eps: float = 1e-6) -> np.ndarray:
    """``G`` (n_poses, 6, 6): the first-order change of the alpha-cost minimiser ``X``
    (``pose_error(X', X)`` coordinates) per right-multiplied error ``(rotvec, t)`` of b's
    pose ``k`` (``H = T_b[i]^-1 T_b[j]`` for ``pose_pairs`` rows ``(i, j)``): the derivative
    of the Gauss-Newton step of the cost, by finite differences of each motion's Gram
    term (a pose no motion uses gets zeros)."""
    from simcalib.solvers.diagnostics.pose_noise import _dq_from_xi, _dq_mul, _gram, \
        _q_and_jacobian
    C, H, X = (np.asarray(a, np.float64) for a in (C, H, X))
    P = np.asarray(pose_pairs, dtype=np.int64)
    w = np.ones(C.shape[0]) if weights is None else np.asarray(weights, np.float64)
    qC, qCd, qH, qHd = _signed_dq(C, H, X)
    Q, D = _q_and_jacobian(X)
    Hm = D.T @ _gram(qC, qCd, qH, qHd, alpha, w) @ D
    Hm = Hm + 1e-12 * np.trace(Hm) / 6.0 * np.eye(6)

    def each(h, hd):                      # per-motion Gram terms times Q: (N, 8)
        return _gram(qC[:, None], qCd[:, None], h[:, None], hd[:, None], alpha,
                     w[:, None]) @ Q
    g0 = each(qH, qHd)
    d_start, d_end = np.zeros((C.shape[0], 8, 6)), np.zeros((C.shape[0], 8, 6))
    for k in range(6):
        xi = np.zeros(6)
        xi[k] = eps
        e, ed = (np.broadcast_to(v, qH.shape) for v in _dq_from_xi(xi))
        d_start[:, :, k] = (each(*_dq_mul(quat_conjugate(e), quat_conjugate(ed), qH, qHd))
                            - g0) / eps
        d_end[:, :, k] = (each(*_dq_mul(qH, qHd, e, ed)) - g0) / eps
    M = -np.linalg.solve(Hm, D.T)                                   # (6, 8)
    G = np.zeros((int(n_poses), 6, 6))
    np.add.at(G, P[:, 0], np.einsum("ij,njk->nik", M, d_start))
    np.add.at(G, P[:, 1], np.einsum("ij,njk->nik", M, d_end))
    return G


def body_velocities(T, time_s, world=None) -> np.ndarray:
    """``(n, 6)`` body-frame twists ``(omega, v)`` (rad/s, m/s; the right-multiplied
    convention of :func:`pose_residuals`) of poses ``T`` at ``time_s`` by central
    differences (one-sided at the ends, and at the ends of a stretch of the worlds:
    ``world`` (n,), None: one world); 0 where two stamps coincide."""
    T = np.asarray(T, np.float64)
    t = np.asarray(time_s, np.float64)
    n = T.shape[0]
    if n < 2:
        return np.zeros((n, 6))
    lo = np.maximum(np.arange(n) - 1, 0)
    hi = np.minimum(np.arange(n) + 1, n - 1)
    if world is not None:
        lo = np.where(world[lo] == world, lo, np.arange(n))
        hi = np.where(world[hi] == world, hi, np.arange(n))
    dt = t[hi] - t[lo]
    d = _log6(invert_transform(T[lo]) @ T[hi])
    return np.where(dt[:, None] > 0, d / np.where(dt > 0, dt, 1.0)[:, None], 0.0)


def noise_determined(C, H, X, alpha: float, pose_pairs, residuals, index, basis, *,
                     draws: int = 16, z: float = 3.09) -> np.ndarray:
    """Directions of X (delta coordinates, unit columns, within ``basis``) that the data
    determine no better than the pose errors alone would: errors in the variables. Along
    a direction the motions leave undetermined (every rotation about one axis: the
    translation along it), the measured motions still carry information, made by their
    own errors; adding one more dose of such errors adds as much again. The dose: the
    pose ``residuals`` (n, 6) at recording positions ``index`` (the ``pose_pairs``'
    numbering), shifted circularly along the recording by ``k / (draws + 1)`` of its
    length, sign alternating (errors with the recording's own size, serial correlation and
    mix, for ``draws`` doses; deterministic). The generalised eigenvalues ``rho`` of the
    cost's Hessian at X against the mean increase ``E[dHm]`` are ~1 there and ~1 /
    error^2 elsewhere; a direction is noise-determined when ``rho`` is within ``z``
    spreads of the doses' own ratio (one dose against the mean dose) above 1."""
    from simcalib.solvers.diagnostics.pose_noise import _dq_from_xi, _gram, _perturb, \
        _q_and_jacobian
    B = np.asarray(basis, np.float64)
    r = np.asarray(residuals, np.float64)
    if B.shape[1] == 0 or r.shape[0] < 3:
        return np.zeros((6, 0))
    P = np.asarray(pose_pairs, dtype=np.int64)
    w = np.ones(P.shape[0])
    qC, qCd, qH, qHd = _signed_dq(np.asarray(C), np.asarray(H), np.asarray(X))
    DB = _q_and_jacobian(np.asarray(X))[1] @ B
    Hm = DB.T @ _gram(qC, qCd, qH, qHd, alpha, w) @ DB
    n = r.shape[0]
    dH = np.empty((draws,) + Hm.shape)
    for k in range(draws):          # one dose at a time: (draws, N, 4, 4) stacks are GBs
        eta = np.zeros((1, int(P.max()) + 1, 6))
        eta[0, np.asarray(index)] = (-1.0) ** k * np.roll(r, ((k + 1) * n) // (draws + 1), 0)
        qh, qhd = _perturb(qH, qHd, P, _dq_from_xi(eta))
        dH[k] = np.einsum("ia,kab,bj->kij", DB.T,
                          _gram(qC[None], qCd[None], qh, qhd, alpha, w[None]), DB)[0] - Hm
    mean = dH.mean(axis=0)
    lam, V = np.linalg.eigh(0.5 * (Hm + Hm.T))
    Wh = V / np.sqrt(np.maximum(lam, 1e-300))             # Wh^T Hm Wh = I
    mu, U = np.linalg.eigh(Wh.T @ (0.5 * (mean + mean.T)) @ Wh)   # mu = 1 / rho
    out = []
    for k in range(mu.size):
        g = Wh @ U[:, k]
        dose = np.einsum("i,kij,j->k", g, dH, g) / float(g @ mean @ g) if mu[k] > 0 else None
        if dose is not None and 1.0 / mu[k] <= 1.0 + z * float(np.std(dose, ddof=1)):
            v = B @ g
            out.append(v / np.linalg.norm(v))
    return np.array(out).T if out else np.zeros((6, 0))


# ------------------------------------------------------------------------- distances
def pose_coordinates(T) -> tuple[np.ndarray, np.ndarray]:
    """``(q, p)``: unit quaternions and positions scaled by the workspace's RMS radius (the
    pose-space metric of :func:`pose_distances`)."""
    T = np.asarray(T, np.float64)
    p = T[:, :3, 3]
    L = math.sqrt(float(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1))))
    return quat_from_matrix(T[:, :3, :3]), (p / L if L > 1e-9 else np.zeros_like(p))


def pose_distances(qa, pa, qb, pb) -> np.ndarray:
    """Pose-space distances between two sets of :func:`pose_coordinates` (all pairs):
    ``sqrt(angle^2 + |dp|^2)`` (rad; positions in workspace radii)."""
    ang = 2.0 * np.arccos(np.clip(np.abs(qa @ qb.T), 0.0, 1.0))
    dp2 = np.sum(pa ** 2, 1)[:, None] + np.sum(pb ** 2, 1)[None] - 2.0 * pa @ pb.T
    return np.sqrt(ang ** 2 + np.maximum(dp2, 0.0))


def _pairs(m: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Pairs ``(a, b)`` of residual positions ``0..m-1``: every pair among an even
    subsample of at most :data:`MAX_PAIRS_POSES` (the first ``k`` pairs: they span the
    data's extent), and every pair at most :data:`TIME_LAGS` apart in the recording (the
    short range)."""
    sub = np.unique(np.linspace(0, m - 1, min(m, MAX_PAIRS_POSES)).round().astype(np.int64))
    a, b = np.triu_indices(sub.size, 1)
    pa, pb = [sub[a]], [sub[b]]
    for k in range(1, min(TIME_LAGS, m - 1) + 1):
        pa.append(np.arange(m - k))
        pb.append(np.arange(k, m))
    return np.concatenate(pa), np.concatenate(pb), int(a.size)


def neighbour_pairs(T_a, k_pose: int = 3, k_time: int = 2) -> dict:
    """Pairs ``(a, b)`` of neighbouring poses (positions ``0..n-1``, each pair once):
    ``"pose"``: each pose with its ``k_pose`` nearest in the pose space; ``"time"``: each
    with the ``k_time`` next in the recording."""
    q, p = pose_coordinates(T_a)
    n = q.shape[0]
    k = min(k_pose, n - 1)
    nb = _nearest_poses(q, p, k)
    P = np.unique(np.sort(np.stack([np.repeat(np.arange(n), k), nb.ravel()], 1), axis=1),
                  axis=0)
    ks = range(1, min(k_time, n - 1) + 1)
    T = (np.concatenate([np.arange(n - k) for k in ks]),
         np.concatenate([np.arange(k, n) for k in ks]))
    return {"pose": (P[:, 0], P[:, 1]), "time": T}


#: up to this many poses the nearest are found among all distances, row by row (no k-d
#: tree: importing scipy's spatial package costs ~0.05-0.1 s, and below ~1000 poses the
#: search over all is no slower than the tree's)
ALL_DISTANCES_POSES = 1000


def _nearest_poses(q, p, k: int) -> np.ndarray:
    """``(n, k)`` indices of each pose's ``k`` nearest other poses in the metric of
    :func:`pose_distances`, exactly (ties: the lower index), in O(n log n): ``angle >= 2
    chord`` (``chord = |q - q'|`` for the nearer sign) makes the Euclidean distance in the
    embedding ``(2q, p)`` (both signs of q) a lower bound of the pose distance. A k-d tree
    gives each pose's ``k`` nearest by that bound; their exact distances bound the k-th
    nearest, ``t``; every pose whose bound is at most ``t`` is a candidate, and the exact
    distances of the candidates give the answer. Up to :data:`ALL_DISTANCES_POSES` poses:
    from all distances, row by row (the same answer)."""
    n = q.shape[0]
    if k <= 0:
        return np.zeros((n, 0), dtype=np.int64)
    if n <= ALL_DISTANCES_POSES:
        every = np.arange(n)
        return np.stack([_k_nearest(q, p, i, every, k) for i in range(n)])
    from scipy.spatial import cKDTree
    emb = np.concatenate([np.hstack([2.0 * q, p]), np.hstack([-2.0 * q, p])])
    tree = cKDTree(emb)
    m = min(2 * n, 2 * (k + 1))      # both signs of each pose: 2 (k + 1) cover k others
    _, cand = tree.query(np.hstack([2.0 * q, p]), m)
    out = np.empty((n, k), dtype=np.int64)
    for i in range(n):
        out[i] = _exact_k(q, p, i, np.unique(cand[i] % n), k, tree)
    return out


def _exact_k(q, p, i: int, first: np.ndarray, k: int, tree) -> np.ndarray:
    """The ``k`` nearest poses to pose ``i`` (not itself) by the exact distance, from the
    bound's candidates (:func:`_nearest_poses`)."""
    n = q.shape[0]
    first = first[first != i]
    d = pose_distances(q[i:i + 1], p[i:i + 1], q[first], p[first])[0]
    t = np.partition(d, k - 1)[k - 1] if first.size >= k else np.inf
    # (a margin above t: the bound is computed differently from the distance, and near 0
    # the arccos of the distance loses what the chord keeps; more candidates are harmless)
    r = t * (1.0 + 1e-9) + 1e-6
    ball = np.unique(np.asarray(tree.query_ball_point(np.hstack([2.0 * q[i], p[i]]), r),
                                dtype=np.int64) % n) if np.isfinite(t) else np.arange(n)
    return _k_nearest(q, p, i, ball, k)


def _k_nearest(q, p, i: int, candidates: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` nearest poses to pose ``i`` among ``candidates`` (ascending positions;
    ``i`` itself left out) by the exact distance, the lower position first on a tie."""
    ball = candidates[candidates != i]
    d = pose_distances(q[i:i + 1], p[i:i + 1], q[ball], p[ball])[0]
    return ball[np.argsort(d, kind="stable")[:k]]


def neighbour_correlation(r, pairs, permutations: int = 99) -> tuple[float, float]:
    """``(c, z)``: the mean correlation of the whitened residuals of neighbouring poses
    (``pairs`` of :func:`neighbour_pairs`), and its standard score against the same mean
    with the residuals shuffled over the poses (``permutations`` fixed shuffles,
    ``default_rng(0)``): independent pose errors give ``z`` ~ N(0, 1), errors that vary
    smoothly over the workspace or the recording a large positive ``z``."""
    r = np.asarray(r, np.float64)
    n = r.shape[0]
    _, Shi = _sqrtm(r.T @ r / max(n - 2, 1))
    z = r @ Shi
    ia, ib = pairs
    stat = lambda zz: float(np.mean(np.sum(zz[ia] * zz[ib], 1))) / 6.0  # noqa: E731
    c = stat(z)
    rng = np.random.default_rng(0)
    null = np.array([stat(z[rng.permutation(n)]) for _ in range(permutations)])
    return c, (c - float(null.mean())) / max(float(null.std(ddof=1)), 1e-12)


# ----------------------------------------------------------------------- error model
@dataclass(frozen=True, eq=False)
class ErrorModel:
    """A pose-error model (module doc): ``white``, ``pose``, ``time`` (6x6, rad and m, b's
    frame) and the ranges ``ell_pose`` (pose-space units) and ``ell_time`` (recording
    positions); ``residual_covariance`` the residuals' own; ``n_poses`` how many;
    ``*_at_bound``: the best range was the largest searched (the correlation reaches across
    the data: its common part is the model's extrapolation)."""
    white: np.ndarray = field(repr=False)
    pose: np.ndarray = field(repr=False)
    time: np.ndarray = field(repr=False)
    ell_pose: float
    ell_time: float
    residual_covariance: np.ndarray = field(repr=False)
    n_poses: int
    ell_pose_at_bound: bool = False
    ell_time_at_bound: bool = False

    def shares(self) -> dict:
        """Each part's share of the per-pose variance (in the residuals' whitened units)."""
        Wi = np.linalg.pinv(self.residual_covariance)
        parts = {k: max(float(np.trace(Wi @ getattr(self, k))), 0.0)
                 for k in ("white", "pose", "time")}
        tot = sum(parts.values()) or 1.0
        return {k: v / tot for k, v in parts.items()}


def _sqrtm(S) -> tuple[np.ndarray, np.ndarray]:
    lam, V = np.linalg.eigh(0.5 * (S + S.T))
    lam = np.maximum(lam, 1e-12 * max(float(lam.max()), 1e-300))
    return (V * np.sqrt(lam)) @ V.T, (V / np.sqrt(lam)) @ V.T


def psd(M) -> np.ndarray:
    """The nearest positive semi-definite matrix (negative eigenvalues set to 0)."""
    lam, V = np.linalg.eigh(0.5 * (M + M.T))
    return (V * np.maximum(lam, 0.0)) @ V.T


@dataclass(frozen=True, eq=False)
class PairDesign:
    """The residual pairs a fit uses (:func:`pair_design`): positions ``ia``, ``ib``, the
    ranges searched and the kernel columns ``1 - rho(d / ell)`` per range (pose space
    ``fp``, recording ``ft``)."""
    ia: np.ndarray
    ib: np.ndarray
    ell_p: np.ndarray
    ell_t: np.ndarray
    fp: np.ndarray
    ft: np.ndarray


def pair_design(T_a, index) -> PairDesign:
    """:class:`PairDesign` for residuals at a's poses ``T_a`` and recording positions
    ``index``: pose-space ranges from the 2 % quantile to the median of the distances
    between the evenly spread poses (correlations longer than the data's own extent are not told apart from a
    common error), recording ranges from 1 position to a third of the recording."""
    index = np.asarray(index, np.float64)
    ia, ib, k_even = _pairs(index.size)
    q, p = pose_coordinates(T_a)
    dpose = np.sqrt((2.0 * np.arccos(np.clip(np.abs(np.sum(q[ia] * q[ib], 1)), 0, 1))) ** 2
                    + np.sum((p[ia] - p[ib]) ** 2, 1))
    dtime = np.abs(index[ia] - index[ib])
    pos = dpose[:k_even][dpose[:k_even] > 0]          # the pairs spanning the data
    lo = float(np.quantile(pos, 0.02)) if pos.size else 1.0
    hi = max(float(np.median(pos)) if pos.size else 1.0, 1.5 * lo)
    ell_p = np.geomspace(lo, hi, _N_GRID)
    ell_t = np.geomspace(1.0, max(2.0, (index[-1] - index[0]) / 3.0), _N_GRID)
    return PairDesign(ia, ib, ell_p, ell_t,
                      1.0 - np.exp(-0.5 * (dpose[None] / ell_p[:, None]) ** 2),
                      1.0 - np.exp(-0.5 * (dtime[None] / ell_t[:, None]) ** 2))


def _best_fit(Yp, pr: PairDesign):
    """Least squares of the pair outer products ``Yp`` (npairs, 36) on ``[1, fp_k, ft_l]``
    over the range grid: ``(k, l, coef (3, 36))`` of the smallest misfit."""
    n = Yp.shape[0]
    sY = Yp.sum(0)
    FY, GY = pr.fp @ Yp, pr.ft @ Yp                   # (grid, 36)
    sf, sg = pr.fp.sum(1), pr.ft.sum(1)
    ff, gg, fg = np.sum(pr.fp ** 2, 1), np.sum(pr.ft ** 2, 1), pr.fp @ pr.ft.T
    best = None
    for k in range(pr.fp.shape[0]):
        for l in range(pr.ft.shape[0]):
            AtA = np.array([[n, sf[k], sg[l]], [sf[k], ff[k], fg[k, l]],
                            [sg[l], fg[k, l], gg[l]]])
            AtY = np.stack([sY, FY[k], GY[l]])
            c = np.linalg.lstsq(AtA, AtY, rcond=1e-10)[0]
            gain = 2.0 * float(np.sum(c * AtY)) - float(np.sum(c * (AtA @ c)))
            if best is None or gain > best[0]:
                best = (gain, k, l, c)
    return best[1:]


def fit_error_model(r, pr: PairDesign) -> ErrorModel:
    """The :class:`ErrorModel` of residuals ``r`` (n, 6) over the pairs of ``pr``: least
    squares on the matrix variogram ``(r_a - r_b)(r_a - r_b)^T / 2`` whitened by the
    residuals' own covariance, each part projected to positive semi-definite."""
    r = np.asarray(r, np.float64)
    n = r.shape[0]
    S = r.T @ r / max(n - 2, 1)
    Sh, Shi = _sqrtm(S)
    dz = (r[pr.ia] - r[pr.ib]) @ Shi
    Yp = 0.5 * (dz[:, :, None] * dz[:, None, :]).reshape(-1, 36)
    k, l, c = _best_fit(Yp, pr)
    back = lambda v: Sh @ psd(v.reshape(6, 6)) @ Sh  # noqa: E731
    return ErrorModel(back(c[0]), back(c[1]), back(c[2]), float(pr.ell_p[k]),
                      float(pr.ell_t[l]), S, n, k == pr.ell_p.size - 1,
                      l == pr.ell_t.size - 1)


# ------------------------------------------------------------------ X's covariance
#: the pose-space kernel sum runs on at most this many blocks of consecutive poses
KERNEL_BLOCKS = 256


def _time_sum(Gs, index, ell) -> np.ndarray:
    """``sum_j rho(|index_i - index_j| / ell) Gs_j`` for every i (FFT convolution over the
    recording positions)."""
    from simcalib.estimation.signals import fft_convolve
    idx = np.asarray(index, np.int64) - int(index[0])
    L = int(idx[-1]) + 1
    full = np.zeros((L,) + Gs.shape[1:])
    full[idx] = Gs
    half = int(min(L - 1, math.ceil(5.0 * ell)))
    k = np.exp(-0.5 * (np.arange(-half, half + 1) / ell) ** 2)
    out = fft_convolve(full, k, axis=0)[half:half + L]     # "same": centred on each
    return out[idx]


def _pose_sum(Gs, q, p, ell) -> tuple[np.ndarray, np.ndarray]:
    """``(Gb, Ab)``: ``Gs`` summed over blocks of consecutive poses (at most
    :data:`KERNEL_BLOCKS`) and ``sum_b' rho(d_bb' / ell) Gb_b'`` per block (a block sits
    at its middle pose)."""
    n = Gs.shape[0]
    nb = min(n, KERNEL_BLOCKS)
    blk = (np.arange(n) * nb) // n
    Gb = np.zeros((nb,) + Gs.shape[1:])
    np.add.at(Gb, blk, Gs)
    mid = np.array([int(np.flatnonzero(blk == b)[len(np.flatnonzero(blk == b)) // 2])
                    for b in range(nb)])
    rho = np.exp(-0.5 * (pose_distances(q[mid], p[mid], q[mid], p[mid]) / ell) ** 2)
    return Gb, np.tensordot(rho, Gb, axes=(1, 0))


def model_covariance(Gs, model: ErrorModel, T_a, index) -> np.ndarray:
    """The covariance under ``model`` of ``sum_i Gs_i r_i`` for sensitivities ``Gs``
    (n, m, 6): ``(m, m)`` (``m = 6``: X's covariance; stack several 6-row sensitivities to
    get their joint covariance), the poses ``T_a`` at recording positions ``index``."""
    Gs = np.asarray(Gs, np.float64)
    out = np.einsum("nij,jk,nlk->il", Gs, model.white, Gs)
    if np.any(model.time):
        A = _time_sum(Gs, index, model.ell_time)
        out += np.einsum("nij,jk,nlk->il", Gs, model.time, A)
    if np.any(model.pose):
        q, p = pose_coordinates(T_a)
        Gb, Ab = _pose_sum(Gs, q, p, model.ell_pose)
        out += np.einsum("nij,jk,nlk->il", Gb, model.pose, Ab)
    return 0.5 * (out + out.T)
