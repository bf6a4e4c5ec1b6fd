"""Dual-quaternion hand-eye solvers of Dekel et al. (CVPR 2020), section 3 and appendix A/E.

The cost (paper eq. 8) for unit dual quaternion ``q + eps q'`` of ``X``::

    sum_i |A_i q|^2 + alpha^2 |B_i q + A_i q'|^2,   |q| = 1,  q . q' = 0
    A_i = L(q_Ci) - R(q_Hi),  B_i = L(q'_Ci) - R(q'_Hi)

is the quadratic form ``q^T S q + q'^T M q' + 2 q^T W q'`` (eq. 9) with
``S = A^T A + alpha^2 B^T B``, ``M = alpha^2 A^T A``, ``W = alpha^2 B^T A``.
:func:`problem_matrices` returns them (with the prior substitution of eqs. 26-29).
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import dual_quat_from_transform, quat_conjugate, quat_left_matrix, \
    quat_right_matrix
from simcalib.solvers.problem import MotionProblem

__all__ = ["problem_matrices", "gram_blocks", "prior_terms"]

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


# ------------------------------------------------------------------ reference (numpy)
def _dqopt_reference(S, W, M):
    """Plain numpy DQOpt (Algorithm 1) for full-rank M: bracket + bisection/Newton."""
    Minv = np.linalg.inv(M)
    Z0 = S - W @ Minv @ W.T
    Z1 = W @ Minv + Minv @ W.T
    Z2 = Minv

    def f(mu):
        lam, V = np.linalg.eigh(Z0 + mu * Z1 - mu * mu * Z2)
        q = V[:, 0]
        return q @ (mu * Z2 - 0.5 * Z1) @ q, q

    w, V = np.linalg.eigh(M)
    Mh = V @ np.diag(np.sqrt(w)) @ V.T
    Mmh = V @ np.diag(1 / np.sqrt(w)) @ V.T
    K = 0.5 * (Mh @ W @ Mmh + Mmh @ W.T @ Mh)
    k = np.linalg.eigvalsh(0.5 * (K + K.T))
    lo, hi = k[0], k[-1]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(mid)[0] < 0:
            lo = mid
        else:
            hi = mid
    mu = 0.5 * (lo + hi)
    q = f(mu)[1]
    qd = Minv @ (mu * q - W.T @ q)
    return q, qd, mu


from simcalib.geometry import transform_from_dual_quat  # noqa: E402
from simcalib.solvers.registry import register  # noqa: E402


@register("dqopt", family="dq", description="optimal DQ solution: root of the monotone f(mu) "
          "(paper 3.2.1)", supports_prior=True, certified=True)
def _dqopt(problem, alpha, prior, rng):
    S, W, M = problem_matrices(problem, alpha, prior)
    q, qd, mu = _dqopt_reference(S, W, M)
    return transform_from_dual_quat(q, qd)
