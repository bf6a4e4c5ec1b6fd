"""Which stops to add so that X becomes best determined: the choice of a stop-and-go chain
(pure numpy; the information model is :mod:`simcalib.studies.advise.information`).

Information after adding candidate motions is ``F_base + sum F_c``, with ``F_c`` computed
from the candidate's predicted camera motions (``C_c`` from the platform's kinematics,
``H_c = X^-1 C_c X`` at the current estimate) and the noise level fitted to the recorded
data.

Criterion (tolerance units: ``omega / tolerance_deg``, ``v / tolerance_m``; ``lambda`` the
eigenvalues of the scaled information, ``1/sqrt(lambda)`` the 1-sigma of a direction):
minimise ``max_k 1/(lambda_k + eps) + mean_k 1/(lambda_k + eps)`` — the largest variance
(= maximise the smallest eigenvalue), with the mean (A-optimality) to rank candidates
that cannot yet fix every undetermined direction at once. ``eps = 1e-6`` (1-sigma of
1000 tolerances) keeps undetermined directions finite. Directions no feasible candidate
can determine (``undetermined``, :func:`simcalib.studies.advise.information.
undeterminable_directions`) are left out: the criterion is that of the information on
their orthogonal complement, so stops are ranked by what they can improve (with such a
direction in, its constant ``1/eps`` would be the maximum of every chain). Greedy over the
feasible candidate set: each step adds the candidate with the best criterion (one batched
eigen-decomposition of all candidates per step), then exchange passes.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import invert_transform
from simcalib.studies.advise.information import (check_undetermined, complement,
                                                 motion_information, predicted_motions,
                                                 systematic_scores, tolerance_scale,
                                                 with_systematic)

__all__ = ["greedy", "greedy_chain", "GreedyResult", "EPS", "greedy_chain_systematic",
           "check_chain_systematic", "chain_information", "best_expected_chains",
           "expected_errors"]

EPS = 1e-6


def _criterion(Ft) -> np.ndarray:
    """Batched criterion of scaled information ``Ft`` ``(..., 6, 6)`` (lower is better)."""
    lam = np.linalg.eigvalsh(0.5 * (Ft + np.swapaxes(Ft, -1, -2)))
    v = 1.0 / (np.maximum(lam, 0.0) + EPS)
    return v.max(axis=-1) + v.mean(axis=-1)


def _criterion_systematic(Ft, Gt) -> np.ndarray:
    """Batched criterion with systematic errors (tolerance units; ``Ft`` ``(..., n, n)``,
    ``Gt`` ``(..., n, P)``): max + mean eigenvalue of ``Fe^-1 + Fe^-1 G G^T Fe^-1`` with
    ``Fe = F + EPS I`` — :func:`_criterion` exactly when ``G = 0``."""
    S = _regularised_covariance(Ft, Gt)
    lam = np.linalg.eigvalsh(0.5 * (S + np.swapaxes(S, -1, -2)))
    return lam.max(axis=-1) + lam.mean(axis=-1)


def _regularised_covariance(Ft, Gt) -> np.ndarray:
    """Batched ``Fe^-1 + Fe^-1 G G^T Fe^-1`` with ``Fe = F + EPS I`` (tolerance units):
    what the chain criteria judge (undetermined directions kept finite)."""
    Fe = 0.5 * (Ft + np.swapaxes(Ft, -1, -2)) + EPS * np.eye(Ft.shape[-1])
    return with_systematic(np.linalg.inv(Fe), Gt)


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
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
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
                 max_passes: int = 4, systematic=None,
                 undetermined=None) -> tuple[GreedyResult, np.ndarray]:
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
    systematic error against the information it brings. ``undetermined``: ``(6, r)``
    directions (tolerance units, orthonormal) no feasible candidate determines
    (:func:`simcalib.studies.advise.information.undeterminable_directions`): the criterion
    and the largest 1-sigma are those of the other directions.

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
                                  max_passes=max_passes, systematic=systematic,
                                  undetermined=undetermined)
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


def expected_errors(F, G, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                    undetermined=None) -> np.ndarray:
    """``(n, 2)``: the expected (root-mean-square) norm of X's rotation error (deg) and
    translation error (m) under information ``F`` ``(n, 6, 6)`` and systematic score ``G``
    ``(n, 6, P)`` (rad, m) — the root of the trace of each block of the covariance
    ``Fe^-1 + Fe^-1 G G^T Fe^-1`` that :func:`best_expected_chains` minimises (an
    undetermined direction counts with the 1-sigma of 1000 tolerances that ``EPS`` gives;
    the ``undetermined`` directions of :func:`greedy_chain` are left out)."""
    F = np.asarray(F, dtype=np.float64)
    G = np.asarray(G, dtype=np.float64)
    if F.ndim != 3 or F.shape[1:] != (6, 6) or G.ndim != 3 or G.shape[:2] != (F.shape[0], 6):
        raise ValueError(f"F must be (n, 6, 6) and G (n, 6, P); received {F.shape}, {G.shape}")
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
    Bc = _determinable_basis(undetermined)
    Ft, Gt = _restricted(Bc, F * np.outer(dsc, dsc), G * dsc[:, None])
    return np.stack([tolerance_deg * np.sqrt(_block_variance(Ft, Gt, 0, Bc)),
                     tolerance_m * np.sqrt(_block_variance(Ft, Gt, 1, Bc))], axis=1)


def best_expected_chains(F_base, motion_a, X, sigma_r_rad: float, sigma_t_m: float, starts, *,
                         feasible=None, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                         noise_scale=None, ref_noise_scale: float = 1.0, systematic=None,
                         max_passes: int = 20, undetermined=None) -> dict:
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
    search reached (deg, m), its chain and what each start converged to; ``undetermined``:
    as for :func:`greedy_chain`."""
    m0 = _chain_model(motion_a, X, sigma_r_rad, sigma_t_m, noise_scale, ref_noise_scale,
                      systematic, tolerance_deg, tolerance_m, undetermined)
    st, feas = _check_starts(starts, feasible, m0.M.shape[0])
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


