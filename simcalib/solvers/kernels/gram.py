"""Gram accumulation of the DQ cost and the assembly of (S, W, M) (paper eq. 9).

The cost ``sum_i w_i (|A_i q|^2 + alpha^2 |B_i q + A_i q'|^2)`` with
``A_i = L(q_Ci) - R(q_Hi)``, ``B_i = L(q'_Ci) - R(q'_Hi)`` is the quadratic form
``q^T S q + q'^T M q' + 2 q^T W q'`` with ``S = AtA + alpha^2 BtB``, ``W = alpha^2 BtA``,
``M = alpha^2 AtA`` (Gram blocks summed over motions with weights ``w_i``, 1 by default).

Kernels (numba): motions in structure-of-arrays form ``Q (16, N)`` (rows c, h, c', h');
``_outer_from_soa`` + ``_grams_from_outer`` accumulate the Gram blocks, ``_assemble``
builds (S, W, M) — the one place that does. Numpy twins: :func:`gram_blocks`,
:func:`assemble`, :func:`problem_matrices`.
"""

from __future__ import annotations

import numpy as np
from simcalib.solvers.kernels.jit import njit, twin_of

from simcalib.geometry import dual_quat_from_transform, quat_conjugate, quat_left_matrix, \
    quat_right_matrix
from simcalib.solvers.kernels.quaternion import _dq_rows, _rigid_ok_at

__all__ = ["gram_blocks", "assemble", "problem_matrices", "prior_terms", "prior_penalty",
           "grams_compiled"]

_G = np.diag([1.0, 1.0, 1.0, 0.0])
_L, _R = quat_left_matrix, quat_right_matrix


def _lr_tensors():
    """T[x][i, j] = X(e_i)^T Y(e_j) for (X, Y) in LR, LL, RL, RR, so that
    sum_i X(a_i)^T Y(b_i) = sum_jk P_jk T[j, k] with P = sum_i a_i b_i^T."""
    E = np.eye(4)
    pairs = ((_L, _R), (_L, _L), (_R, _L), (_R, _R))
    return np.ascontiguousarray(np.array(
        [[[f(E[i]).T @ g(E[j]) for j in range(4)] for i in range(4)] for f, g in pairs]))


@njit(cache=True, error_model="numpy", fastmath={"reassoc", "contract"})
def _dot_rows(Q, wts, weighted, a, b, n):
    """sum_m w_m Q[a, m] Q[b, m] (w = 1 when not weighted)."""
    s = 0.0
    if weighted:
        for m in range(n):
            s += wts[m] * Q[a, m] * Q[b, m]
    else:
        for m in range(n):
            s += Q[a, m] * Q[b, m]
    return s


@njit(cache=True, error_model="numpy")
def _outer_from_soa(Q, wts, weighted, n, P, nrm):
    """Q (16, N) rows: c (0-3), h (4-7), c' (8-11), h' (12-15). Fills the summed outer
    products P[0] = sum c h^T, P[1] = c' h'^T, P[2] = c' c^T, P[3] = c' h^T, P[4] = h' c^T,
    P[5] = h' h^T and nrm = (sum |c|^2+|h|^2, sum |c'|^2+|h'|^2), each term times the
    motion's weight when ``weighted``."""
    for i in range(4):
        for j in range(4):
            P[0, i, j] = _dot_rows(Q, wts, weighted, i, 4 + j, n)
            P[1, i, j] = _dot_rows(Q, wts, weighted, 8 + i, 12 + j, n)
            P[2, i, j] = _dot_rows(Q, wts, weighted, 8 + i, j, n)
            P[3, i, j] = _dot_rows(Q, wts, weighted, 8 + i, 4 + j, n)
            P[4, i, j] = _dot_rows(Q, wts, weighted, 12 + i, j, n)
            P[5, i, j] = _dot_rows(Q, wts, weighted, 12 + i, 4 + j, n)
    s0 = 0.0
    s1 = 0.0
    for i in range(8):
        s0 += _dot_rows(Q, wts, weighted, i, i, n)
        s1 += _dot_rows(Q, wts, weighted, 8 + i, 8 + i, n)
    nrm[0] = s0
    nrm[1] = s1


@njit(cache=True, error_model="numpy", fastmath={"reassoc"})
def _sum_flat(F):
    """Sum of a contiguous 1-D array (reassociated: vectorised, reads memory in order)."""
    s = 0.0
    for j in range(F.shape[0]):
        s += F[j]
    return s


