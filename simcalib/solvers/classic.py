"""Daniilidis (1999) dual-quaternion SVD method, with the paper's alpha scaling.

K. Daniilidis, "Hand-eye calibration using dual quaternions", IJRR 18 (1999) 286-298.

For each motion (C_i, H_i) with sign-aligned dual quaternions ``a + eps a'`` (of C_i) and
``b + eps b'`` (of H_i) the method stacks the 6x8 block (quaternions (x, y, z, w))::

    [ [a+b]x      a-b      0       0   ]   ( q  )
    [ [a'+b']x    a'-b'    [a+b]x  a-b ] . ( q' ) = 0

(the vector parts of ``a q = q b`` and its dual part; the scalar equations are dropped, as in
the paper, because they hold identically for exact screw motions). The two right singular
vectors ``v1, v2`` of the 6N x 8 matrix with the smallest singular values span the solution
space; ``q + eps q' = l1 v1 + l2 v2`` with ``|q| = 1`` and ``q . q' = 0`` gives a quadratic
in ``l1 / l2``. Dekel et al. (sec. 4.3) scale the translation part by ``alpha`` for a fair
comparison: translations of C and H are multiplied by ``alpha`` before the SVD and the
resulting translation divided by it (alpha = 1 is the original method).

Degenerate input (more than two near-zero singular values, i.e. the motions do not fix X)
is reported through ``SolverOutput.success = False`` and a message naming the undetermined
directions; the returned X is then one arbitrary member of the solution set.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import transform_from_dual_quat
from simcalib.solvers.problem import MotionProblem, SolverOutput
from simcalib.solvers.registry import register

__all__ = ["daniilidis_matrix", "daniilidis", "daniilidis_batch", "unit_dual_quat_from_span",
           "unit_dual_quat_from_null_space", "describe_motion_degeneracy"]

# A singular value below NULL_TOL * (largest singular value) counts as zero.
NULL_TOL = 1e-10


def daniilidis_matrix(problem: MotionProblem, alpha: float = 1.0) -> np.ndarray:
    """The stacked ``(6N, 8)`` Daniilidis matrix acting on ``(q, alpha q')``."""
    s = problem.q_C[:, :3] + problem.q_H[:, :3]
    d = problem.q_C[:, :3] - problem.q_H[:, :3]
    sd = alpha * (problem.q_C_dual[:, :3] + problem.q_H_dual[:, :3])
    dd = alpha * (problem.q_C_dual[:, :3] - problem.q_H_dual[:, :3])
    n = s.shape[0]
    T = np.zeros((n, 6, 8))
    for blk, (v, w, c0) in enumerate(((s, d, 0), (sd, dd, 0), (s, d, 4))):
        r0 = 0 if blk == 0 else 3
        # [v]x in columns c0..c0+2, w in column c0+3
        T[:, r0 + 0, c0 + 1] = -v[:, 2]
        T[:, r0 + 0, c0 + 2] = v[:, 1]
        T[:, r0 + 1, c0 + 0] = v[:, 2]
        T[:, r0 + 1, c0 + 2] = -v[:, 0]
        T[:, r0 + 2, c0 + 0] = -v[:, 1]
        T[:, r0 + 2, c0 + 1] = v[:, 0]
        T[:, r0:r0 + 3, c0 + 3] = w
    return T.reshape(6 * n, 8)


def unit_dual_quat_from_span(v1: np.ndarray, v2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The unit dual quaternion ``l1 v1 + l2 v2`` (8-vectors ``(q, q')``) with ``|q| = 1`` and
    ``q . q' = 0`` (Daniilidis' quadratic). Returns ``(q, q')``.

    Written on the circle ``(l1, l2) = (cos t, sin t)``: the constraint ``q . q' = 0`` is a
    2x2 quadratic form ``Qd`` that must vanish; of its (up to two) null directions the one
    with the larger ``|q|`` is taken and scaled to ``|q| = 1``. With noise ``Qd`` may be
    definite (no exact solution); then the direction where ``|q . q'|`` is smallest relative
    to ``|q|^2`` is used and the remaining ``q . q'`` is projected away.
    """
    u1, w1, u2, w2 = v1[:4], v1[4:], v2[:4], v2[4:]
    p_, r_, s_ = float(u1 @ w1), 0.5 * float(u1 @ w2 + u2 @ w1), float(u2 @ w2)
    Qu = np.array([[u1 @ u1, u1 @ u2], [u1 @ u2, u2 @ u2]])
    # on l = (cos t, sin t): l^T Qd l = m + rho cos(2t - 2 theta)
    m = 0.5 * (p_ + s_)
    rho = float(np.hypot(0.5 * (p_ - s_), r_))
    theta = 0.5 * np.arctan2(2.0 * r_, p_ - s_)
    if rho == 0.0 and m == 0.0:            # Qd == 0: every direction satisfies q . q' = 0
        ts = [0.0, 0.5 * np.pi]
    elif abs(m) <= rho:                     # two exact solutions
        dt = 0.5 * np.arccos(np.clip(-m / rho, -1.0, 1.0))
        ts = [theta + dt, theta - dt]
    else:
        ts = None
    if ts is not None:
        cands = [np.array([np.cos(t), np.sin(t)]) for t in ts]
    else:
        # no real solution (noise): generalised eigenvector minimising |l^T Qd l| / l^T Qu l
        Qd = np.array([[p_, r_], [r_, s_]])
        try:
            ev, V = np.linalg.eig(np.linalg.solve(Qu, Qd))
            cands = [np.real(V[:, int(np.argmin(np.abs(ev.real)))])]
        except np.linalg.LinAlgError:
            t = theta + (0.5 * np.pi if m > 0 else 0.0)
            cands = [np.array([np.cos(t), np.sin(t)])]
    best = max(cands, key=lambda l: l @ Qu @ l)
    qq = float(best @ Qu @ best)
    if not np.isfinite(qq) or qq <= 1e-24 * max(float(np.trace(Qu)), 1e-300) or qq <= 0.0:
        raise ValueError("no combination of the two vectors has a rotation part "
                         "(the rotation is undetermined)")
    l = best / np.sqrt(qq)
    x = l[0] * v1 + l[1] * v2
    q, qd = x[:4], x[4:]
    if q[3] < 0:
        q, qd = -q, -qd
    return q, qd


def unit_dual_quat_from_null_space(V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Like :func:`unit_dual_quat_from_span` for a null space of any dimension ``k >= 2``
    (rows of ``V``, ``(k, 8)``, orthonormal): the two combinations with the largest rotation
    part span the search (for k = 2 this is the plain span). Raises ValueError when no
    combination has a rotation part (nothing determines q)."""
    V = np.atleast_2d(V)
    if V.shape[0] == 2:
        v1, v2 = V[0], V[1]
    else:
        _, _, Wt = np.linalg.svd(V[:, :4].T)     # combinations by size of the q-part
        v1, v2 = Wt[0] @ V, Wt[1] @ V
    if max(np.linalg.norm(v1[:4]), np.linalg.norm(v2[:4])) < 1e-8:
        raise ValueError("the null space has no rotation part: the rotation is undetermined")
    return unit_dual_quat_from_span(v1, v2)


def describe_motion_degeneracy(problem: MotionProblem, tol_rad: float = 1e-6) -> str:
    """Plain-words description of why motions may not determine X (rotation axes of C)."""
    q = problem.q_C
    s = np.linalg.norm(q[:, :3], axis=1)
    angles = 2.0 * np.arctan2(s, np.abs(q[:, 3]))
    if angles.max() < tol_rad:
        return ("no motion rotates (max angle {:.3g} rad): the rotation of X is "
                "undetermined".format(angles.max()))
    rot = angles >= tol_rad
    axes = q[rot, :3] / s[rot, None]
    _, sv, Vt = np.linalg.svd(axes, full_matrices=False)
    if sv.size < 2 or sv[1] < tol_rad * max(sv[0], 1.0):
        ax = Vt[0] * np.sign(Vt[0][np.argmax(np.abs(Vt[0]))])
        return ("all rotation axes are parallel to ({:.3f}, {:.3f}, {:.3f}) in frame a "
                "(planar or single-axis motion): the translation of X along that axis is "
                "undetermined".format(*ax))
    return "the motions are (numerically) degenerate"


def daniilidis(problem: MotionProblem, alpha: float = 1.0) -> SolverOutput:
    T = daniilidis_matrix(problem, alpha)
    # right singular vectors of T from its 8x8 triangular factor (QR is backward stable,
    # so this is as accurate as the SVD of T and ~4x faster)
    R = np.linalg.qr(T, mode="r") if T.shape[0] >= 8 else T
    _, sv, Vt = np.linalg.svd(R)
    n_null = int(np.sum(sv <= NULL_TOL * sv[0])) if sv[0] > 0 else 8
    diag = {"singular_values": sv, "n_null": n_null}
    try:
        q, qd_scaled = unit_dual_quat_from_null_space(Vt[-max(n_null, 2):])
    except ValueError:
        return SolverOutput(np.full((4, 4), np.nan), diag, success=False, message=(
            f"degenerate motions for Daniilidis: {describe_motion_degeneracy(problem)}; "
            "no estimate"))
    X = transform_from_dual_quat(q, qd_scaled / alpha)
    if n_null > 2:
        return SolverOutput(X, diag, success=False, message=(
            f"degenerate motions for Daniilidis: the {T.shape[0]}x8 matrix has {n_null} "
            f"near-zero singular values (a unique X needs exactly 2): "
            f"{describe_motion_degeneracy(problem)}; the returned X is one arbitrary "
            f"solution"))
    return SolverOutput(X, diag, success=True,
                        message="ok" if sv[-3] > 0 else "ok (exact null space)")


def _daniilidis_matrices(qC, qCd, qH, qHd, alphas) -> np.ndarray:
    """Stacked Daniilidis matrices ``(B, 6N, 8)`` of aligned motions ``(B, N, 4)``."""
    a = np.asarray(alphas, dtype=np.float64)[:, None, None]
    s, d = qC[..., :3] + qH[..., :3], qC[..., :3] - qH[..., :3]
    sd, dd = a * (qCd[..., :3] + qHd[..., :3]), a * (qCd[..., :3] - qHd[..., :3])
    B, n = s.shape[:2]
    T = np.zeros((B, n, 6, 8))
    for blk, (v, w, c0) in enumerate(((s, d, 0), (sd, dd, 0), (s, d, 4))):
        r0 = 0 if blk == 0 else 3
        T[..., r0 + 0, c0 + 1] = -v[..., 2]
        T[..., r0 + 0, c0 + 2] = v[..., 1]
        T[..., r0 + 1, c0 + 0] = v[..., 2]
        T[..., r0 + 1, c0 + 2] = -v[..., 0]
        T[..., r0 + 2, c0 + 0] = -v[..., 1]
        T[..., r0 + 2, c0 + 1] = v[..., 0]
        T[..., r0:r0 + 3, c0 + 3] = w
    return T.reshape(B, 6 * n, 8)


def _unit_dual_quats_from_spans(v1, v2, use):
    """:func:`unit_dual_quat_from_span` for the rows ``use`` of ``v1, v2 (B, 8)`` at once
    (the same formulas, as arrays). Returns ``q, q' (B, 4)`` and the mask of rows done;
    rows it leaves (not in ``use``, no rotation part, ``Qd == 0``, a singular ``Qu``) go
    through the single-problem function, which also words their failure."""
    def dot(a, b):
        return np.einsum("bi,bi->b", a, b)
    u1, w1, u2, w2 = v1[:, :4], v1[:, 4:], v2[:, :4], v2[:, 4:]
    p_, r_, s_ = dot(u1, w1), 0.5 * (dot(u1, w2) + dot(u2, w1)), dot(u2, w2)
    Qu = np.stack([np.stack([dot(u1, u1), dot(u1, u2)], -1),
                   np.stack([dot(u1, u2), dot(u2, u2)], -1)], -2)
    m = 0.5 * (p_ + s_)
    rho = np.hypot(0.5 * (p_ - s_), r_)
    theta = 0.5 * np.arctan2(2.0 * r_, p_ - s_)
    has_q = np.maximum(np.linalg.norm(u1, axis=1), np.linalg.norm(u2, axis=1)) >= 1e-8
    use = use & has_q & ~((rho == 0.0) & (m == 0.0))
    exact = use & (np.abs(m) <= rho)
    with np.errstate(invalid="ignore", divide="ignore"):
        dt = 0.5 * np.arccos(np.clip(-m / np.where(exact, rho, 1.0), -1.0, 1.0))
    t1, t2 = theta + dt, theta - dt
    l1 = np.stack([np.cos(t1), np.sin(t1)], -1)
    l2 = np.stack([np.cos(t2), np.sin(t2)], -1)
    # no real solution (noise): generalised eigenvector minimising |l^T Qd l| / l^T Qu l
    inexact = np.flatnonzero(use & ~exact)
    if inexact.size:
        Qd = np.stack([np.stack([p_, r_], -1), np.stack([r_, s_], -1)], -2)[inexact]
        try:
            ev, V = np.linalg.eig(np.linalg.solve(Qu[inexact], Qd))
        except np.linalg.LinAlgError:   # some Qu singular: those rows go one by one
            use = use.copy()
            use[inexact] = False
        else:
            pick = np.argmin(np.abs(ev.real), axis=1)
            l1[inexact] = np.real(V[np.arange(inexact.size), :, pick])
            l2[inexact] = l1[inexact]
    qq1 = np.einsum("bi,bij,bj->b", l1, Qu, l1)
    qq2 = np.einsum("bi,bij,bj->b", l2, Qu, l2)
    second = qq2 > qq1          # max() keeps the first of equal candidates
    best = np.where(second[:, None], l2, l1)
    qq = np.where(second, qq2, qq1)
    trace = np.maximum(Qu[:, 0, 0] + Qu[:, 1, 1], 1e-300)
    use = use & np.isfinite(qq) & (qq > 1e-24 * trace) & (qq > 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = best / np.sqrt(np.where(use, qq, 1.0))[:, None]
    x = lam[:, :1] * v1 + lam[:, 1:] * v2
    x = np.where((x[:, 3] < 0)[:, None], -x, x)
    return x[:, :4], x[:, 4:], use


def daniilidis_batch(C, H, alphas, prior=None, weights=None) -> dict:
    """Daniilidis on ``B`` validated problems at once: the motions are converted and aligned
    by the compiled kernel, the stacked matrices factored by batched QR + SVD (the same
    LAPACK routines as :func:`daniilidis`, so ``X[b]`` equals the single solve) and the
    closing 2x2 quadratic solved for all problems at once (rare degenerate cases one by
    one). ``C, H`` are float64, C-contiguous and checked for rigidity in the kernel
    (``batch_validates``: a problem with a non-rigid pose is reported in ``bad`` and
    ``solve_batch`` raises, naming it); no weights (``supports_weights=False``)."""
    from simcalib.solvers.kernels.batch import run_batch
    from simcalib.solvers.kernels.dqcore import DQOPT
    B = C.shape[0]
    kernel = run_batch(DQOPT, alphas, C=C, H=H, keep_q=True)
    Q, flips, bad = kernel["Q"], kernel["nflip"], kernel["bad"]
    if (bad >= 0).any():
        return {"X": np.full((B, 4, 4), np.nan), "bad": bad}
    qC, qH = np.swapaxes(Q[:, 0:4], 1, 2), np.swapaxes(Q[:, 4:8], 1, 2)
    qCd, qHd = np.swapaxes(Q[:, 8:12], 1, 2), np.swapaxes(Q[:, 12:16], 1, 2)
    T = _daniilidis_matrices(qC, qCd, qH, qHd, alphas)
    R = np.linalg.qr(T, mode="r") if T.shape[1] >= 8 else T
    _, sv, Vt = np.linalg.svd(R)
    X = np.full((B, 4, 4), np.nan)
    reason = np.full(B, "", dtype=object)
    top = sv[:, :1]
    n_null = np.where(top[:, 0] > 0, np.sum(sv <= NULL_TOL * top, axis=1), 8)
    ok = n_null <= 2
    q, qd, done = _unit_dual_quats_from_spans(Vt[:, -2, :], Vt[:, -1, :], ok)
    X[done] = transform_from_dual_quat(q[done], qd[done] / alphas[done, None])
    for b in np.flatnonzero(~done):   # rare: a larger null space or a degenerate span
        try:
            q_b, qd_b = unit_dual_quat_from_null_space(Vt[b, -max(int(n_null[b]), 2):])
        except ValueError as exc:
            reason[b] = f"degenerate motions for Daniilidis: {exc}"
            ok[b] = False
            continue
        X[b] = transform_from_dual_quat(q_b, qd_b / alphas[b])
        if not ok[b]:
            reason[b] = (f"degenerate motions for Daniilidis: {n_null[b]} near-zero singular "
                         "values (a unique X needs exactly 2)")
    from simcalib.solvers.problem import batch_cost
    return {"X": X, "success": ok, "failure_reason": reason, "sign_flips": flips,
            "cost": batch_cost(Q, X, alphas), "bad": bad}


@register("daniilidis", family="classic", uses_alpha=True, supports_prior=False,
          expected_cost_us=1000.0, batch=daniilidis_batch, batch_validates=True,
          needs_rotation=True,
          description="Daniilidis 1999 dual-quaternion SVD (translation scaled by alpha)")
def _daniilidis(problem: MotionProblem, alpha: float, prior, rng) -> SolverOutput:
    if prior is not None:
        raise ValueError("daniilidis does not support a prior; received prior="
                         f"{prior!r}; use a DQ method (e.g. dqopt) for priors")
    return daniilidis(problem, alpha)