def _check_starts(starts, feasible, N: int) -> tuple[np.ndarray, np.ndarray]:
    """``(starts (n, k), feasible (N,))`` of :func:`best_expected_chains`, checked."""
    st = np.asarray(starts)
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
    return st, feas


def greedy_chain_systematic(*args, **kw) -> tuple[GreedyResult, np.ndarray, np.ndarray]:
    """:func:`greedy_chain` returning also the systematic score ``(k, 6, P)`` each stop of
    the final chain adds."""
    return _greedy_chain(*args, **kw)


def _greedy_chain(F_base, motion_a, X, sigma_r_rad, sigma_t_m, k, *, feasible=None,
                  tolerance_deg=1.0, tolerance_m=0.01, noise_scale=None,
                  ref_noise_scale=1.0, refine=True, max_passes=4, systematic=None,
                  undetermined=None):
    """:func:`greedy_chain_systematic`: the greedy chain, its exchange passes, its result."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be an integer >= 1; received {k!r}")
    m = _chain_model(motion_a, X, sigma_r_rad, sigma_t_m, noise_scale, ref_noise_scale,
                     systematic, tolerance_deg, tolerance_m, undetermined)
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
    #: (6, m) orthonormal basis (tolerance units) of the directions a chain can determine:
    #: the complement of those no feasible candidate determines; None: all six
    Bc: np.ndarray | None = None


def _check_noise_scale(noise_scale, N: int) -> np.ndarray:
    """The per-candidate pose-noise factors ``(N,)`` (default ones), finite and > 0."""
    sc = np.ones(N) if noise_scale is None else np.asarray(noise_scale, dtype=np.float64)
    if sc.shape != (N,) or not np.all(np.isfinite(sc)) or np.any(sc <= 0):
        raise ValueError(f"noise_scale must be ({N},) finite and > 0; received shape "
                         f"{sc.shape}")
    return sc


def _chain_model(motion_a, X, s_r, s_t, noise_scale, ref_noise_scale, systematic,
                 tolerance_deg, tolerance_m, undetermined=None) -> _ChainModel:
    """The checked inputs of a chain choice (noise factors, systematic errors, the
    directions no candidate determines)."""
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
    M = np.asarray(motion_a, dtype=np.float64)
    N = M.shape[0]
    sc = _check_noise_scale(noise_scale, N)
    sysm = check_chain_systematic(systematic, N)
    G0 = sysm[0] if sysm is not None else np.zeros((6, 0))
    return _ChainModel(M, X, s_r, s_t, sc, ref_noise_scale, sysm, G0, dsc, np.outer(dsc, dsc),
                       Bc=_determinable_basis(undetermined))


def _determinable_basis(undetermined) -> np.ndarray | None:
    """The complement of the ``undetermined`` directions ``(6, r)`` (tolerance units,
    orthonormal), or None when there are none."""
    U = check_undetermined(undetermined)
    return None if U is None else complement(U)


def _restricted(Bc, Ft, Gt) -> tuple:
    """``(Bc^T Ft Bc, Bc^T Gt)``: information and score on the determinable directions
    (unchanged when ``Bc`` is None)."""
    if Bc is None:
        return Ft, Gt
    return Bc.T @ Ft @ Bc, Bc.T @ Gt


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
    """Criterion (batched) of information ``F`` and systematic score ``G`` (rad, m), on the
    determinable directions."""
    Ft, Gt = _restricted(m.Bc, F * m.S, G * m.dsc[:, None])
    if m.block is not None:
        return _block_variance(Ft, Gt, m.block, m.Bc)
    if m.sysm is None:
        return _criterion(Ft)
    return _criterion_systematic(Ft, Gt)


def _block_variance(Ft, Gt, block: int, Bc=None) -> np.ndarray:
    """Batched expected squared norm of the rotation (``block`` 0) or translation (1) error
    of X: the trace of that block of ``Fe^-1 + Fe^-1 G G^T Fe^-1`` (tolerance units,
    ``Fe = F + EPS I`` as in :func:`_criterion_systematic`); with ``Bc``, ``Ft`` and ``Gt``
    are on the determinable directions ``Bc`` (:func:`_restricted`), the covariance mapped
    back to the axes."""
    S = _regularised_covariance(Ft, Gt)
    if Bc is None:
        d = np.diagonal(S, axis1=-2, axis2=-1)
    else:
        d = np.einsum("ij,...jk,ik->...i", Bc, S, Bc)
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
    crits = [float(_chain_criterion(m, cur_F, cur_G))]
    mx = [_max_std_sys(cur_F, cur_G, m.dsc, m.Bc)]
    for Fa, Ga in zip(LF, LG):
        cur_F, cur_G = cur_F + Fa, cur_G + Ga
        crits.append(float(_chain_criterion(m, cur_F, cur_G)))
        mx.append(_max_std_sys(cur_F, cur_G, m.dsc, m.Bc))
    P = m.G0.shape[1]
    return (GreedyResult(np.array(order, dtype=np.int64), np.array(crits), np.array(mx)),
            np.array(LF).reshape(-1, 6, 6),
            np.array(LG).reshape((len(LF), 6, P)) if LG else np.zeros((0, 6, P)))


def _max_std_sys(F, G, dsc, Bc=None) -> float:
    """Largest 1-sigma in tolerance units on the determinable directions (``Bc``, None: all
    six): of the information alone without systematic errors (:func:`_max_std`), else of
    ``F^-1 + F^-1 G G^T F^-1``."""
    Ft, Gt = _restricted(Bc, F * np.outer(dsc, dsc), G * dsc[:, None])
    w = _max_std(Ft)
    if G.shape[-1] == 0 or not math.isfinite(w):
        return w
    try:
        Fi = np.linalg.inv(0.5 * (Ft + Ft.T))
    except np.linalg.LinAlgError:           # numerically singular: a direction undetermined
        return math.inf
    lam = np.linalg.eigvalsh(with_systematic(Fi, Gt))[-1]
    return float(math.sqrt(max(lam, 0.0)))


def _max_std(Ft) -> float:
    lam = np.linalg.eigvalsh(0.5 * (Ft + Ft.T))[0]
    return float(1.0 / math.sqrt(lam)) if lam > 0 else math.inf