@njit(cache=True, error_model="numpy")
def _quats_soa(C, H, tol, Q):
    """Validate + convert motions into Q (16, N) (sign-aligned: the scalar parts of a pair
    get the same sign); returns the first bad index or -1. Loops over the motions that LLVM
    vectorises: a sequential pass over C and H first (their sum: it brings the problem's
    25 kB into the cache in memory order, ~2 us less per problem in a large batch than
    the strided first touch by the checks; a non-finite sum sends every motion through the
    exact check below), then check, convert C, convert H. The conversion gives every
    scalar part w >= 0 (or -0.0), so the pairs' scalar parts have the same sign already:
    no sign pass (it multiplied every h, h' by 1.0)."""
    n = C.shape[0]
    total = _sum_flat(C.reshape(-1)) + _sum_flat(H.reshape(-1))
    nbad = 0 if np.isfinite(total) else 1
    for i in range(n):
        nbad += not (_rigid_ok_at(C, i, tol) & _rigid_ok_at(H, i, tol))
    if nbad > 0:
        for i in range(n):
            if not (_rigid_ok_at(C, i, tol) & _rigid_ok_at(H, i, tol)):
                return i
    for side in range(2):   # one call site with runtime rows: one compiled _dq_rows
        _dq_rows(C if side == 0 else H, Q, 4 * side, 8 + 4 * side)
    return -1


@njit(cache=True, error_model="numpy")
def _contract(T, k, P, sign, out):
    """out += sum_jl sign P[j, l] T[k, j, l] where T = _nz_table(): each T[k, j, l] is a
    signed permutation (4 entries +-1, listed as rows (a, b, s)), so only those 4 are
    added (the same sums, in the same order, as with the dense 4x4 tensor)."""
    for j in range(4):
        for l in range(4):
            p = sign * P[j, l]
            if p != 0.0:
                for t in range(4):
                    out[T[k, j, l, t, 0], T[k, j, l, t, 1]] += p * T[k, j, l, t, 2]


@njit(cache=True, error_model="numpy")
def _grams_from_outer(T, P, nrm, AtA, BtB, BtA):
    """A^T A, B^T B, B^T A from the accumulated outer products (A = L(c) - R(h), ...).
    (The tensor index is passed as np.int64(k): a literal k would make numba compile one
    _contract per value.) X1 = sum L(c)^T R(h) is summed in AtA and symmetrised there
    (no scratch: -(x + y) = -(y + x) to the bit), X2 likewise in BtB."""
    for a in range(4):
        for b in range(4):
            AtA[a, b] = 0.0
            BtB[a, b] = 0.0
            BtA[a, b] = 0.0
    _contract(T, np.int64(0), P[0], 1.0, AtA)      # X1 = sum L(c)^T R(h)
    _contract(T, np.int64(0), P[1], 1.0, BtB)      # X2 = sum L(c')^T R(h')
    for a in range(4):
        for b in range(a, 4):
            x1, y1 = AtA[a, b], AtA[b, a]
            x2, y2 = BtB[a, b], BtB[b, a]
            AtA[a, b] = -(x1 + y1)
            AtA[b, a] = -(y1 + x1)
            BtB[a, b] = -(x2 + y2)
            BtB[b, a] = -(y2 + x2)
        AtA[a, a] += nrm[0]
        BtB[a, a] += nrm[1]
    _contract(T, np.int64(1), P[2], 1.0, BtA)     # L(c')^T L(c)
    _contract(T, np.int64(0), P[3], -1.0, BtA)    # - L(c')^T R(h)
    _contract(T, np.int64(2), P[4], -1.0, BtA)    # - R(h')^T L(c)
    _contract(T, np.int64(3), P[5], 1.0, BtA)     # + R(h')^T R(h)


def _nz_table(T):
    """The non-zero entries of each T[k, j, l] (a signed permutation matrix) as
    (a, b, value) rows: (4, 4, 4, 4, 3) int64."""
    out = np.zeros(T.shape[:3] + (4, 3), dtype=np.int64)
    for k in range(T.shape[0]):
        for j in range(4):
            for l in range(4):
                a, b = np.nonzero(T[k, j, l])
                if len(a) != 4 or not np.all(np.abs(T[k, j, l][a, b]) == 1.0):
                    raise RuntimeError("L/R tensor is not a signed permutation")
                out[k, j, l] = np.stack([a, b, T[k, j, l][a, b].astype(np.int64)], axis=1)
    return out


_T_DENSE = _lr_tensors()        # (4 [LR, LL, RL, RR], 4, 4, 4, 4)
_T = _nz_table(_T_DENSE)        # (4 [LR, LL, RL, RR], 4, 4, 4 non-zeros, (a, b, +-1))


@njit(cache=True, error_model="numpy")
def _assemble(AtA, BtB, BtA, a2, S_add, W_add, M_add, S, W, M):
    """(S, W, M) of eq. 9 from the Gram blocks (symmetrised) plus the prior terms."""
    for i in range(4):
        for j in range(4):
            sa = 0.5 * (AtA[i, j] + AtA[j, i])
            S[i, j] = sa + a2 * 0.5 * (BtB[i, j] + BtB[j, i]) + S_add[i, j]
            W[i, j] = a2 * BtA[i, j] + W_add[i, j]
            M[i, j] = a2 * sa + M_add[i, j]


