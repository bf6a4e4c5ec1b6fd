"""Motion advice: which stops to add so that X becomes best determined (pure numpy).

Information model (the one of :mod:`simcalib.solvers.diagnostics.uncertainty`): each motion ``i``
carries the Fisher information ``F_i = K_i^T Q_i^-1 K_i`` on the error
``delta = (omega, v)`` of X (rad, m; camera-a frame), with ``K_i`` the Jacobian of the
residual of ``C_i X = X H_i`` and ``Q_i`` the eq. 38 noise (``sigma_r``, ``sigma_t``) of
``C_i`` and ``H_i`` propagated to it. Information adds over motions, so the information
after adding candidate motions is ``F_base + sum F_c``, with ``F_c`` computed from the
candidate's predicted camera motions (``C_c`` from the platform's kinematics, ``H_c =
X^-1 C_c X`` at the current estimate) and the noise level fitted to the recorded data.

Criterion (tolerance units: ``omega / tolerance_deg``, ``v / tolerance_m``; ``lambda`` the
eigenvalues of the scaled information, ``1/sqrt(lambda)`` the 1-sigma of a direction):
minimise ``max_k 1/(lambda_k + eps) + mean_k 1/(lambda_k + eps)`` — the largest variance
(= maximise the smallest eigenvalue), with the mean (A-optimality) to rank candidates
that cannot yet fix every undetermined direction at once. ``eps = 1e-6`` (1-sigma of
1000 tolerances) keeps undetermined directions finite. Greedy over the feasible
candidate set: each step adds the candidate with the best criterion (one batched
eigen-decomposition of all candidates per step).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import invert_transform

__all__ = ["motion_information", "predicted_std", "greedy", "greedy_chain", "GreedyResult",
           "undeterminable", "EPS", "systematic_scores", "systematic_std",
           "greedy_chain_systematic", "check_chain_systematic", "max_std_tolerance_units",
           "variance_shares", "chain_information", "best_expected_chains", "expected_errors"]

EPS = 1e-6
_FLOOR_R = math.sqrt(np.finfo(float).eps)


def _scale(tolerance_deg, tolerance_m) -> np.ndarray:
    return np.array([math.radians(tolerance_deg)] * 3 + [tolerance_m] * 3)


def motion_information(C, H, X, sigma_r_rad: float, sigma_t_m: float) -> np.ndarray:
    """``(N, 6, 6)`` Fisher information of each motion on ``delta`` (rad, m) at ``X``."""
    from simcalib.solvers.diagnostics.uncertainty import linear_model
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    if C.ndim != 3 or C.shape[1:] != (4, 4) or H.shape != C.shape:
        raise ValueError(f"C and H must be (N, 4, 4) of the same shape; received {C.shape}, "
                         f"{H.shape}")
    if C.shape[0] == 0:
        return np.zeros((0, 6, 6))
    _, K, Qr, Qt = linear_model(C, H, np.asarray(X, dtype=np.float64))
    L = max(float(np.linalg.norm(X[:3, 3])), 1e-3)
    Q = ((sigma_r_rad ** 2 + _FLOOR_R ** 2) * Qr
         + (sigma_t_m ** 2 + (1e-9 * L) ** 2) * Qt)
    Qinv = np.linalg.inv(Q)
    F = np.einsum("nki,nkl,nlj->nij", K, Qinv, K)
    return 0.5 * (F + np.swapaxes(F, -1, -2))


def predicted_motions(motion_a, X) -> tuple[np.ndarray, np.ndarray]:
    """``(C, H)`` of motions of camera a ``motion_a`` with camera b following through X."""
    C = np.asarray(motion_a, dtype=np.float64)
    return C, invert_transform(X) @ C @ X


def predicted_std(F, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                  range_rad: float = 1.0, range_m: float = 1.0) -> np.ndarray:
    """1-sigma per axis ``(wx, wy, wz)`` deg, ``(vx, vy, vz)`` m from information ``F``;
    ``inf`` on axes touched by a direction whose 1-sigma exceeds the range (1 rad, or
    ``range_m``): undetermined."""
    dsc = _scale(tolerance_deg, tolerance_m)
    Ft = np.asarray(F) * np.outer(dsc, dsc)
    lam, U = np.linalg.eigh(0.5 * (Ft + Ft.T))
    sig = np.where(lam > 0, 1.0 / np.sqrt(np.maximum(lam, 1e-300)), np.inf)
    rng_sc = np.array([range_rad] * 3 + [range_m] * 3) / dsc
    undet = sig * np.sqrt(np.sum((U / rng_sc[:, None]) ** 2, axis=0)) > 1.0
    B = U[:, ~undet]
    cov_t = (B / lam[~undet]) @ B.T if B.shape[1] else np.zeros((6, 6))
    s = np.sqrt(np.clip(np.diag(cov_t), 0, None)) * dsc
    if undet.any():
        touched = np.linalg.norm(U[:, undet], axis=1) > 1e-6
        s[touched] = np.inf
    return np.concatenate([np.degrees(s[:3]), s[3:]])


def _criterion(Ft) -> np.ndarray:
    """Batched criterion of scaled information ``Ft`` ``(..., 6, 6)`` (lower is better)."""
    lam = np.linalg.eigvalsh(0.5 * (Ft + np.swapaxes(Ft, -1, -2)))
    v = 1.0 / (np.maximum(lam, 0.0) + EPS)
    return v.max(axis=-1) + v.mean(axis=-1)


@dataclass(frozen=True)
class GreedyResult:
    """``order``: chosen candidate indices in the order added; ``criterion`` ``(k+1,)``: the
    criterion before and after each addition; ``max_std_tol`` ``(k+1,)``: largest 1-sigma in
    tolerance units (``1/sqrt(lambda_min)``)."""
    order: np.ndarray
    criterion: np.ndarray
    max_std_tol: np.ndarray


def greedy(F_base, F_cand, k: int, *, feasible=None, tolerance_deg: float = 1.0,
           tolerance_m: float = 0.01) -> GreedyResult:
    """Greedy choice of ``k`` of the candidates (information ``F_cand`` ``(N, 6, 6)``) to add
    to ``F_base``; ``feasible`` ``(N,)`` bool restricts the choice. Each candidate is used at
    most once. Fewer than ``k`` are returned when fewer are feasible."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be an integer >= 1; received {k!r}")
    dsc = _scale(tolerance_deg, tolerance_m)
    S = np.outer(dsc, dsc)
    Fb = np.asarray(F_base, dtype=np.float64) * S
    Fc = np.asarray(F_cand, dtype=np.float64) * S
    avail = np.ones(Fc.shape[0], bool) if feasible is None else np.asarray(feasible, bool).copy()
    order, crit, mx = [], [float(_criterion(Fb))], [_max_std(Fb)]
    cur = Fb
    for _ in range(int(k)):
        idx = np.flatnonzero(avail)
        if idx.size == 0:
            break
        c = _criterion(cur[None] + Fc[idx])
        j = int(idx[int(np.argmin(c))])
        order.append(j)
        avail[j] = False
        cur = cur + Fc[j]
        crit.append(float(_criterion(cur)))
        mx.append(_max_std(cur))
    return GreedyResult(np.array(order, dtype=np.int64), np.array(crit), np.array(mx))


