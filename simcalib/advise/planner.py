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

import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import invert_transform

__all__ = ["motion_information", "predicted_std", "greedy", "greedy_chain", "GreedyResult",
           "undeterminable", "EPS"]

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


def _chain_info(M, T_from, X, s_r, s_t, scale_from, scale_to):
    """Information of the motions ``T_from -> M`` (batched over ``M`` or ``T_from``) with the
    variance factor of the two stops' poses averaged (each pose error enters the motion)."""
    C, H = predicted_motions(invert_transform(T_from) @ M, X)
    F = motion_information(C, H, X, s_r, s_t)
    f = 0.5 * (np.asarray(scale_from, dtype=np.float64) + np.asarray(scale_to, np.float64))
    return F / np.broadcast_to(f, (F.shape[0],))[:, None, None]


def greedy_chain(F_base, motion_a, X, sigma_r_rad: float, sigma_t_m: float, k: int, *,
                 feasible=None, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                 noise_scale=None, ref_noise_scale: float = 1.0, refine: bool = True,
                 max_passes: int = 4) -> tuple[GreedyResult, np.ndarray]:
    """Choice of ``k`` stops visited in order (stop and go): the motion each stop adds is the
    one from the previous stop (the reference for the first), so a stop's pose error enters
    two consecutive motions instead of one shared reference error entering all.
    ``motion_a`` ``(N, 4, 4)``: camera a's motion from the reference to each candidate.
    ``noise_scale`` ``(N,)``: variance factor of each candidate stop's pose error relative
    to the fitted noise (e.g. a worse marker view; 1 = as fitted), ``ref_noise_scale`` that
    of the reference stop; a motion's noise variance is scaled by the mean of its two stops'.

    Greedy first (each step adds the stop with the best criterion); then, with ``refine``,
    exchange passes (Fedorov-style): each chosen stop in turn is replaced by the available
    candidate that lowers the criterion of the whole chain most, until a pass changes
    nothing (at most ``max_passes``). Returns the :class:`GreedyResult` (criterion and
    largest 1-sigma of the final chain after each of its stops) and the information
    ``(k, 6, 6)`` each stop of the final chain adds."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be an integer >= 1; received {k!r}")
    dsc = _scale(tolerance_deg, tolerance_m)
    S = np.outer(dsc, dsc)
    M = np.asarray(motion_a, dtype=np.float64)
    N = M.shape[0]
    sc = np.ones(N) if noise_scale is None else np.asarray(noise_scale, dtype=np.float64)
    if sc.shape != (N,) or not np.all(np.isfinite(sc)) or np.any(sc <= 0):
        raise ValueError(f"noise_scale must be ({N},) finite and > 0; received shape "
                         f"{sc.shape}")
    avail = np.ones(N, bool) if feasible is None else np.asarray(feasible, bool).copy()
    F0 = np.asarray(F_base, dtype=np.float64)
    I4 = np.eye(4)
    s_r, s_t = sigma_r_rad, sigma_t_m

    def pose(j):
        return I4 if j < 0 else M[j]

    def scale(j):
        return ref_noise_scale if j < 0 else sc[j]

    cur_F = F0
    order = []
    for _ in range(int(k)):
        idx = np.flatnonzero(avail)
        if idx.size == 0:
            break
        prev = order[-1] if order else -1
        Fc = _chain_info(M[idx], pose(prev), X, s_r, s_t, scale(prev), sc[idx])
        j = int(np.argmin(_criterion((cur_F[None] + Fc) * S)))
        order.append(int(idx[j]))
        avail[idx[j]] = False
        cur_F = cur_F + Fc[j]

    def links(order):
        """Information of each motion of the chain ``order`` (from the reference)."""
        prevs = [-1] + order[:-1]
        return [_chain_info(M[[o]], pose(p), X, s_r, s_t, scale(p), sc[o])[0]
                for p, o in zip(prevs, order)]

    if refine and len(order) > 0:
        for _ in range(int(max_passes)):
            changed = False
            for p in range(len(order)):
                idx = np.flatnonzero(avail)
                if idx.size == 0:
                    break
                L = links(order)
                prev = order[p - 1] if p > 0 else -1
                rest = F0 + sum(L[i] for i in range(len(order)) if i not in (p, p + 1))
                F_in = _chain_info(M[idx], pose(prev), X, s_r, s_t, scale(prev), sc[idx])
                tot = rest[None] + F_in
                if p + 1 < len(order):
                    nxt = order[p + 1]
                    C, H = predicted_motions(invert_transform(M[idx]) @ M[nxt], X)
                    F_out = motion_information(C, H, X, s_r, s_t)
                    F_out = F_out / (0.5 * (sc[idx] + sc[nxt]))[:, None, None]
                    tot = tot + F_out
                c = _criterion(tot * S)
                best = int(np.argmin(c))
                now = float(_criterion((F0 + sum(L)) * S))
                if c[best] < now * (1 - 1e-9):
                    avail[order[p]] = True
                    order[p] = int(idx[best])
                    avail[order[p]] = False
                    changed = True
            if not changed:
                break
    added = links(order) if order else []
    cur = F0.copy()
    crit, mx = [float(_criterion(cur * S))], [_max_std(cur * S)]
    for Fa in added:
        cur = cur + Fa
        crit.append(float(_criterion(cur * S)))
        mx.append(_max_std(cur * S))
    return (GreedyResult(np.array(order, dtype=np.int64), np.array(crit), np.array(mx)),
            np.array(added).reshape(-1, 6, 6))


def _max_std(Ft) -> float:
    lam = np.linalg.eigvalsh(0.5 * (Ft + Ft.T))[0]
    return float(1.0 / math.sqrt(lam)) if lam > 0 else math.inf


def undeterminable(F_base, F_cand, *, feasible=None, tolerance_deg: float = 1.0,
                   tolerance_m: float = 0.01, range_rad: float = 1.0,
                   range_m: float = 1.0) -> list[dict]:
    """Directions of X that no feasible candidate motion can determine: undetermined (1-sigma
    beyond the range) by the feasible candidates alone, each added 100 times, and not
    determined within the tolerance by the recorded motions (``F_base``). The candidates
    are judged alone because the recorded motions' information along such a direction may
    be made by their errors (a systematic tilt of the measured poses looks like the
    rotation that would determine it) and adding candidates cannot change that. Each is a
    dict:
    ``kind`` (rotation / translation / coupled), ``rotation_axis_a``, ``translation_dir_a``
    (unit, camera-a frame, zeros when that part is < 5 %), ``description``, ``fix`` (the
    prior or extra measurement that would determine it)."""
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
            fix.append(f"a prior on X's translation along {vec(td)} (prior.translation_m "
                       "with a weight prior.b, e.g. the camera offset measured with a ruler or "
                       "taken from the CAD model, to within the tolerance)")
            fix.append("or motions rotating about an axis not parallel to it — which this "
                       "platform cannot make (e.g. tilt the rig: drive over a ramp, or mount "
                       "it on an arm)")
        if ax.any():
            fix.append(f"a prior on X's rotation about {vec(ax)} (prior.rotvec_deg with a "
                       "weight prior.a), or motions with rotations about two non-parallel axes")
        out.append({"kind": kind, "rotation_axis_a": ax.tolist(),
                    "translation_dir_a": td.tolist(), "description": desc,
                    "statement": (f"{desc}: no motion this platform can make determines it "
                                  "(undetermined even with every feasible candidate)"),
                    "fix": "; ".join(fix)})
    return out