@njit(cache=True, error_model="numpy")
def _grams_entry(T, Q, wts, weighted, AtA, BtB, BtA):
    n = Q.shape[1]
    P = np.empty((6, 4, 4))
    nrm = np.empty(2)
    _outer_from_soa(Q, wts, weighted, n, P, nrm)
    _grams_from_outer(T, P, nrm, AtA, BtB, BtA)


def soa(q_C, q_C_dual, q_H, q_H_dual):
    """Motions (N, 4) x 4 -> the kernels' Q (16, N) (rows c, h, c', h')."""
    return np.ascontiguousarray(np.concatenate([q_C.T, q_H.T, q_C_dual.T, q_H_dual.T]))


def grams_compiled(q_C, q_C_dual, q_H, q_H_dual, weights=None):
    """Compiled Gram blocks (test entry point; twin of :func:`gram_blocks`)."""
    Q = soa(q_C, q_C_dual, q_H, q_H_dual)
    w = np.ones(Q.shape[1]) if weights is None else np.ascontiguousarray(weights, dtype=np.float64)
    AtA, BtB, BtA = np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4))
    _grams_entry(_T, Q, w, weights is not None, AtA, BtB, BtA)
    return AtA, BtB, BtA


# -------------------------------- numpy twins run by interpreted kernels (jit.twin_of)
@twin_of(_quats_soa, when=lambda C, H, tol, Q: C.shape[0] >= 10)   # measured crossover
def _quats_soa_twin(C, H, tol, Q):
    """:func:`_quats_soa` over all motions at once (numpy): the first non-rigid motion, or
    -1 after filling Q (dual quaternions of :func:`simcalib.geometry.dual_quat_from_transform`,
    the same algorithm, then the scalar-part sign rule)."""
    ok = _rigid_mask(C, tol) & _rigid_mask(H, tol)
    if not ok.all():
        return int(np.argmin(ok))
    for side, T in enumerate((C, H)):
        q, qd = dual_quat_from_transform(T)
        Q[4 * side:4 * side + 4] = q.T
        Q[8 + 4 * side:12 + 4 * side] = qd.T
    sg = np.where(Q[3] * Q[7] < 0.0, -1.0, 1.0)
    Q[4:8] *= sg
    Q[12:16] *= sg
    return -1


def _rigid_mask(T, tol):
    """``quaternion._rigid_ok_at`` for every ``T[i]`` of ``T (N, 4, 4)`` (numpy)."""
    with np.errstate(invalid="ignore", over="ignore"):
        R = T[:, :3, :3]
        ok = np.abs(T[:, 0, 3] + T[:, 1, 3] + T[:, 2, 3]) < np.inf
        ok &= (np.abs(T[:, 3, :3]) <= tol).all(axis=1) & (np.abs(T[:, 3, 3] - 1.0) <= tol)
        gram = np.einsum("nki,nkj->nij", R, R) - np.eye(3)
        ok &= (np.abs(gram) <= tol).all(axis=(1, 2))
        det = (R[:, 0, 0] * (R[:, 1, 1] * R[:, 2, 2] - R[:, 1, 2] * R[:, 2, 1])
               - R[:, 0, 1] * (R[:, 1, 0] * R[:, 2, 2] - R[:, 1, 2] * R[:, 2, 0])
               + R[:, 0, 2] * (R[:, 1, 0] * R[:, 2, 1] - R[:, 1, 1] * R[:, 2, 0]))
        ok &= np.abs(det - 1.0) <= tol
    return ok


@twin_of(_outer_from_soa)
def _outer_from_soa_twin(Q, wts, weighted, n, P, nrm):
    """:func:`_outer_from_soa` as one product of the motion rows (numpy)."""
    A = Q[:, :n]
    G = (A * wts[:n]) @ A.T if weighted else A @ A.T     # every row pair's (weighted) dot
    for k, (r, c) in enumerate(((0, 4), (8, 12), (8, 0), (8, 4), (12, 0), (12, 4))):
        P[k] = G[r:r + 4, c:c + 4]
    d = np.diagonal(G)
    nrm[0] = d[:8].sum()
    nrm[1] = d[8:].sum()