def _adinv(T):
    """``Ad(T^-1)`` (…, 6, 6): ``exp(-xi) T = T exp(-Ad(T^-1) xi)``."""
    from simcalib.geometry import adjoint_from_transform
    return adjoint_from_transform(invert_transform(T))


def systematic_scores(C, H, X, sigma_r_rad: float, sigma_t_m: float, B_start_a, B_end_a,
                      B_start_b, B_end_b) -> np.ndarray:
    """``(N, 6, P)``: how systematic pose errors move each motion's information-weighted
    score ``K_i^T Q_i^-1 e_i`` (the estimate's error is ``F^-1 sum_i`` of it): the poses
    at each motion's start and end carry the errors ``xi = B @ eta`` (``B_*`` ``(N, 6, P)``
    per camera, or ``(6, P)`` when every motion starts or ends at the same pose;
    ``eta ~ N(0, I)`` shared), the motion the error ``xi_end - Ad(M^-1) xi_start``
    (right-multiplied), the residual its first-order response (the eq. 38 noise Jacobians
    of :func:`simcalib.solvers.diagnostics.uncertainty.linear_model`)."""
    from simcalib.solvers.diagnostics.uncertainty import (linear_model_jacobians,
                                                          noise_covariance_parts)
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    _, K, Jc, Jh = linear_model_jacobians(C, H, X)
    Qr, Qt = noise_covariance_parts(Jc, Jh)
    L = max(float(np.linalg.norm(X[:3, 3])), 1e-3)
    Q = ((sigma_r_rad ** 2 + _FLOOR_R ** 2) * Qr + (sigma_t_m ** 2 + (1e-9 * L) ** 2) * Qt)
    KQ = np.swapaxes(K, -1, -2) @ np.linalg.inv(Q)
    Mc, Mh = KQ @ Jc, KQ @ Jh          # (N, 6, 6): the products with the bases come last
    return (_times_basis(Mc, B_end_a) - _times_basis(Mc @ _adinv(C), B_start_a)
            + _times_basis(Mh, B_end_b) - _times_basis(Mh @ _adinv(H), B_start_b))


def _times_basis(M, B) -> np.ndarray:
    """``M @ B`` for ``M`` ``(N, 6, 6)`` and an error basis ``B``: ``(N, 6, P)`` (one per
    motion) or ``(6, P)`` (one pose shared by every motion: a single 2-D product)."""
    B = np.asarray(B, dtype=np.float64)
    if B.ndim == 2:
        return (M.reshape(-1, 6) @ B).reshape(M.shape[0], 6, B.shape[-1])
    return M @ B


def systematic_std(F, G, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                   range_rad: float = 1.0, range_m: float = 1.0) -> np.ndarray:
    """:func:`predicted_std` with the systematic pose errors: over the determined
    directions the covariance ``F^-1 + F^-1 G G^T F^-1`` (``G`` ``(6, P)``, the summed
    :func:`systematic_scores`); ``inf`` where ``F`` leaves a direction undetermined."""
    white = predicted_std(F, tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
                          range_rad=range_rad, range_m=range_m)
    dsc = _scale(tolerance_deg, tolerance_m)
    Fi = _determined_inverse(F, dsc, range_rad, range_m)
    S = _with_systematic(Fi, np.asarray(G) * dsc[:, None])
    s = np.sqrt(np.clip(np.diag(S), 0, None)) * dsc
    s = np.concatenate([np.degrees(s[:3]), s[3:]])
    return np.where(np.isfinite(white), s, np.inf)


