"""Dual-quaternion hand-eye solvers of Dekel et al. (CVPR 2020), section 3 and appendix A/E.

The cost (paper eq. 8) for unit dual quaternion ``q + eps q'`` of ``X``::

    sum_i |A_i q|^2 + alpha^2 |B_i q + A_i q'|^2,   |q| = 1,  q . q' = 0
    A_i = L(q_Ci) - R(q_Hi),  B_i = L(q'_Ci) - R(q'_Hi)

is the quadratic form ``q^T S q + q'^T M q' + 2 q^T W q'`` (eq. 9) with
``S = A^T A + alpha^2 B^T B``, ``M = alpha^2 A^T A``, ``W = alpha^2 B^T A``.
:func:`problem_matrices` returns them (with the prior substitution of eqs. 26-29).

The methods run as numba kernels (``_solve_core`` for one problem, ``_batch_kernel`` for a
batch, parallel over problems); see docs/solvers.md for the algorithms, the handling of
noise-free data (eigenvalues of M clipped at ``CLIP_REL``) and the sign re-alignment.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import dual_quat_from_transform, quat_conjugate, quat_left_matrix, \
    quat_right_matrix
from simcalib.solvers.problem import MotionProblem, SolverOutput
from simcalib.solvers.registry import register

__all__ = ["problem_matrices", "gram_blocks", "prior_terms", "solve_matrices", "eval_at_mu",
           "fast_build_problem", "align_problem", "data_cost", "batch_data_cost",
           "dual_quat_fast", "METHOD_CODES", "CLIP_REL"]

_G = np.diag([1.0, 1.0, 1.0, 0.0])


def gram_blocks(q_C, q_C_dual, q_H, q_H_dual):
    """``(A^T A, B^T B, B^T A)`` summed over motions; inputs ``(..., N, 4)``, outputs
    ``(..., 4, 4)``."""
    A = quat_left_matrix(q_C) - quat_right_matrix(q_H)
    B = quat_left_matrix(q_C_dual) - quat_right_matrix(q_H_dual)
    AtA = np.einsum("...nki,...nkj->...ij", A, A)
    BtB = np.einsum("...nki,...nkj->...ij", B, B)
    BtA = np.einsum("...nki,...nkj->...ij", B, A)
    return AtA, BtB, BtA


def prior_terms(prior):
    """``(S_add, W_add, M_add, const)`` of the prior (eqs. 26-29, NOTES.md errata).

    With ``Q^ = q^ + eps q^'`` the prior's dual quaternion, ``L* = L(conj q^)``,
    ``L'* = L(conj q^')``: ``S += a L*^T G L*``, ``W += b L'*^T L*``, ``M += b I``.
    The quadratic form then equals ``cost + a dq^T G dq + b |dq'|^2 - const`` with
    ``const = b |q^'|^2`` on the constraint set.
    """
    q_hat, q_hat_dual = dual_quat_from_transform(prior.X)
    Ls = quat_left_matrix(quat_conjugate(q_hat))
    Lds = quat_left_matrix(quat_conjugate(q_hat_dual))
    S_add = prior.a * Ls.T @ _G @ Ls
    W_add = prior.b * Lds.T @ Ls
    M_add = prior.b * np.eye(4)
    const = prior.b * float(q_hat_dual @ q_hat_dual)
    return S_add, W_add, M_add, const


def problem_matrices(problem: MotionProblem, alpha: float, prior=None):
    """``(S, W, M)`` of paper eq. (9) for ``problem`` (4x4 each, float64).

    With a :class:`simcalib.solvers.api.Prior` the substitution of eq. (29) is applied, so
    ``q^T S q + q'^T M q' + 2 q^T W q'`` equals the cost (8) plus the prior terms
    ``a |vec(dq)|^2 + b |dq'|^2`` minus the constant ``b |q^'|^2`` (``dQ = Q^* X``).
    """
    AtA, BtB, BtA = gram_blocks(problem.q_C, problem.q_C_dual, problem.q_H, problem.q_H_dual)
    a2 = float(alpha) ** 2
    S = AtA + a2 * BtB
    W = a2 * BtA
    M = a2 * AtA
    if prior is not None:
        S_add, W_add, M_add, _ = prior_terms(prior)
        S = S + S_add
        W = W + W_add
        M = M + M_add
    S = 0.5 * (S + S.T)
    M = 0.5 * (M + M.T)
    return S, W, M



# =====================================================================================
# Compiled kernels (numba). All per-problem work is scalar code on 4x4 matrices; batches
# run in parallel over problems.
# =====================================================================================
from numba import njit, prange  # noqa: E402

_EPS = 2.220446049250313e-16
#: eigenvalues of M below CLIP_REL * scale are raised to it (noise-free / degenerate data)
CLIP_REL = 1e-10

DQOPT, DQ2STEPS, DQCONVRLX, DQ2NDORD, DQ2NDORD_LAMBDA, DQITR = 0, 1, 2, 3, 4, 5
METHOD_CODES = {"dqopt": DQOPT, "dq2steps": DQ2STEPS, "dqconvrlx": DQCONVRLX,
                "dq2ndord": DQ2NDORD, "dq2ndord_lambda": DQ2NDORD_LAMBDA, "dqitr": DQITR}
# layout of the per-problem info vector
(I_MU, I_LAM0, I_LAM1, I_ITERS, I_NCLIP, I_LO, I_HI, I_F, I_DF, I_STATUS, I_XI0, I_XI3,
 I_COST) = range(13)
N_INFO = 13
# status codes
ST_OK, ST_MAXITER, ST_FALLBACK = 0, 1, 2


@njit(cache=True)
def _eigh(A, w, V):
    """Symmetric eigen-decomposition by cyclic Jacobi (accurate, small n); ascending ``w``,
    eigenvectors in the columns of ``V``."""
    n = A.shape[0]
    a = A.copy()
    for i in range(n):
        for j in range(n):
            V[i, j] = 1.0 if i == j else 0.0
    _jacobi(a, w, V)


@njit(cache=True)
def _eigh_warm(A, V0, w, V):
    """As :func:`_eigh`, starting from the approximate eigenvectors V0 (columns)."""
    n = A.shape[0]
    a = np.empty((n, n))
    tmp = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += A[i, k] * V0[k, j]
            tmp[i, j] = acc
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += V0[k, i] * tmp[k, j]
            a[i, j] = acc
            a[j, i] = acc
    for i in range(n):
        for j in range(n):
            V[i, j] = V0[i, j]
    _jacobi(a, w, V)


@njit(cache=True)
def _jacobi(a, w, V):
    """Cyclic Jacobi on the symmetric matrix a (overwritten); V accumulates rotations."""
    n = a.shape[0]
    for sweep in range(40):
        off = 0.0
        dg = 0.0
        for p in range(n):
            dg += a[p, p] * a[p, p]
            for q in range(p + 1, n):
                off += a[p, q] * a[p, q]
        if off == 0.0 or off <= 1e-38 * dg:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                if abs(apq) < 1e-20 * (abs(a[p, p]) + abs(a[q, q])):
                    a[p, q] = 0.0
                    a[q, p] = 0.0
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                if abs(theta) > 1e150:
                    t = 0.5 / theta
                else:
                    t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):
                    akp = a[k, p]
                    akq = a[k, q]
                    a[k, p] = c * akp - s * akq
                    a[k, q] = s * akp + c * akq
                for k in range(n):
                    apk = a[p, k]
                    aqk = a[q, k]
                    a[p, k] = c * apk - s * aqk
                    a[q, k] = s * apk + c * aqk
                for k in range(n):
                    vkp = V[k, p]
                    vkq = V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
    for i in range(n):
        w[i] = a[i, i]
    # insertion sort (ascending) with columns
    for i in range(1, n):
        j = i
        while j > 0 and w[j - 1] > w[j]:
            tmp = w[j - 1]
            w[j - 1] = w[j]
            w[j] = tmp
            for k in range(n):
                tmp = V[k, j - 1]
                V[k, j - 1] = V[k, j]
                V[k, j] = tmp
            j -= 1


@njit(cache=True, inline="always")
def _quat_dq_at(T, i):
    """(q, q') of the rigid transform T[i] as 8 scalars: same algorithm as
    geometry.quat_from_matrix (largest-diagonal branch, normalised, w >= 0) and
    q' = 1/2 (t, 0) (x) q."""
    m00 = T[i, 0, 0]
    m11 = T[i, 1, 1]
    m22 = T[i, 2, 2]
    d0 = 1.0 + m00 - m11 - m22
    d1 = 1.0 - m00 + m11 - m22
    d2 = 1.0 - m00 - m11 + m22
    d3 = 1.0 + m00 + m11 + m22
    k = 0
    dk = d0
    if d1 > dk:
        k = 1
        dk = d1
    if d2 > dk:
        k = 2
        dk = d2
    if d3 > dk:
        k = 3
        dk = d3
    s = 2.0 * np.sqrt(max(dk, 1e-300))
    inv = 1.0 / s
    d21 = (T[i, 2, 1] - T[i, 1, 2]) * inv
    d02 = (T[i, 0, 2] - T[i, 2, 0]) * inv
    d10 = (T[i, 1, 0] - T[i, 0, 1]) * inv
    s01 = (T[i, 0, 1] + T[i, 1, 0]) * inv
    s02 = (T[i, 0, 2] + T[i, 2, 0]) * inv
    s12 = (T[i, 1, 2] + T[i, 2, 1]) * inv
    if k == 0:
        x, y, z, w = 0.25 * s, s01, s02, d21
    elif k == 1:
        x, y, z, w = s01, 0.25 * s, s12, d02
    elif k == 2:
        x, y, z, w = s02, s12, 0.25 * s, d10
    else:
        x, y, z, w = d21, d02, d10, 0.25 * s
    nrm = 1.0 / np.sqrt(x * x + y * y + z * z + w * w)
    if w < 0.0:
        nrm = -nrm
    x *= nrm
    y *= nrm
    z *= nrm
    w *= nrm
    tx = 0.5 * T[i, 0, 3]
    ty = 0.5 * T[i, 1, 3]
    tz = 0.5 * T[i, 2, 3]
    # (t,0) (x) q with L(p) rows [w,-z,y,x],[z,w,-x,y],[-y,x,w,z],[-x,-y,-z,w], p_w = 0
    return (x, y, z, w, -tz * y + ty * z + tx * w, tz * x - tx * z + ty * w,
            -ty * x + tx * y + tz * w, -tx * x - ty * y - tz * z)


@njit(cache=True)
def _quat_dq(T, q, qd):
    """(q, q') of one 4x4 transform into q, qd."""
    T3 = T.reshape((1, 4, 4))
    r = _quat_dq_at(T3, 0)
    for k in range(4):
        q[k] = r[k]
        qd[k] = r[4 + k]


@njit(cache=True, inline="always")
def _rigid_ok_at(T, i, tol):
    tot = 0.0
    for r in range(4):
        for c in range(4):
            tot += T[i, r, c]
    if not np.isfinite(tot):
        return False
    if (abs(T[i, 3, 0]) > tol or abs(T[i, 3, 1]) > tol or abs(T[i, 3, 2]) > tol
            or abs(T[i, 3, 3] - 1.0) > tol):
        return False
    for a in range(3):
        for b in range(a, 3):
            g = T[i, 0, a] * T[i, 0, b] + T[i, 1, a] * T[i, 1, b] + T[i, 2, a] * T[i, 2, b]
            if a == b:
                g -= 1.0
            if abs(g) > tol:
                return False
    det = (T[i, 0, 0] * (T[i, 1, 1] * T[i, 2, 2] - T[i, 1, 2] * T[i, 2, 1])
           - T[i, 0, 1] * (T[i, 1, 0] * T[i, 2, 2] - T[i, 1, 2] * T[i, 2, 0])
           + T[i, 0, 2] * (T[i, 1, 0] * T[i, 2, 1] - T[i, 1, 1] * T[i, 2, 0]))
    return abs(det - 1.0) <= tol


@njit(cache=True)
def _quats_kernel(C, H, tol, qC, qCd, qH, qHd):
    """Validate and convert (N,4,4) C, H to sign-aligned dual quaternions. Returns the
    index of the first invalid motion (or -1)."""
    n = C.shape[0]
    for i in range(n):
        if not _rigid_ok_at(C, i, tol) or not _rigid_ok_at(H, i, tol):
            return i
        rc = _quat_dq_at(C, i)
        rh = _quat_dq_at(H, i)
        sg = -1.0 if rc[3] * rh[3] < 0.0 else 1.0
        for k in range(4):
            qC[i, k] = rc[k]
            qCd[i, k] = rc[4 + k]
            qH[i, k] = sg * rh[k]
            qHd[i, k] = sg * rh[4 + k]
    return -1


def _lr_tensors():
    """T[x][i, j] = X(e_i)^T Y(e_j) for (X, Y) in LR, LL, RL, RR, so that
    sum_i X(a_i)^T Y(b_i) = sum_jk P_jk T[j, k] with P = sum_i a_i b_i^T."""
    from simcalib.geometry import quat_left_matrix as _L, quat_right_matrix as _R
    E = np.eye(4)
    pairs = ((_L, _R), (_L, _L), (_R, _L), (_R, _R))
    return np.ascontiguousarray(np.array(
        [[[f(E[i]).T @ g(E[j]) for j in range(4)] for i in range(4)] for f, g in pairs]))


_T = _lr_tensors()   # (4 [LR, LL, RL, RR], 4, 4, 4, 4)


@njit(cache=True, fastmath={"reassoc", "contract"})
def _dot_rows(Q, a, b, n):
    s = 0.0
    for m in range(n):
        s += Q[a, m] * Q[b, m]
    return s


@njit(cache=True)
def _outer_from_soa(Q, n, P, nrm):
    """Q (16, N) rows: c (0-3), h (4-7), c' (8-11), h' (12-15). Fills the summed outer
    products P[0] = sum c h^T, P[1] = c' h'^T, P[2] = c' c^T, P[3] = c' h^T, P[4] = h' c^T,
    P[5] = h' h^T and nrm = (sum |c|^2+|h|^2, sum |c'|^2+|h'|^2)."""
    for i in range(4):
        for j in range(4):
            P[0, i, j] = _dot_rows(Q, i, 4 + j, n)
            P[1, i, j] = _dot_rows(Q, 8 + i, 12 + j, n)
            P[2, i, j] = _dot_rows(Q, 8 + i, j, n)
            P[3, i, j] = _dot_rows(Q, 8 + i, 4 + j, n)
            P[4, i, j] = _dot_rows(Q, 12 + i, j, n)
            P[5, i, j] = _dot_rows(Q, 12 + i, 4 + j, n)
    s0 = 0.0
    s1 = 0.0
    for i in range(8):
        s0 += _dot_rows(Q, i, i, n)
        s1 += _dot_rows(Q, 8 + i, 8 + i, n)
    nrm[0] = s0
    nrm[1] = s1


@njit(cache=True)
def _quats_soa(C, H, tol, Q):
    """Validate + convert motions into Q (16, N) (sign-aligned); returns first bad index
    or -1."""
    for i in range(C.shape[0]):
        if not _rigid_ok_at(C, i, tol) or not _rigid_ok_at(H, i, tol):
            return i
        rc = _quat_dq_at(C, i)
        rh = _quat_dq_at(H, i)
        sg = -1.0 if rc[3] * rh[3] < 0.0 else 1.0
        for k in range(4):
            Q[k, i] = rc[k]
            Q[4 + k, i] = sg * rh[k]
            Q[8 + k, i] = rc[4 + k]
            Q[12 + k, i] = sg * rh[4 + k]
    return -1


@njit(cache=True)
def _contract(T, k, P, sign, out):
    for j in range(4):
        for l in range(4):
            p = sign * P[j, l]
            if p != 0.0:
                for a in range(4):
                    for b in range(4):
                        out[a, b] += p * T[k, j, l, a, b]


@njit(cache=True)
def _grams_from_outer(T, P, nrm, AtA, BtB, BtA):
    """A^T A, B^T B, B^T A from the accumulated outer products (A = L(c) - R(h), ...)."""
    X1 = np.zeros((4, 4))
    X2 = np.zeros((4, 4))
    _contract(T, 0, P[0], 1.0, X1)      # sum L(c)^T R(h)
    _contract(T, 0, P[1], 1.0, X2)      # sum L(c')^T R(h')
    for a in range(4):
        for b in range(4):
            AtA[a, b] = -(X1[a, b] + X1[b, a])
            BtB[a, b] = -(X2[a, b] + X2[b, a])
            BtA[a, b] = 0.0
        AtA[a, a] += nrm[0]
        BtB[a, a] += nrm[1]
    _contract(T, 1, P[2], 1.0, BtA)     # L(c')^T L(c)
    _contract(T, 0, P[3], -1.0, BtA)    # - L(c')^T R(h)
    _contract(T, 2, P[4], -1.0, BtA)    # - R(h')^T L(c)
    _contract(T, 3, P[5], 1.0, BtA)     # + R(h')^T R(h)


@njit(cache=True)
def _grams_kernel(T, qC, qCd, qH, qHd, AtA, BtB, BtA):
    n = qC.shape[0]
    Q = np.empty((16, n))
    for i in range(n):
        for k in range(4):
            Q[k, i] = qC[i, k]
            Q[4 + k, i] = qH[i, k]
            Q[8 + k, i] = qCd[i, k]
            Q[12 + k, i] = qHd[i, k]
    P = np.empty((6, 4, 4))
    nrm = np.empty(2)
    _outer_from_soa(Q, n, P, nrm)
    _grams_from_outer(T, P, nrm, AtA, BtB, BtA)


@njit(cache=True)
def _m_eig(S, M, xi, V):
    """Eigen-decomposition of M with eigenvalues clipped to >= CLIP_REL * scale (scale = the
    largest eigenvalue of M, or trace(S)/4 when M is ~0).
    Returns how many were clipped (noise-free or degenerate data: M is singular)."""
    _eigh(M, xi, V)
    scale = xi[3]
    tr = (S[0, 0] + S[1, 1] + S[2, 2] + S[3, 3]) * 0.25
    if scale < 1e-14 * tr:   # M ~ 0 (pure translation): relative to S instead
        scale = tr
    floor = CLIP_REL * scale
    if floor < 1e-280:
        floor = 1e-280
    nclip = 0
    for k in range(4):
        if xi[k] < floor:
            xi[k] = floor
            nclip += 1
    return nclip


@njit(cache=True)
def _zmat(S, WV, V, xi, mu, Z):
    """Z(mu) = S - (W - mu) M^-1 (W - mu)^T = Z0 + mu Z1 - mu^2 Z2 (eq. 12)."""
    for i in range(4):
        for j in range(i, 4):
            acc = S[i, j]
            for k in range(4):
                acc -= (WV[i, k] - mu * V[i, k]) * (WV[j, k] - mu * V[j, k]) / xi[k]
            Z[i, j] = acc
            Z[j, i] = acc


@njit(cache=True)
def _proj(E, col, WV, V, mu, pv, pu):
    """pv[k] = e . v_k, pu[k] = e . u_k with u_k = (W - mu) v_k, e = E[:, col]."""
    for k in range(4):
        sv = 0.0
        su = 0.0
        for i in range(4):
            sv += E[i, col] * V[i, k]
            su += E[i, col] * (WV[i, k] - mu * V[i, k])
        pv[k] = sv
        pu[k] = su


@njit(cache=True)
def _f_df(E, lam, WV, V, xi, mu, pv, pu, pva, pua):
    """f(mu) = q0 . q0' (eq. 18) and its derivative (first-order perturbation of q0)."""
    _proj(E, 0, WV, V, mu, pv, pu)
    f = 0.0
    qz2q = 0.0
    for k in range(4):
        f -= pv[k] * pu[k] / xi[k]
        qz2q += pv[k] * pv[k] / xi[k]
    df = qz2q
    for a in range(1, 4):
        _proj(E, a, WV, V, mu, pva, pua)
        za = 0.0
        for k in range(4):
            za += (pua[k] * pv[k] + pva[k] * pu[k]) / xi[k]
        gap = lam[a] - lam[0]
        if gap > 0.0:
            df += za * za / gap
    return f, df


@njit(cache=True)
def _mu_tilde(q, WV, V, xi):
    """mu~(q) = 1/2 q.Z1.q / q.Z2.q (eq. 14/24)."""
    num = 0.0
    den = 0.0
    for k in range(4):
        pv = 0.0
        pw = 0.0
        for i in range(4):
            pv += q[i] * V[i, k]
            pw += q[i] * WV[i, k]
        num += pv * pw / xi[k]
        den += pv * pv / xi[k]
    return num / den


@njit(cache=True)
def _qdual(q, mu, WV, V, xi, qd):
    """q' = M^-1 (mu - W^T) q (eq. 11), with the component along the smallest eigenvector
    of M taken from the constraint q . q' = 0 when that eigenvalue is small (stable for
    nearly singular M)."""
    c = np.empty(4)
    pv = np.empty(4)
    for k in range(4):
        sv = 0.0
        sw = 0.0
        for i in range(4):
            sv += q[i] * V[i, k]
            sw += q[i] * WV[i, k]
        pv[k] = sv
        c[k] = (mu * sv - sw) / xi[k]
    if xi[0] < 1e-6 * xi[3] and abs(pv[0]) > 0.5:
        acc = 0.0
        for k in range(1, 4):
            acc += c[k] * pv[k]
        c[0] = -acc / pv[0]
    for i in range(4):
        acc = 0.0
        for k in range(4):
            acc += V[i, k] * c[k]
        qd[i] = acc
    # exact projection onto q . q' = 0 (q is unit)
    dot = q[0] * qd[0] + q[1] * qd[1] + q[2] * qd[2] + q[3] * qd[3]
    for i in range(4):
        qd[i] -= dot * q[i]


@njit(cache=True)
def _z_basis(E, WV, V, xi, Z1ab, Z2ab):
    """Z1^{ab} = q_a Z1 q_b, Z2^{ab} = q_a Z2 q_b in the eigenbasis E of Z0."""
    P = np.empty((4, 4))
    R = np.empty((4, 4))
    for a in range(4):
        for k in range(4):
            sv = 0.0
            sw = 0.0
            for i in range(4):
                sv += E[i, a] * V[i, k]
                sw += E[i, a] * WV[i, k]
            P[a, k] = sv
            R[a, k] = sw
    for a in range(4):
        for b in range(4):
            z1 = 0.0
            z2 = 0.0
            for k in range(4):
                z1 += (R[a, k] * P[b, k] + P[a, k] * R[b, k]) / xi[k]
                z2 += P[a, k] * P[b, k] / xi[k]
            Z1ab[a, b] = z1
            Z2ab[a, b] = z2


@njit(cache=True)
def _second_order_mu(E, lam, Z1ab, Z2ab, q):
    """DQ2ndOrd, eq. (23): mu_(2) and q_(2) (unnormalised) from the Z0 eigenbasis."""
    den = Z2ab[0, 0]
    for a in range(1, 4):
        den -= Z1ab[a, 0] ** 2 / (lam[0] - lam[a])
    mu = 0.5 * Z1ab[0, 0] / den
    s1 = 0.0
    for a in range(1, 4):
        s1 += (Z1ab[a, 0] / (lam[0] - lam[a])) ** 2
    coef = np.zeros(4)
    coef[0] = 1.0 - 0.5 * mu * mu * s1
    for a in range(1, 4):
        l0a = lam[0] - lam[a]
        inner = 0.0
        for b in range(1, 4):
            inner += Z1ab[b, 0] * Z1ab[a, b] / (lam[0] - lam[b])
        inner = inner - Z2ab[a, 0] - Z1ab[0, 0] * Z1ab[a, 0] / l0a
        coef[a] = mu * Z1ab[a, 0] / l0a + mu * mu * inner / l0a
    for i in range(4):
        acc = 0.0
        for a in range(4):
            acc += coef[a] * E[i, a]
        q[i] = acc
    return mu


@njit(cache=True)
def _second_order_lambda(E, lam, Z1ab, Z2ab, q):
    """DQ2ndOrd in Delta-lambda (appendix A, eqs. 35-36, derived for Z = Z0 + mu Z1 - mu^2 Z2;
    the printed appendix uses the opposite sign of the Z2 term). Returns False when the
    expansion is undefined (q0 Z1 q0 = 0, i.e. noise-free: then q = q0)."""
    z100 = Z1ab[0, 0]
    for i in range(4):
        q[i] = E[i, 0]
    if z100 == 0.0:
        return False
    m1 = 1.0 / z100
    c1a = np.zeros(4)
    for a in range(1, 4):
        c1a[a] = m1 * Z1ab[a, 0] / (lam[0] - lam[a])
    # q0 Z1 q1, q1 Z1 q1, q0 Z2 q1
    q0z1q1 = 0.0
    q0z2q1 = 0.0
    q1z1q1 = 0.0
    for a in range(1, 4):
        q0z1q1 += Z1ab[0, a] * c1a[a]
        q0z2q1 += Z2ab[0, a] * c1a[a]
        for b in range(1, 4):
            q1z1q1 += c1a[a] * Z1ab[a, b] * c1a[b]
    m2 = (m1 * m1 * Z2ab[0, 0] - m1 * q0z1q1) / z100
    c2a = np.zeros(4)
    nrm1 = 0.0
    for a in range(1, 4):
        nrm1 += c1a[a] * c1a[a]
        qaz1q1 = 0.0
        for b in range(1, 4):
            qaz1q1 += Z1ab[a, b] * c1a[b]
        c2a[a] = (m1 * qaz1q1 + m2 * Z1ab[a, 0] - m1 * m1 * Z2ab[a, 0] - c1a[a]) / (lam[0] - lam[a])
    c2a[0] = -0.5 * nrm1
    q0z1q2 = 0.0
    for a in range(4):
        q0z1q2 += Z1ab[0, a] * c2a[a]
    k0 = -0.5 * z100
    k1 = m1 * Z2ab[0, 0] - q0z1q1
    k2 = m2 * Z2ab[0, 0] + 2.0 * m1 * q0z2q1 - q0z1q2 - 0.5 * q1z1q1
    disc = k1 * k1 - 4.0 * k0 * k2
    if disc >= 0.0 and k1 != 0.0:
        sq = np.sqrt(disc)
        if k1 < 0.0:
            sq = -sq
        dl = -2.0 * k0 / (k1 + sq)
    elif k1 != 0.0:
        dl = -k0 / k1
    else:
        return False
    coef = np.zeros(4)
    coef[0] = 1.0 + dl * dl * c2a[0]
    for a in range(1, 4):
        coef[a] = dl * c1a[a] + dl * dl * c2a[a]
    for i in range(4):
        acc = 0.0
        for a in range(4):
            acc += coef[a] * E[i, a]
        if not np.isfinite(acc):
            for j in range(4):
                q[j] = E[j, 0]
            return False
        q[i] = acc
    return True


@njit(cache=True)
def _normalize(q):
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        q[i] /= n


@njit(cache=True)
def _m_eig_wv(S, W, M, xi, V, WV):
    """Eigen-decomposition of M (clipped as in the solvers) and W @ V; returns the clip count."""
    nclip = _m_eig(S, M, xi, V)
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for k in range(4):
                acc += W[i, k] * V[k, j]
            WV[i, j] = acc
    return nclip


@njit(cache=True)
def _solve_core(method, S, W, M, q, qd, info):
    """One DQ problem given (S, W, M) (eq. 9, prior included). Writes q, q' and info."""
    xi = np.empty(4)
    V = np.empty((4, 4))
    WV = np.empty((4, 4))
    nclip = _m_eig_wv(S, W, M, xi, V, WV)
    Z = np.empty((4, 4))
    lam = np.empty(4)
    E = np.empty((4, 4))
    pv = np.empty(4)
    pu = np.empty(4)
    pva = np.empty(4)
    pua = np.empty(4)
    mu = 0.0
    iters = 0
    status = ST_OK
    lo = np.nan
    hi = np.nan
    f = np.nan
    df = np.nan
    if method == DQ2STEPS:
        for i in range(4):
            q[i] = V[i, 0]
        mu = _mu_tilde(q, WV, V, xi)
    elif method == DQOPT:
        # bracket (appendix C): mu* lies in [k_min, k_max], the extreme eigenvalues of
        # K = sym(M^1/2 W M^-1/2); here the cheaper valid bound |mu*| <= ||K||_F (the exact
        # eigenvalue bracket is reported by the certificate).
        kf = 0.0
        for a in range(4):
            for b in range(4):
                wab = 0.0
                wba = 0.0
                for i in range(4):
                    wab += V[i, a] * WV[i, b]
                    wba += V[i, b] * WV[i, a]
                kab = 0.5 * (np.sqrt(xi[a] / xi[b]) * wab + np.sqrt(xi[b] / xi[a]) * wba)
                kf += kab * kab
        kf = np.sqrt(kf)
        lo = -kf * (1.0 + 1e-12) - 1e-300
        hi = kf * (1.0 + 1e-12) + 1e-300
        mu = 0.0
        blo = lo
        bhi = hi
        E0 = np.empty((4, 4))
        for it in range(200):
            _zmat(S, WV, V, xi, mu, Z)
            if it == 0:
                _eigh(Z, lam, E)
            else:
                for i in range(4):
                    for j in range(4):
                        E0[i, j] = E[i, j]
                _eigh_warm(Z, E0, lam, E)
            f, df = _f_df(E, lam, WV, V, xi, mu, pv, pu, pva, pua)
            iters += 1
            qdn = 0.0
            for k in range(4):
                qdn += (pu[k] / xi[k]) ** 2
            ftol = 4.0 * _EPS * (1.0 + np.sqrt(qdn))
            if abs(f) <= ftol:
                for i in range(4):
                    q[i] = E[i, 0]
                break
            if f > 0.0:
                bhi = mu
            else:
                blo = mu
            step = f / df if df > 0.0 else 0.0
            mu_new = mu - step
            if abs(f) <= 1e6 * ftol and mu_new > blo and mu_new < bhi:
                # Newton is in its quadratic regime: the remaining error after this step is
                # O(f^2); move q to mu_new by first-order perturbation and stop.
                for i in range(4):
                    q[i] = E[i, 0]
                dmu = mu_new - mu
                for a in range(1, 4):
                    _proj(E, a, WV, V, mu, pva, pua)
                    za = 0.0
                    for k in range(4):
                        za += (pua[k] * pv[k] + pva[k] * pu[k]) / xi[k]
                    gap = lam[0] - lam[a]
                    if gap < 0.0:
                        for i in range(4):
                            q[i] += dmu * za / gap * E[i, a]
                mu = mu_new
                break
            if not (mu_new > blo and mu_new < bhi):
                mu_new = 0.5 * (blo + bhi)
            if abs(mu_new - mu) <= 2.0 * _EPS * abs(mu) or bhi - blo <= 4.0 * _EPS * max(abs(blo), abs(bhi)):
                for i in range(4):
                    q[i] = E[i, 0]
                break
            mu = mu_new
        else:
            status = ST_MAXITER
            for i in range(4):
                q[i] = E[i, 0]
    elif method == DQITR:
        converged = False
        E0 = np.empty((4, 4))
        for it in range(500):
            _zmat(S, WV, V, xi, mu, Z)
            if it == 0:
                _eigh(Z, lam, E)
            else:
                for i in range(4):
                    for j in range(4):
                        E0[i, j] = E[i, j]
                _eigh_warm(Z, E0, lam, E)
            iters += 1
            for i in range(4):
                q[i] = E[i, 0]
            mu_new = _mu_tilde(q, WV, V, xi)
            if abs(mu_new - mu) <= 1e-14 * abs(mu_new) or mu_new == mu:
                mu = mu_new
                converged = True
                break
            mu = mu_new
        if not converged:
            status = ST_MAXITER
    else:
        # relaxed problem: Z0 = Z(0)
        _zmat(S, WV, V, xi, 0.0, Z)
        _eigh(Z, lam, E)
        if method == DQCONVRLX:
            for i in range(4):
                q[i] = E[i, 0]
        else:
            Z1ab = np.empty((4, 4))
            Z2ab = np.empty((4, 4))
            _z_basis(E, WV, V, xi, Z1ab, Z2ab)
            if method == DQ2NDORD:
                _second_order_mu(E, lam, Z1ab, Z2ab, q)
                ok = True
                for i in range(4):
                    if not np.isfinite(q[i]):
                        ok = False
                if not ok:
                    for i in range(4):
                        q[i] = E[i, 0]
                    status = ST_FALLBACK
            else:
                if not _second_order_lambda(E, lam, Z1ab, Z2ab, q):
                    status = ST_FALLBACK
        _normalize(q)
        mu = _mu_tilde(q, WV, V, xi)
    _normalize(q)
    _qdual(q, mu, WV, V, xi, qd)
    if method == DQ2STEPS:
        lam[0] = np.nan  # no eigen-decomposition of Z was needed
        lam[1] = np.nan
    # objective (quadratic form of eq. 9 with these S, W, M)
    cost = 0.0
    for i in range(4):
        for j in range(4):
            cost += q[i] * S[i, j] * q[j] + qd[i] * M[i, j] * qd[j] + 2.0 * q[i] * W[i, j] * qd[j]
    info[I_MU] = mu
    info[I_LAM0] = lam[0]
    info[I_LAM1] = lam[1]
    info[I_ITERS] = iters
    info[I_NCLIP] = nclip
    info[I_LO] = lo
    info[I_HI] = hi
    info[I_F] = f
    info[I_DF] = df
    info[I_STATUS] = status
    info[I_XI0] = xi[0]
    info[I_XI3] = xi[3]
    info[I_COST] = cost


@njit(cache=True)
def _transform_from_dq(q, qd, X):
    x, y, z, w = q[0], q[1], q[2], q[3]
    X[0, 0] = 1 - 2 * (y * y + z * z)
    X[0, 1] = 2 * (x * y - z * w)
    X[0, 2] = 2 * (x * z + y * w)
    X[1, 0] = 2 * (x * y + z * w)
    X[1, 1] = 1 - 2 * (x * x + z * z)
    X[1, 2] = 2 * (y * z - x * w)
    X[2, 0] = 2 * (x * z - y * w)
    X[2, 1] = 2 * (y * z + x * w)
    X[2, 2] = 1 - 2 * (x * x + y * y)
    # t = 2 q' (x) conj(q), vector part
    a, b, c, d = qd[0], qd[1], qd[2], qd[3]
    X[0, 3] = 2.0 * (-d * x + a * w - b * z + c * y)
    X[1, 3] = 2.0 * (-d * y + b * w - c * x + a * z)
    X[2, 3] = 2.0 * (-d * z + c * w - a * y + b * x)
    X[3, 0] = 0.0
    X[3, 1] = 0.0
    X[3, 2] = 0.0
    X[3, 3] = 1.0


@njit(cache=True)
def _cost_soa(Q, n, q, qd, a2):
    """Cost (8) motion by motion from the SoA quaternions Q (16, N)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    dx, dy, dz, dw = qd[0], qd[1], qd[2], qd[3]
    tot = 0.0
    for i in range(n):
        p = _qmul(Q[0, i], Q[1, i], Q[2, i], Q[3, i], x, y, z, w)
        r = _qmul(x, y, z, w, Q[4, i], Q[5, i], Q[6, i], Q[7, i])
        p1 = _qmul(Q[8, i], Q[9, i], Q[10, i], Q[11, i], x, y, z, w)
        p2 = _qmul(x, y, z, w, Q[12, i], Q[13, i], Q[14, i], Q[15, i])
        p3 = _qmul(Q[0, i], Q[1, i], Q[2, i], Q[3, i], dx, dy, dz, dw)
        p4 = _qmul(dx, dy, dz, dw, Q[4, i], Q[5, i], Q[6, i], Q[7, i])
        for k in range(4):
            tot += (p[k] - r[k]) ** 2 + a2 * (p1[k] - p2[k] + p3[k] - p4[k]) ** 2
    return tot


@njit(cache=True)
def _align_soa(T, Q, n, alpha, q, qd, info, AtA, BtB, BtA):
    """Sign alignment of the motion pairs beyond the scalar-part rule of NOTES.md.

    Near 180 deg rotations the scalar parts of q_C and q_H are ~0 and noise can give them
    the same sign although the pair is anti-aligned, turning the motion into a gross outlier
    (|A_i q|^2 ~ 4). With the optimal (dqopt) rotation q of the problem, flip (q_H, q_H')
    of every motion with (q_C (x) q) . (q (x) q_H) < 0 (then |q_C q + q q_H| < |q_C q - q q_H|),
    re-solve, repeat until stable. Exact pairs and pairs away from 180 deg are unchanged.
    Returns the number of flips; q, qd, info hold the dqopt solution (no prior) and AtA,
    BtB, BtA the Gram blocks of the final Q.
    """
    P = np.empty((6, 4, 4))
    nrm = np.empty(2)
    S = np.empty((4, 4))
    W = np.empty((4, 4))
    M = np.empty((4, 4))
    a2 = alpha * alpha
    total = 0
    nflip = 0
    for rnd in range(4):
        _outer_from_soa(Q, n, P, nrm)
        _grams_from_outer(T, P, nrm, AtA, BtB, BtA)
        for i in range(4):
            for j in range(4):
                S[i, j] = 0.5 * (AtA[i, j] + AtA[j, i]) + a2 * 0.5 * (BtB[i, j] + BtB[j, i])
                W[i, j] = a2 * BtA[i, j]
                M[i, j] = a2 * 0.5 * (AtA[i, j] + AtA[j, i])
        _solve_core(DQOPT, S, W, M, q, qd, info)
        nflip = 0
        for i in range(n):
            if abs(Q[3, i]) > 0.25 and abs(Q[7, i]) > 0.25:
                continue  # scalar-part rule reliable (rotation > 30 deg from 180 deg)
            a = _qmul(Q[0, i], Q[1, i], Q[2, i], Q[3, i], q[0], q[1], q[2], q[3])
            b = _qmul(q[0], q[1], q[2], q[3], Q[4, i], Q[5, i], Q[6, i], Q[7, i])
            if a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0:
                for k in range(4):
                    Q[4 + k, i] = -Q[4 + k, i]
                    Q[12 + k, i] = -Q[12 + k, i]
                nflip += 1
        total += nflip
        if nflip == 0:
            break
    if nflip > 0:  # stopped after flipping: Gram blocks and solution of the final Q
        _outer_from_soa(Q, n, P, nrm)
        _grams_from_outer(T, P, nrm, AtA, BtB, BtA)
        for i in range(4):
            for j in range(4):
                S[i, j] = 0.5 * (AtA[i, j] + AtA[j, i]) + a2 * 0.5 * (BtB[i, j] + BtB[j, i])
                W[i, j] = a2 * BtA[i, j]
                M[i, j] = a2 * 0.5 * (AtA[i, j] + AtA[j, i])
        _solve_core(DQOPT, S, W, M, q, qd, info)
    return total


@njit(cache=True)
def _align_arrays(T, qC, qCd, qH, qHd, alpha):
    n = qC.shape[0]
    Q = np.empty((16, n))
    for i in range(n):
        for k in range(4):
            Q[k, i] = qC[i, k]
            Q[4 + k, i] = qH[i, k]
            Q[8 + k, i] = qCd[i, k]
            Q[12 + k, i] = qHd[i, k]
    q = np.empty(4)
    qd = np.empty(4)
    info = np.empty(N_INFO)
    AtA = np.empty((4, 4))
    BtB = np.empty((4, 4))
    BtA = np.empty((4, 4))
    nf = _align_soa(T, Q, n, alpha, q, qd, info, AtA, BtB, BtA)
    if nf > 0:
        for i in range(n):
            for k in range(4):
                qH[i, k] = Q[4 + k, i]
                qHd[i, k] = Q[12 + k, i]
    return nf


@njit(cache=True, parallel=True)
def _batch_kernel(method, T, C, H, alphas, tol, has_prior, S_add, W_add, M_add, X, cost, info,
                  bad, nflip):
    """Fused batch: validate + convert + accumulate + solve + X + data cost, per problem."""
    nb = C.shape[0]
    n = C.shape[1]
    for b in prange(nb):
        Q = np.empty((16, n))
        P = np.empty((6, 4, 4))
        nrm = np.empty(2)
        AtA = np.empty((4, 4))
        BtB = np.empty((4, 4))
        BtA = np.empty((4, 4))
        bad[b] = _quats_soa(C[b], H[b], tol, Q)
        if bad[b] >= 0:
            continue
        q = np.empty(4)
        qd = np.empty(4)
        nflip[b] = _align_soa(T, Q, n, alphas[b], q, qd, info[b], AtA, BtB, BtA)
        a2 = alphas[b] * alphas[b]
        S = np.empty((4, 4))
        W = np.empty((4, 4))
        M = np.empty((4, 4))
        for i in range(4):
            for j in range(4):
                S[i, j] = 0.5 * (AtA[i, j] + AtA[j, i]) + a2 * 0.5 * (BtB[i, j] + BtB[j, i]) + S_add[i, j]
                W[i, j] = a2 * BtA[i, j] + W_add[i, j]
                M[i, j] = a2 * 0.5 * (AtA[i, j] + AtA[j, i]) + M_add[i, j]
        if method != DQOPT or has_prior:
            _solve_core(method, S, W, M, q, qd, info[b])
        _transform_from_dq(q, qd, X[b])
        # data cost (8): Gram form; recomputed motion by motion when small relative to the
        # scale (the Gram form loses digits there: noise-free or low-noise data)
        cst = 0.0
        scale = 0.0
        for i in range(4):
            scale += AtA[i, i] + a2 * BtB[i, i]
            for j in range(4):
                cst += q[i] * AtA[i, j] * q[j] + a2 * (q[i] * BtB[i, j] * q[j]
                                                       + 2.0 * q[i] * BtA[i, j] * qd[j]
                                                       + qd[i] * AtA[i, j] * qd[j])
        if cst < 1e-5 * scale:
            cst = _cost_soa(Q, n, q, qd, a2)
        cost[b] = cst


@njit(cache=True)
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product (x, y, z, w) of a and b."""
    return (a3 * b0 + b3 * a0 + a1 * b2 - a2 * b1,
            a3 * b1 + b3 * a1 + a2 * b0 - a0 * b2,
            a3 * b2 + b3 * a2 + a0 * b1 - a1 * b0,
            a3 * b3 - a0 * b0 - a1 * b1 - a2 * b2)


@njit(cache=True)
def _cost_kernel(qC, qCd, qH, qHd, q, qd, alpha):
    """Cost (8) summed motion by motion: |c q - q h|^2 + alpha^2 |c' q - q h' + c q' - q' h|^2."""
    a2 = alpha * alpha
    tot = 0.0
    x, y, z, w = q[0], q[1], q[2], q[3]
    dx, dy, dz, dw = qd[0], qd[1], qd[2], qd[3]
    for i in range(qC.shape[0]):
        c = qC[i]
        cd = qCd[i]
        h = qH[i]
        hd = qHd[i]
        p = _qmul(c[0], c[1], c[2], c[3], x, y, z, w)
        r = _qmul(x, y, z, w, h[0], h[1], h[2], h[3])
        s1 = 0.0
        for k in range(4):
            s1 += (p[k] - r[k]) ** 2
        p1 = _qmul(cd[0], cd[1], cd[2], cd[3], x, y, z, w)
        p2 = _qmul(x, y, z, w, hd[0], hd[1], hd[2], hd[3])
        p3 = _qmul(c[0], c[1], c[2], c[3], dx, dy, dz, dw)
        p4 = _qmul(dx, dy, dz, dw, h[0], h[1], h[2], h[3])
        s2 = 0.0
        for k in range(4):
            s2 += (p1[k] - p2[k] + p3[k] - p4[k]) ** 2
        tot += s1 + a2 * s2
    return tot


@njit(cache=True)
def _solve_from_quats(method, T, qC, qCd, qH, qHd, alpha, S_add, W_add, M_add, q, qd, X,
                      info):
    AtA = np.empty((4, 4))
    BtB = np.empty((4, 4))
    BtA = np.empty((4, 4))
    _grams_kernel(T, qC, qCd, qH, qHd, AtA, BtB, BtA)
    a2 = alpha * alpha
    S = np.empty((4, 4))
    W = np.empty((4, 4))
    M = np.empty((4, 4))
    for i in range(4):
        for j in range(4):
            S[i, j] = 0.5 * (AtA[i, j] + AtA[j, i]) + a2 * 0.5 * (BtB[i, j] + BtB[j, i]) + S_add[i, j]
            W[i, j] = a2 * BtA[i, j] + W_add[i, j]
            M[i, j] = a2 * 0.5 * (AtA[i, j] + AtA[j, i]) + M_add[i, j]
    _solve_core(method, S, W, M, q, qd, info)
    _transform_from_dq(q, qd, X)


# ----------------------------------------------------------------------- python glue
_TOL = 1e-6  # geometry.ORTHONORMAL_TOL


def fast_build_problem(C, H, alpha: float = 1.0, return_flips: bool = False):
    """:func:`simcalib.solvers.problem.build_problem` through a compiled path (invalid input
    is handed to build_problem, which raises its error), followed by the sign re-alignment
    of near-180-degree motion pairs with the optimal rotation at ``alpha`` (see
    ``_align_soa``; NOTES.md's scalar-part rule fails there under noise)."""
    from simcalib.solvers.problem import build_problem
    try:
        Ca = np.ascontiguousarray(C, dtype=np.float64)
        Ha = np.ascontiguousarray(H, dtype=np.float64)
    except (TypeError, ValueError):
        build_problem(C, H)   # raises the conversion error
        raise
    if (Ca.ndim != 3 or Ha.ndim != 3 or Ca.shape[1:] != (4, 4) or Ha.shape[1:] != (4, 4)
            or Ca.shape[0] != Ha.shape[0] or Ca.shape[0] < 2):
        build_problem(C, H)   # raises the shape error
        raise ValueError(f"C and H must have shape (N, 4, 4) with N >= 2; received "
                         f"{Ca.shape} and {Ha.shape}")
    n = Ca.shape[0]
    qC = np.empty((n, 4))
    qCd = np.empty((n, 4))
    qH = np.empty((n, 4))
    qHd = np.empty((n, 4))
    if _quats_kernel(Ca, Ha, _TOL, qC, qCd, qH, qHd) >= 0:
        problem = build_problem(C, H)   # raises the validation error (if any)
        aligned = align_problem(problem, alpha)
        nf = int(np.sum(np.any(aligned.q_H != problem.q_H, axis=1)))
        return (aligned, nf) if return_flips else aligned
    nf = _align_arrays(_T, qC, qCd, qH, qHd, float(alpha))
    problem = MotionProblem(Ca, Ha, qC, qCd, qH, qHd)
    return (problem, int(nf)) if return_flips else problem


def align_problem(problem: MotionProblem, alpha: float = 1.0) -> MotionProblem:
    """Problem with (q_H, q_H') re-aligned by the optimal rotation (see ``_align_soa``);
    the same object if nothing flips."""
    qH = problem.q_H.copy()
    qHd = problem.q_H_dual.copy()
    nf = _align_arrays(_T, np.ascontiguousarray(problem.q_C), np.ascontiguousarray(problem.q_C_dual),
                       qH, qHd, float(alpha))
    if nf == 0:
        return problem
    return MotionProblem(problem.C, problem.H, problem.q_C, problem.q_C_dual, qH, qHd)


def _matrices_fast(problem: MotionProblem, alpha: float, prior):
    AtA = np.empty((4, 4))
    BtB = np.empty((4, 4))
    BtA = np.empty((4, 4))
    _grams_kernel(_T, problem.q_C, problem.q_C_dual, problem.q_H, problem.q_H_dual, AtA, BtB, BtA)
    AtA = 0.5 * (AtA + AtA.T)
    BtB = 0.5 * (BtB + BtB.T)
    a2 = alpha * alpha
    S = AtA + a2 * BtB
    W = a2 * BtA
    M = a2 * AtA
    if prior is not None:
        S_add, W_add, M_add, _ = prior_terms(prior)
        S, W, M = S + S_add, W + W_add, M + M_add
    return S, W, M


def solve_matrices(method: str, S, W, M):
    """Run one DQ method on (S, W, M). Returns ``(q, q', info)`` (info: see I_* indices)."""
    q = np.empty(4)
    qd = np.empty(4)
    info = np.empty(N_INFO)
    _solve_core(METHOD_CODES[method], np.ascontiguousarray(S, dtype=np.float64),
                np.ascontiguousarray(W, dtype=np.float64),
                np.ascontiguousarray(M, dtype=np.float64), q, qd, info)
    return q, qd, info


_STATUS_TEXT = {ST_OK: "", ST_MAXITER: "iteration limit reached",
                ST_FALLBACK: "expansion undefined (noise-free data): relaxed solution used"}


_ZERO4 = np.zeros((4, 4))


def _prior_adds(prior):
    if prior is None:
        return _ZERO4, _ZERO4, _ZERO4
    S_add, W_add, M_add, _ = prior_terms(prior)
    return (np.ascontiguousarray(S_add), np.ascontiguousarray(W_add),
            np.ascontiguousarray(M_add))


@njit(cache=True)
def _rigid_one(T, tol):
    return _rigid_ok_at(T.reshape((1, 4, 4)), 0, tol)


def is_rigid(X, tol: float = _TOL) -> bool:
    """One 4x4 float64 array is a rigid transform (same test as geometry.check_transforms)."""
    return bool(_rigid_one(np.ascontiguousarray(X, dtype=np.float64), tol))


def dual_quat_fast(X):
    """(q, q') of one 4x4 transform (compiled; same convention as
    geometry.dual_quat_from_transform)."""
    q = np.empty(4)
    qd = np.empty(4)
    _quat_dq(np.ascontiguousarray(X, dtype=np.float64), q, qd)
    return q, qd


def data_cost(problem: MotionProblem, q, qd, alpha: float) -> float:
    """Cost (8) at the dual quaternion (q, q') (compiled, motion by motion)."""
    return float(_cost_kernel(np.ascontiguousarray(problem.q_C), np.ascontiguousarray(problem.q_C_dual),
                              np.ascontiguousarray(problem.q_H), np.ascontiguousarray(problem.q_H_dual),
                              np.asarray(q, dtype=np.float64), np.asarray(qd, dtype=np.float64),
                              float(alpha)))


def _make_solver(method: str):
    code = METHOD_CODES[method]

    def fn(problem, alpha, prior, rng):
        S_add, W_add, M_add = _prior_adds(prior)
        q = np.empty(4)
        qd = np.empty(4)
        info = np.empty(N_INFO)
        X = np.empty((4, 4))
        _solve_from_quats(code, _T, problem.q_C, problem.q_C_dual, problem.q_H,
                          problem.q_H_dual, float(alpha), S_add, W_add, M_add, q, qd, X, info)
        status = int(info[I_STATUS])
        diag = {"mu": float(info[I_MU]), "lambda0": float(info[I_LAM0]),
                "lambda1": float(info[I_LAM1]), "iterations": int(info[I_ITERS]),
                "n_clipped": int(info[I_NCLIP]), "q": q, "q_dual": qd,
                "status": status}
        if method == "dqopt":
            diag.update(bracket=(float(info[I_LO]), float(info[I_HI])), f=float(info[I_F]),
                        df=float(info[I_DF]))
        success = status != ST_MAXITER
        return SolverOutput(X=X, diagnostics=diag, success=success,
                            message=_STATUS_TEXT.get(status, ""))
    fn.__name__ = f"_{method}"
    return fn


def _make_batch(method: str):
    code = METHOD_CODES[method]

    def batch(C, H, alphas, prior):
        """C, H validated (B, N, 4, 4) float64 C-contiguous; alphas (B,). Returns
        (X, cost, objective_quadratic, info, bad)."""
        nb = C.shape[0]
        S_add, W_add, M_add = _prior_adds(prior)
        X = np.full((nb, 4, 4), np.nan)
        cost = np.full(nb, np.inf)
        info = np.zeros((nb, N_INFO))
        bad = np.empty(nb, dtype=np.int64)
        nflip = np.zeros(nb, dtype=np.int64)
        _batch_kernel(code, _T, C, H, alphas, _TOL, prior is not None, S_add, W_add, M_add, X,
                      cost, info, bad, nflip)
        out = {"X": X, "cost": cost, "bad": bad, "mu": info[:, I_MU],
               "iterations": info[:, I_ITERS].astype(np.int64),
               "n_clipped": info[:, I_NCLIP].astype(np.int64),
               "lambda0": info[:, I_LAM0], "sign_flips": nflip}
        out["success"] = info[:, I_STATUS] != ST_MAXITER
        return out
    batch.__name__ = f"_{method}_batch"
    return batch


_DESCRIPTIONS = {
    "dqopt": "optimal: root of the monotone f(mu) = q0.q0' (paper 3.2.1), appendix-C bracket, "
             "safeguarded Newton with the closed-form derivative; certified",
    "dq2steps": "two steps (3.2.2): rotation from M's smallest eigenvector, then q' by eq. 20",
    "dqconvrlx": "convex relaxation (3.2.3): smallest eigenvector of Z0, q' by eq. 20",
    "dq2ndord": "second-order expansion in mu around the relaxed solution (eq. 23)",
    "dq2ndord_lambda": "second-order expansion in Delta-lambda (appendix A, eqs. 35-36)",
    "dqitr": "fixed-point iteration mu <- mu~(q(mu)) (3.2.5, Algorithm 5)",
}

for _name in METHOD_CODES:
    register(_name, family="dq", description=_DESCRIPTIONS[_name], supports_prior=True,
             certified=(_name == "dqopt"), batch=_make_batch(_name),
             batch_validates=True)(_make_solver(_name))


@njit(cache=True, parallel=True)
def _batch_cost_kernel(T, C, H, X, alphas, cost):
    nb = C.shape[0]
    n = C.shape[1]
    for b in prange(nb):
        qC = np.empty((n, 4))
        qCd = np.empty((n, 4))
        qH = np.empty((n, 4))
        qHd = np.empty((n, 4))
        _quats_kernel(C[b], H[b], 1e300, qC, qCd, qH, qHd)
        _align_arrays(T, qC, qCd, qH, qHd, alphas[b])
        q = np.empty(4)
        qd = np.empty(4)
        _quat_dq(X[b], q, qd)
        cost[b] = _cost_kernel(qC, qCd, qH, qHd, q, qd, alphas[b])


def batch_data_cost(C, H, X, alphas) -> np.ndarray:
    """Cost (8) of each ``X[b]`` on problem ``b`` (compiled, parallel; motions aligned as in
    :func:`fast_build_problem`); non-finite X -> inf."""
    X = np.ascontiguousarray(X, dtype=np.float64)
    finite = np.isfinite(X).all(axis=(-2, -1))
    Xs = np.where(finite[:, None, None], X, np.eye(4))
    cost = np.empty(X.shape[0])
    _batch_cost_kernel(_T, np.ascontiguousarray(C, dtype=np.float64),
                       np.ascontiguousarray(H, dtype=np.float64), Xs,
                       np.ascontiguousarray(alphas, dtype=np.float64), cost)
    return np.where(finite, cost, np.inf)


@njit(cache=True)
def _eval_mu_kernel(S, W, M, mu, lam, E, out):
    """Z(mu) eigen-decomposition (M clipped as in the solvers) and f, f' at mu."""
    xi = np.empty(4)
    V = np.empty((4, 4))
    WV = np.empty((4, 4))
    nclip = _m_eig_wv(S, W, M, xi, V, WV)
    Z = np.empty((4, 4))
    _zmat(S, WV, V, xi, mu, Z)
    _eigh(Z, lam, E)
    pv = np.empty(4)
    pu = np.empty(4)
    pva = np.empty(4)
    pua = np.empty(4)
    f, df = _f_df(E, lam, WV, V, xi, mu, pv, pu, pva, pua)
    out[0] = f
    out[1] = df
    out[2] = nclip
    # exact appendix-C bracket: eigenvalues of K = sym(M^1/2 W M^-1/2)
    K = np.empty((4, 4))
    for a in range(4):
        for b in range(4):
            wab = 0.0
            wba = 0.0
            for i in range(4):
                wab += V[i, a] * WV[i, b]
                wba += V[i, b] * WV[i, a]
            K[a, b] = 0.5 * (np.sqrt(xi[a] / xi[b]) * wab + np.sqrt(xi[b] / xi[a]) * wba)
    kw = np.empty(4)
    KV = np.empty((4, 4))
    _eigh(K, kw, KV)
    out[3] = kw[0]
    out[4] = kw[3]


def eval_at_mu(S, W, M, mu: float):
    """``(lam (4,), q0 (4,), f, df, n_clipped, (k_min, k_max))`` for ``Z(mu)`` of (S, W, M):
    eigenvalues, smallest eigenvector, f(mu) = q0.q0' (eq. 18), f'(mu), and the appendix-C
    bracket of mu*."""
    lam = np.empty(4)
    E = np.empty((4, 4))
    out = np.empty(5)
    _eval_mu_kernel(np.ascontiguousarray(S, dtype=np.float64),
                    np.ascontiguousarray(W, dtype=np.float64),
                    np.ascontiguousarray(M, dtype=np.float64), float(mu), lam, E, out)
    return lam, E[:, 0].copy(), float(out[0]), float(out[1]), int(out[2]), (float(out[3]),
                                                                             float(out[4]))