@twin_of(_grams_from_outer)
def _grams_from_outer_twin(T, P, nrm, AtA, BtB, BtA):
    """:func:`_grams_from_outer` with the dense L/R tensors (numpy; ``T`` unused)."""
    def contract(k, Pk):
        return np.einsum("jl,jlab->ab", Pk, _T_DENSE[k])
    X1 = contract(0, P[0])
    X2 = contract(0, P[1])
    eye = np.eye(4)
    AtA[:] = -(X1 + X1.T) + nrm[0] * eye
    BtB[:] = -(X2 + X2.T) + nrm[1] * eye
    BtA[:] = contract(1, P[2]) - contract(0, P[3]) - contract(2, P[4]) + contract(3, P[5])


# ------------------------------------------------------------------------ numpy twins
def gram_blocks(q_C, q_C_dual, q_H, q_H_dual, weights=None):
    """``(A^T A, B^T B, B^T A)`` summed over motions (weighted by ``weights`` (..., N) if
    given); inputs ``(..., N, 4)``, outputs ``(..., 4, 4)``."""
    A = _L(q_C) - _R(q_H)
    B = _L(q_C_dual) - _R(q_H_dual)
    if weights is None:
        w = np.ones(A.shape[:-2])
    else:
        w = np.asarray(weights, dtype=np.float64)
    AtA = np.einsum("...n,...nki,...nkj->...ij", w, A, A)
    BtB = np.einsum("...n,...nki,...nkj->...ij", w, B, B)
    BtA = np.einsum("...n,...nki,...nkj->...ij", w, B, A)
    return AtA, BtB, BtA


def assemble(AtA, BtB, BtA, alpha: float, prior_adds=None):
    """Numpy twin of ``_assemble``: (S, W, M) from the Gram blocks and optional
    ``(S_add, W_add, M_add)``."""
    a2 = float(alpha) ** 2
    sym = 0.5 * (AtA + np.swapaxes(AtA, -1, -2))
    S = sym + a2 * 0.5 * (BtB + np.swapaxes(BtB, -1, -2))
    W = a2 * BtA
    M = a2 * sym
    if prior_adds is not None:
        S, W, M = S + prior_adds[0], W + prior_adds[1], M + prior_adds[2]
    return S, W, M


def prior_terms(prior):
    """``(S_add, W_add, M_add, const)`` of the prior (paper eqs. 26-29, see docs/solvers.md).

    With ``Q^ = q^ + eps q^'`` the prior's dual quaternion, ``L* = L(conj q^)``,
    ``L'* = L(conj q^')``: ``S += a L*^T G L*``, ``W += b L'*^T L*``, ``M += b I``.
    The quadratic form then equals ``cost + a dq^T G dq + b |dq'|^2 - const`` with
    ``const = b |q^'|^2`` on the constraint set.
    """
    q_hat, q_hat_dual = dual_quat_from_transform(prior.X)
    Ls = _L(quat_conjugate(q_hat))
    Lds = _L(quat_conjugate(q_hat_dual))
    S_add = prior.a * Ls.T @ _G @ Ls
    W_add = prior.b * Lds.T @ Ls
    M_add = prior.b * np.eye(4)
    const = prior.b * float(q_hat_dual @ q_hat_dual)
    return S_add, W_add, M_add, const


def prior_penalty(q, qd, prior) -> np.ndarray | float:
    """The prior terms ``a |vec(dq)|^2 + b |dq'|^2`` at (q, q') (``(..., 4)``), with
    ``dq + eps dq' = Q_prior^* (q + eps q')``."""
    from simcalib.geometry import quat_multiply
    q_hat, q_hat_dual = dual_quat_from_transform(prior.X)
    dq = quat_multiply(quat_conjugate(q_hat), q)
    dqd = quat_multiply(quat_conjugate(q_hat_dual), q) + quat_multiply(quat_conjugate(q_hat), qd)
    val = prior.a * np.sum(dq[..., :3] ** 2, axis=-1) + prior.b * np.sum(dqd**2, axis=-1)
    return float(val) if np.ndim(val) == 0 else val


def problem_matrices(problem, alpha: float, prior=None, weights=None):
    """``(S, W, M)`` of paper eq. (9) for a :class:`MotionProblem` (4x4 each, float64).

    With a :class:`simcalib.Prior` the substitution of eq. (29) is applied, so
    ``q^T S q + q'^T M q' + 2 q^T W q'`` equals the cost (8) plus the prior terms
    ``a |vec(dq)|^2 + b |dq'|^2`` minus the constant ``b |q^'|^2`` (``dQ = Q^* X``).
    ``weights`` (N,): per-motion weights of the cost (default: the problem's, else 1).
    """
    if weights is None:
        weights = getattr(problem, "weights", None)
    AtA, BtB, BtA = gram_blocks(problem.q_C, problem.q_C_dual, problem.q_H, problem.q_H_dual,
                                weights)
    adds = None if prior is None else prior_terms(prior)[:3]
    return assemble(AtA, BtB, BtA, alpha, adds)