def _determined_inverse(F, dsc, range_rad: float, range_m: float) -> np.ndarray:
    """Inverse of the scaled information ``F * dsc dsc^T`` over its determined directions
    (1-sigma within ``range_rad`` / ``range_m``), zero along the others."""
    Ft = np.asarray(F) * np.outer(dsc, dsc)
    lam, U = np.linalg.eigh(0.5 * (Ft + Ft.T))
    rng_sc = np.array([range_rad] * 3 + [range_m] * 3) / dsc
    sig = np.where(lam > 0, 1.0 / np.sqrt(np.maximum(lam, 1e-300)), np.inf)
    det = sig * np.sqrt(np.sum((U / rng_sc[:, None]) ** 2, axis=0)) <= 1.0
    B = U[:, det]
    return (B / lam[det]) @ B.T if B.shape[1] else np.zeros((6, 6))


def variance_shares(F, G, groups, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                    range_rad: float = 1.0, range_m: float = 1.0) -> tuple[np.ndarray, list]:
    """Where the predicted variance of each axis of X comes from: ``(shares (6, 1 + n),
    names)`` with ``names = ["white noise", *the n distinct groups]`` and ``shares[a, j]``
    the fraction of axis ``a``'s variance (the diagonal of
    ``F^-1 + F^-1 G G^T F^-1`` over the determined directions, :func:`systematic_std`) that
    the white noise (``F^-1``) or the columns of ``G`` (6, P) labelled with group ``j``
    (``groups``: P labels, e.g. "marker map") add — exactly, since ``G G^T`` is the sum
    of its column groups' ``G_g G_g^T``. Rows of undetermined axes (zero variance over
    the determined directions) are NaN."""
    G = np.asarray(G, dtype=np.float64)
    labels = list(groups)
    if G.ndim != 2 or G.shape[0] != 6 or len(labels) != G.shape[1]:
        raise ValueError(f"G must be (6, P) with P group labels; received G of shape "
                         f"{G.shape} and {len(labels)} labels")
    dsc = _scale(tolerance_deg, tolerance_m)
    Fi = _determined_inverse(F, dsc, range_rad, range_m)
    names = ["white noise"] + list(dict.fromkeys(labels))
    parts = [np.diag(Fi)]
    Gt = G * dsc[:, None]
    for name in names[1:]:
        FG = Fi @ Gt[:, [i for i, g in enumerate(labels) if g == name]]
        parts.append(np.sum(FG * FG, axis=1))
    V = np.stack(parts, axis=1)
    total = V.sum(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        shares = np.where(total > 0, V / np.where(total > 0, total, 1.0), np.nan)
    return shares, names


def _with_systematic(Fi, Gt) -> np.ndarray:
    """The covariance ``Fi + Fi G G^T Fi`` (batched): white-noise covariance ``Fi`` plus
    what the shared pose errors with score ``G`` add."""
    FG = Fi @ Gt
    return Fi + FG @ np.swapaxes(FG, -1, -2)


def _criterion_systematic(Ft, Gt) -> np.ndarray:
    """Batched criterion with systematic errors (tolerance units; ``Ft`` ``(..., 6, 6)``,
    ``Gt`` ``(..., 6, P)``): max + mean eigenvalue of ``Fe^-1 + Fe^-1 G G^T Fe^-1`` with
    ``Fe = F + EPS I`` — :func:`_criterion` exactly when ``G = 0``."""
    S = _regularised_covariance(Ft, Gt)
    lam = np.linalg.eigvalsh(0.5 * (S + np.swapaxes(S, -1, -2)))
    return lam.max(axis=-1) + lam.mean(axis=-1)


def _regularised_covariance(Ft, Gt) -> np.ndarray:
    """Batched ``Fe^-1 + Fe^-1 G G^T Fe^-1`` with ``Fe = F + EPS I`` (tolerance units):
    what the chain criteria judge (undetermined directions kept finite)."""
    Fe = 0.5 * (Ft + np.swapaxes(Ft, -1, -2)) + EPS * np.eye(6)
    return _with_systematic(np.linalg.inv(Fe), Gt)


def _link(T_from, T_to, X, s_r, s_t, scale_from, scale_to, B_from=None, B_to=None):
    """``(F (n, 6, 6), G (n, 6, P))`` of the motions ``T_from -> T_to`` (stop and go; batched,
    either side may be one pose): the information with the variance factor of the two
    stops' poses averaged (each pose error enters the motion) and, with the stops' error
    bases ``B_*`` ``(2, n, 6, P)`` or, for one pose, ``(2, 6, P)`` (cameras a, b), the
    systematic score
    (:func:`systematic_scores`); ``P = 0`` without them."""
    C, H = predicted_motions(invert_transform(T_from) @ T_to, X)
    f = 0.5 * (np.asarray(scale_from, dtype=np.float64) + np.asarray(scale_to, np.float64))
    F = motion_information(C, H, X, s_r, s_t) / np.broadcast_to(f, (C.shape[0],))[:, None, None]
    if B_from is None:
        return F, np.zeros((F.shape[0], 6, 0))
    return F, systematic_scores(C, H, X, s_r, s_t, B_from[0], B_to[0], B_from[1], B_to[1])


def check_chain_systematic(systematic, n: int):
    """``(G_base (6, P), B_ref (2, 6, P), B_cand (2, n, 6, P))`` or None: the systematic
    pose errors of :func:`greedy_chain` (score of the recorded motions; per camera a / b the
    error basis of the reference stop and of each candidate stop)."""
    if systematic is None:
        return None
    try:
        G0, Br, Bc = (np.asarray(x, dtype=np.float64) for x in systematic)
    except (TypeError, ValueError):
        raise ValueError("systematic must be (G_base, B_ref, B_cand); received "
                         f"{type(systematic).__name__}") from None
    P = G0.shape[-1] if G0.ndim == 2 else -1
    if G0.shape != (6, P) or Br.shape != (2, 6, P) or Bc.shape != (2, n, 6, P) \
            or not (np.isfinite(G0).all() and np.isfinite(Br).all() and np.isfinite(Bc).all()):
        raise ValueError(f"systematic must be finite G_base (6, P), B_ref (2, 6, P), B_cand "
                         f"(2, {n}, 6, P); received shapes {G0.shape}, {Br.shape}, {Bc.shape}")
    return G0, Br, Bc


def greedy_chain(F_base, motion_a, X, sigma_r_rad: float, sigma_t_m: float, k: int, *,
                 feasible=None, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                 noise_scale=None, ref_noise_scale: float = 1.0, refine: bool = True,
                 max_passes: int = 4, systematic=None) -> tuple[GreedyResult, np.ndarray]:
    """Choice of ``k`` stops visited in order (stop and go): the motion each stop adds is the
    one from the previous stop (the reference for the first), so a stop's pose error enters
    two consecutive motions instead of one shared reference error entering all.
    ``motion_a`` ``(N, 4, 4)``: camera a's motion from the reference to each candidate.
    ``noise_scale`` ``(N,)``: variance factor of each candidate stop's pose error relative
    to the fitted noise (e.g. a worse marker view; 1 = as fitted), ``ref_noise_scale`` that
    of the reference stop; a motion's noise variance is scaled by the mean of its two stops'.
    ``systematic``: optional ``(G_base, B_ref, B_cand)`` (:func:`check_chain_systematic`):
    pose errors shared by the stops and the recorded poses (a marker map, calibrations);
    the criterion is then that of the covariance ``F^-1 + F^-1 G G^T F^-1`` with ``G`` the
    summed :func:`systematic_scores` of the recorded motions and the chain's links
    (:func:`_criterion_systematic`), so the choice weighs what a stop's view adds in
    systematic error against the information it brings.

    Greedy first (each step adds the stop with the best criterion); then, with ``refine``,
    exchange passes (Fedorov-style): each chosen stop in turn is replaced by the available
    candidate that lowers the criterion of the whole chain most, until a pass changes
    nothing (at most ``max_passes``). With ``systematic`` every stop must lower the
    criterion: the greedy stops early when none does (fewer than ``k`` stops: more would
    add more systematic error than information) and an exchange that would make a step
    raise it is not taken. Returns the :class:`GreedyResult` (criterion and
    largest 1-sigma of the final chain after each of its stops) and the information
    ``(k, 6, 6)`` each stop of the final chain adds."""
    res, added, _ = _greedy_chain(F_base, motion_a, X, sigma_r_rad, sigma_t_m, k,
                                  feasible=feasible, tolerance_deg=tolerance_deg,
                                  tolerance_m=tolerance_m, noise_scale=noise_scale,
                                  ref_noise_scale=ref_noise_scale, refine=refine,
                                  max_passes=max_passes, systematic=systematic)
    return res, added


def chain_information(F_base, motion_a, X, sigma_r_rad: float, sigma_t_m: float, chains, *,
                      noise_scale=None, ref_noise_scale: float = 1.0,
                      systematic=None) -> tuple[np.ndarray, np.ndarray]:
    """``(F (n, 6, 6), G (n, 6, P))``: the information and the systematic score of the
    recorded motions plus each of ``n`` given chains of stops ``chains`` ``(n, k)``
    (candidate indices, visited in order from the reference, stop and go) — what
    :func:`greedy_chain` weighs, for chains it did not choose (e.g. random ones, to compare
    with the chosen chain). Batched over the chains; same arguments as
    :func:`greedy_chain` (``P = 0`` without ``systematic``)."""
    M = np.asarray(motion_a, dtype=np.float64)
    N = M.shape[0]
    ch = np.asarray(chains)
    if ch.ndim != 2 or not np.issubdtype(ch.dtype, np.integer) or ch.size == 0 \
            or ch.min() < 0 or ch.max() >= N:
        raise ValueError(f"chains must be a non-empty (n, k) integer array of candidate "
                         f"indices in [0, {N}); received shape {ch.shape}, dtype {ch.dtype}")
    sc = _check_noise_scale(noise_scale, N)
    sysm = check_chain_systematic(systematic, N)
    n = ch.shape[0]
    F = np.broadcast_to(np.asarray(F_base, dtype=np.float64), (n, 6, 6)).copy()
    G = np.zeros((n, 6, 0)) if sysm is None else np.broadcast_to(sysm[0], (n,) + sysm[0].shape
                                                                 ).copy()
    T_prev = np.broadcast_to(np.eye(4), (n, 4, 4))
    s_prev = np.full(n, float(ref_noise_scale))
    B_prev = None if sysm is None else sysm[1]        # the reference: one pose for every chain
    for j in range(ch.shape[1]):
        idx = ch[:, j]
        B = None if sysm is None else sysm[2][:, idx]
        Fj, Gj = _link(T_prev, M[idx], X, sigma_r_rad, sigma_t_m, s_prev, sc[idx], B_prev, B)
        F, G = F + Fj, G + Gj
        T_prev, s_prev, B_prev = M[idx], sc[idx], B
    return F, G


def expected_errors(F, G, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01
                    ) -> np.ndarray:
    """``(n, 2)``: the expected (root-mean-square) norm of X's rotation error (deg) and
    translation error (m) under information ``F`` ``(n, 6, 6)`` and systematic score ``G``
    ``(n, 6, P)`` (rad, m) — the root of the trace of each block of the covariance
    ``Fe^-1 + Fe^-1 G G^T Fe^-1`` that :func:`best_expected_chains` minimises (an
    undetermined direction counts with the 1-sigma of 1000 tolerances that ``EPS`` gives)."""
    F = np.asarray(F, dtype=np.float64)
    G = np.asarray(G, dtype=np.float64)
    if F.ndim != 3 or F.shape[1:] != (6, 6) or G.ndim != 3 or G.shape[:2] != (F.shape[0], 6):
        raise ValueError(f"F must be (n, 6, 6) and G (n, 6, P); received {F.shape}, {G.shape}")
    dsc = _scale(tolerance_deg, tolerance_m)
    Ft, Gt = F * np.outer(dsc, dsc), G * dsc[:, None]
    return np.stack([tolerance_deg * np.sqrt(_block_variance(Ft, Gt, 0)),
                     tolerance_m * np.sqrt(_block_variance(Ft, Gt, 1))], axis=1)


def best_expected_chains(F_base, motion_a, X, sigma_r_rad: float, sigma_t_m: float, starts, *,
                         feasible=None, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                         noise_scale=None, ref_noise_scale: float = 1.0, systematic=None,
                         max_passes: int = 20) -> dict:
    """How small the expected error of X can be made by a choice of ``k`` stops among the
    feasible candidates, under this model (white noise and the shared pose errors, the same
    as :func:`greedy_chain`), as far as a local search finds: for X's rotation and its
    translation each on its own (so no single chain need reach both: what the best chain
    for that block gives, whatever it does to the other),
    coordinate exchange — every stop in turn replaced by the feasible candidate that
    lowers that block's expected squared error most (the trace of its block of the
    covariance), passes until one changes nothing (at most ``max_passes``) — from each of
    the ``starts`` ``(n, k)`` chains (candidate indices, visited in order from the
    reference; e.g. the planner's chain and random ones). A local search of a
    combinatorial problem: the spread of ``per_start`` says how far it is from settled.

    Returns ``{"rotation": {"expected_deg", "chain", "per_start_deg"}, "translation":
    {"expected_m", "chain", "per_start_m"}}``: the smallest root-mean-square error norm the
    search reached (deg, m), its chain and what each start converged to."""
    st = np.asarray(starts)
    m0 = _chain_model(motion_a, X, sigma_r_rad, sigma_t_m, noise_scale, ref_noise_scale,
                      systematic, tolerance_deg, tolerance_m)
    N = m0.M.shape[0]
    if st.ndim != 2 or st.size == 0 or not np.issubdtype(st.dtype, np.integer) \
            or st.min() < 0 or st.max() >= N \
            or any(len(set(row.tolist())) != st.shape[1] for row in st):
        raise ValueError(f"starts must be a non-empty (n, k) integer array of distinct "
                         f"candidate indices in [0, {N}) per row; received shape {st.shape}, "
                         f"dtype {st.dtype}")
    feas = np.ones(N, bool) if feasible is None else np.asarray(feasible, bool)
    if feas.shape != (N,) or not feas[st].all():
        raise ValueError(f"feasible must be ({N},) bool and hold every start's stops; "
                         f"received shape {feas.shape}")
    F0 = np.asarray(F_base, dtype=np.float64)
    out = {}
    for block, name, unit, tol in ((0, "rotation", "deg", tolerance_deg),
                                   (1, "translation", "m", tolerance_m)):
        m = dataclasses.replace(m0, block=block, monotone=False)
        found = []
        for row in st:
            order = [int(j) for j in row]
            avail = feas.copy()
            avail[order] = False
            _exchange_passes(m, F0, order, avail, max_passes)
            LF, LG = _chain_links(m, order)
            v = float(_chain_criterion(m, F0 + sum(LF), m.G0 + sum(LG, np.zeros_like(m.G0))))
            found.append((tol * math.sqrt(max(v, 0.0)), order))
        best = min(found, key=lambda f: f[0])
        out[name] = {f"expected_{unit}": best[0], "chain": best[1],
                     f"per_start_{unit}": [f[0] for f in found]}
    return out


def greedy_chain_systematic(*args, **kw) -> tuple[GreedyResult, np.ndarray, np.ndarray]:
    """:func:`greedy_chain` returning also the systematic score ``(k, 6, P)`` each stop of
    the final chain adds."""
    return _greedy_chain(*args, **kw)


def _greedy_chain(F_base, motion_a, X, sigma_r_rad, sigma_t_m, k, *, feasible=None,
                  tolerance_deg=1.0, tolerance_m=0.01, noise_scale=None,
                  ref_noise_scale=1.0, refine=True, max_passes=4, systematic=None):
    """:func:`greedy_chain_systematic`: the greedy chain, its exchange passes, its result."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be an integer >= 1; received {k!r}")
    m = _chain_model(motion_a, X, sigma_r_rad, sigma_t_m, noise_scale, ref_noise_scale,
                     systematic, tolerance_deg, tolerance_m)
    N = m.M.shape[0]
    avail = np.ones(N, bool) if feasible is None else np.asarray(feasible, bool).copy()
    F0 = np.asarray(F_base, dtype=np.float64)
    order = _greedy_stops(m, F0, avail, k)
    if refine and len(order) > 0:
        _exchange_passes(m, F0, order, avail, max_passes)
    return _chain_result(m, F0, order)


@dataclass(frozen=True)
class _ChainModel:
    """What the links and the criterion of a stop-and-go chain are computed from."""
    M: np.ndarray             # (N, 4, 4) camera a's motion from the reference to each candidate
    X: object
    s_r: float
    s_t: float
    sc: np.ndarray            # (N,) noise variance factor of each candidate stop
    ref_scale: float          # ... and of the reference stop
    sysm: tuple | None        # check_chain_systematic's (G_base, B_ref, B_cand), or None
    G0: np.ndarray            # (6, P) systematic score of the recorded motions (P = 0: none)
    dsc: np.ndarray           # (6,) tolerance scale
    S: np.ndarray             # (6, 6) its outer product
    #: what a chain is judged by: None the planner's criterion (:func:`_criterion` /
    #: :func:`_criterion_systematic`); 0 / 1 the expected squared norm of X's rotation /
    #: translation error alone (the trace of that block of the covariance; tolerance units)
    block: int | None = None
    #: exchanges must leave every stop lowering the criterion (the planner's rule with
    #: systematic errors); off for :func:`best_expected_chains`, which judges whole chains
    monotone: bool = True


def _check_noise_scale(noise_scale, N: int) -> np.ndarray:
    """The per-candidate pose-noise factors ``(N,)`` (default ones), finite and > 0."""
    sc = np.ones(N) if noise_scale is None else np.asarray(noise_scale, dtype=np.float64)
    if sc.shape != (N,) or not np.all(np.isfinite(sc)) or np.any(sc <= 0):
        raise ValueError(f"noise_scale must be ({N},) finite and > 0; received shape "
                         f"{sc.shape}")
    return sc


def _chain_model(motion_a, X, s_r, s_t, noise_scale, ref_noise_scale, systematic,
                 tolerance_deg, tolerance_m) -> _ChainModel:
    """The checked inputs of a chain choice (noise factors and systematic errors)."""
    dsc = _scale(tolerance_deg, tolerance_m)
    M = np.asarray(motion_a, dtype=np.float64)
    N = M.shape[0]
    sc = _check_noise_scale(noise_scale, N)
    sysm = check_chain_systematic(systematic, N)
    G0 = sysm[0] if sysm is not None else np.zeros((6, 0))
    return _ChainModel(M, X, s_r, s_t, sc, ref_noise_scale, sysm, G0, dsc, np.outer(dsc, dsc))


def _stop_pose_scale(m: _ChainModel, j):
    """Camera a's pose and the noise factor of stop ``j`` (-1: the reference)."""
    return (np.eye(4), m.ref_scale) if j < 0 else (m.M[j], m.sc[j])


def _stop_basis(m: _ChainModel, j) -> np.ndarray:
    """(2, 6, P) error basis of stop ``j`` (-1: the reference), cameras a and b."""
    return m.sysm[1] if j < 0 else m.sysm[2][:, j]


def _chain_link(m: _ChainModel, prev, idx, nxt=None):
    """(F, G) of the motions prev -> idx (idx an array), or idx -> nxt when nxt given."""
    if nxt is None:
        Bf, Bt = (None, None) if m.sysm is None else (_stop_basis(m, prev), m.sysm[2][:, idx])
        T_prev, s_prev = _stop_pose_scale(m, prev)
        return _link(T_prev, m.M[idx], m.X, m.s_r, m.s_t, s_prev, m.sc[idx], Bf, Bt)
    Bf, Bt = (None, None) if m.sysm is None else (m.sysm[2][:, idx], _stop_basis(m, nxt))
    return _link(m.M[idx], m.M[nxt], m.X, m.s_r, m.s_t, m.sc[idx], m.sc[nxt], Bf, Bt)


def _chain_criterion(m: _ChainModel, F, G):
    """Criterion (batched) of information ``F`` and systematic score ``G`` (rad, m)."""
    if m.block is not None:
        return _block_variance(F * m.S, G * m.dsc[:, None], m.block)
    if m.sysm is None:
        return _criterion(F * m.S)
    return _criterion_systematic(F * m.S, G * m.dsc[:, None])


def _block_variance(Ft, Gt, block: int) -> np.ndarray:
    """Batched expected squared norm of the rotation (``block`` 0) or translation (1) error
    of X: the trace of that block of ``Fe^-1 + Fe^-1 G G^T Fe^-1`` (tolerance units,
    ``Fe = F + EPS I`` as in :func:`_criterion_systematic`)."""
    d = np.diagonal(_regularised_covariance(Ft, Gt), axis1=-2, axis2=-1)
    return d[..., 3 * block:3 * block + 3].sum(axis=-1)


def _greedy_stops(m: _ChainModel, F0, avail, k) -> list:
    """Greedy chain: each step adds the available stop with the best criterion."""
    cur_F, cur_G = F0, m.G0
    order = []
    for _ in range(int(k)):
        idx = np.flatnonzero(avail)
        if idx.size == 0:
            break
        prev = order[-1] if order else -1
        Fc, Gc = _chain_link(m, prev, idx)
        c = _chain_criterion(m, cur_F[None] + Fc, cur_G[None] + Gc)
        j = int(np.argmin(c))
        if m.sysm is not None and not c[j] < float(_chain_criterion(m, cur_F, cur_G)):
            break          # every stop would add more systematic error than information
        order.append(int(idx[j]))
        avail[idx[j]] = False
        cur_F, cur_G = cur_F + Fc[j], cur_G + Gc[j]
    return order


def _chain_links(m: _ChainModel, order):
    """(F, G) of each motion of the chain ``order`` (from the reference)."""
    prevs = [-1] + order[:-1]
    out = [_chain_link(m, p, np.array([o])) for p, o in zip(prevs, order)]
    return [f[0] for f, _ in out], [g[0] for _, g in out]


def _lowers_at_every_stop(m: _ChainModel, F0, order) -> bool:
    """Whether no stop of the chain ``order`` raises the criterion."""
    LF, LG = _chain_links(m, order)
    F, G = F0, m.G0
    prev_c = float(_chain_criterion(m, F, G))
    for Fa, Ga in zip(LF, LG):
        F, G = F + Fa, G + Ga
        c = float(_chain_criterion(m, F, G))
        if c > prev_c:
            return False
        prev_c = c
    return True


def _exchange_passes(m: _ChainModel, F0, order, avail, max_passes) -> None:
    """Exchange passes over ``order`` (in place) until one changes nothing."""
    for _ in range(int(max_passes)):
        changed = False
        for p in range(len(order)):
            idx = np.flatnonzero(avail)
            if idx.size == 0:
                break
            if _exchange_stop(m, F0, order, avail, p, idx):
                changed = True
        if not changed:
            break


def _exchange_stop(m: _ChainModel, F0, order, avail, p, idx) -> bool:
    """Whether stop ``p`` of ``order`` was replaced (in place) by a better candidate."""
    LF, LG = _chain_links(m, order)
    c = _criteria_with_stop_replaced(m, F0, order, LF, LG, p, idx)
    now = float(_chain_criterion(m, F0 + sum(LF), m.G0 + sum(LG, np.zeros_like(m.G0))))
    for best in np.argsort(c, kind="stable")[:10]:
        if not c[best] < now * (1 - 1e-9):
            break
        trial = order[:p] + [int(idx[best])] + order[p + 1:]
        if m.sysm is not None and m.monotone and not _lowers_at_every_stop(m, F0, trial):
            continue   # each stop must lower the predicted uncertainty
        avail[order[p]] = True
        order[p] = int(idx[best])
        avail[order[p]] = False
        return True
    return False


def _criteria_with_stop_replaced(m: _ChainModel, F0, order, LF, LG, p, idx):
    """Criterion of the chain ``order`` with stop ``p`` replaced by each of ``idx``."""
    prev = order[p - 1] if p > 0 else -1
    keep = [i for i in range(len(order)) if i not in (p, p + 1)]
    rest_F = F0 + sum((LF[i] for i in keep), np.zeros((6, 6)))
    rest_G = m.G0 + sum((LG[i] for i in keep), np.zeros_like(m.G0))
    F_in, G_in = _chain_link(m, prev, idx)
    tot_F, tot_G = rest_F[None] + F_in, rest_G[None] + G_in
    if p + 1 < len(order):
        F_out, G_out = _chain_link(m, None, idx, order[p + 1])
        tot_F, tot_G = tot_F + F_out, tot_G + G_out
    return _chain_criterion(m, tot_F, tot_G)


def _chain_result(m: _ChainModel, F0, order):
    """(GreedyResult, information, systematic score of each stop) of the chain ``order``."""
    LF, LG = _chain_links(m, order) if order else ([], [])
    cur_F, cur_G = F0.copy(), m.G0.copy()
    crits, mx = [float(_chain_criterion(m, cur_F, cur_G))], [_max_std_sys(cur_F, cur_G, m.dsc)]
    for Fa, Ga in zip(LF, LG):
        cur_F, cur_G = cur_F + Fa, cur_G + Ga
        crits.append(float(_chain_criterion(m, cur_F, cur_G)))
        mx.append(_max_std_sys(cur_F, cur_G, m.dsc))
    P = m.G0.shape[1]
    return (GreedyResult(np.array(order, dtype=np.int64), np.array(crits), np.array(mx)),
            np.array(LF).reshape(-1, 6, 6),
            np.array(LG).reshape((len(LF), 6, P)) if LG else np.zeros((0, 6, P)))


def _max_std_sys(F, G, dsc) -> float:
    """Largest 1-sigma in tolerance units: of the information alone without systematic
    errors (:func:`_max_std`), else of ``Fe^-1 + Fe^-1 G G^T Fe^-1``."""
    Ft = F * np.outer(dsc, dsc)
    if G.shape[-1] == 0:
        return _max_std(Ft)
    w = _max_std(Ft)
    if not math.isfinite(w):
        return math.inf
    try:
        Fi = np.linalg.inv(0.5 * (Ft + Ft.T))
    except np.linalg.LinAlgError:           # numerically singular: a direction undetermined
        return math.inf
    S = _with_systematic(Fi, G * dsc[:, None])
    lam = np.linalg.eigvalsh(S)[-1]
    return float(math.sqrt(max(lam, 0.0)))


def max_std_tolerance_units(F, *, tolerance_deg: float = 1.0,
                            tolerance_m: float = 0.01) -> float:
    """Largest 1-sigma of information ``F`` (rad, m) in tolerance units
    (``1/sqrt(lambda_min)``; inf when a direction is undetermined)."""
    dsc = _scale(tolerance_deg, tolerance_m)
    return _max_std(np.asarray(F, dtype=np.float64) * np.outer(dsc, dsc))


def _max_std(Ft) -> float:
    lam = np.linalg.eigvalsh(0.5 * (Ft + Ft.T))[0]
    return float(1.0 / math.sqrt(lam)) if lam > 0 else math.inf


#: how a prior on X is given, named in the fix of :func:`undeterminable`: a scenario's keys
PRIOR_KEYS_SCENARIO = {"translation": "prior.translation_m with a weight prior.b",
                       "rotation": "prior.rotvec_deg with a weight prior.a"}
#: ... and ``calibrate``'s (pose files)
PRIOR_KEYS_CALIBRATE = {
    "translation": "prior=[tx,ty,tz,qx,qy,qz,qw] with a weight prior_weight_translation",
    "rotation": "prior=[tx,ty,tz,qx,qy,qz,qw] with a weight prior_weight_rotation"}


def undeterminable(F_base, F_cand, *, feasible=None, tolerance_deg: float = 1.0,
                   tolerance_m: float = 0.01, range_rad: float = 1.0,
                   range_m: float = 1.0, prior_keys: dict | None = None) -> list[dict]:
    """Directions of X that no feasible candidate motion can determine: undetermined (1-sigma
    beyond the range) by the feasible candidates alone, each added 100 times, and not
    determined within the tolerance by the recorded motions (``F_base``). The candidates
    are judged alone because the recorded motions' information along such a direction may
    be made by their errors (a systematic tilt of the measured poses looks like the
    rotation that would determine it) and adding candidates cannot change that. Each is a
    dict:
    ``kind`` (rotation / translation / coupled), ``rotation_axis_a``, ``translation_dir_a``
    (unit, camera-a frame, zeros when that part is < 5 %), ``description``, ``fix`` (the
    prior or extra measurement that would determine it; ``prior_keys``: how the prior is
    given, :data:`PRIOR_KEYS_SCENARIO` by default)."""
    keys = PRIOR_KEYS_SCENARIO if prior_keys is None else prior_keys
    dsc = _scale(tolerance_deg, tolerance_m)
    Fb = np.asarray(F_base, dtype=np.float64) * np.outer(dsc, dsc)
    Fc = np.asarray(F_cand, dtype=np.float64)
    if feasible is not None:
        Fc = Fc[np.asarray(feasible, bool)]
    Ft = 100.0 * Fc.sum(axis=0) * np.outer(dsc, dsc)
    lam, U = np.linalg.eigh(0.5 * (Ft + Ft.T))
    sig = np.where(lam > 0, 1.0 / np.sqrt(np.maximum(lam, 1e-300)), np.inf)
    rng_sc = np.array([range_rad] * 3 + [range_m] * 3) / dsc
    out = []
    for k in range(6):
        u = U[:, k]
        if not sig[k] * math.sqrt(float(np.sum((u / rng_sc) ** 2))) > 1.0:
            continue
        if float(u @ Fb @ u) >= 1.0:      # the recorded motions determine it (1-sigma <= tol)
            continue
        w, t = u[:3], u[3:]
        nw, nt = np.linalg.norm(w), np.linalg.norm(t)
        tot = math.hypot(nw, nt)
        ax = w / nw if nw > 0.05 * tot else np.zeros(3)
        td = t / nt if nt > 0.05 * tot else np.zeros(3)
        vec = lambda v: "[" + ", ".join(f"{x:+.3f}" for x in v) + "]"   # noqa: E731
        if ax.any() and td.any():
            kind = "coupled"
            desc = (f"rotation of X about {vec(ax)} coupled with translation along {vec(td)} "
                    "(camera-a frame)")
        elif ax.any():
            kind, desc = "rotation", f"rotation of X about {vec(ax)} (camera-a frame)"
        else:
            kind, desc = "translation", f"translation of X along {vec(td)} (camera-a frame)"
        fix = []
        if td.any():
            fix.append(f"a prior on X's translation along {vec(td)} ({keys['translation']}, "
                       "e.g. the camera offset measured with a ruler or taken from the CAD "
                       "model, to within the tolerance)")
            fix.append("or motions rotating about an axis not parallel to it — which this "
                       "platform cannot make (e.g. tilt the rig: drive over a ramp, or mount "
                       "it on an arm)")
        if ax.any():
            fix.append(f"a prior on X's rotation about {vec(ax)} ({keys['rotation']}), or "
                       "motions with rotations about two non-parallel axes")
        out.append({"kind": kind, "rotation_axis_a": ax.tolist(),
                    "translation_dir_a": td.tolist(), "description": desc,
                    "statement": (f"{desc}: no motion this platform can make determines it "
                                  "(undetermined even with every feasible candidate)"),
                    "fix": "; ".join(fix)})
    return out
