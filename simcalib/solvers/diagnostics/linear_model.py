"""The linear model of the residuals of ``C_i X = X H_i`` around an estimate (Jacobians,
noise Jacobians, the noise null test, subspace helpers, the dual-quaternion map and the
prior's Jacobians) used by :func:`simcalib.solvers.diagnostics.uncertainty.covariance`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import (
    dual_quat_from_transform,
    invert_transform,
    quat_conjugate,
    quat_left_matrix,
    quat_right_matrix,
    rotvec_from_matrix,
    skew_matrix,
)
from simcalib.solvers.diagnostics.inputs import (
    NULL_LEVEL,
    _PURE,
)


# ------------------------------------------------------------------------ linear model
def linear_model(C, H, X):
    """Residuals e (N,6), Jacobians K (N,6,6) w.r.t. delta, and the two noise-covariance
    parts Qr, Qt (N,6,6) with Cov(e_i) = sigma_r^2 Qr_i + sigma_t^2 Qt_i."""
    e, K, J_c, J_h = linear_model_jacobians(C, H, X)
    return (e, K, *noise_covariance_parts(J_c, J_h))


def noise_covariance_parts(J_c, J_h):
    """``(Qr, Qt)`` (N,6,6) of :func:`linear_model` from the noise Jacobians of
    :func:`linear_model_jacobians` (isotropic eq. 38 noise: per-component variance
    ``sigma_r^2 / 3`` on the rotation columns, ``sigma_t^2`` on the translation ones)."""
    def outer(J):
        return J @ np.swapaxes(J, -1, -2)
    Qr = (outer(J_c[..., :3]) + outer(J_h[..., :3])) / 3.0
    Qt = outer(J_c[..., 3:]) + outer(J_h[..., 3:])
    return Qr, Qt


def linear_model_jacobians(C, H, X):
    """Residuals e (N,6), Jacobians K (N,6,6) w.r.t. delta, and the first-order response
    of the residuals to the eq. 38 noise right-multiplied on C_i and on H_i: ``J_c``,
    ``J_h`` (N,6,6), columns (rotation eps, translation n)."""
    N = C.shape[0]
    RX, tX = X[:3, :3], X[:3, 3]
    Cp = X @ H @ invert_transform(X)                       # C_i' = X H_i X^-1
    RCp, tCp = Cp[:, :3, :3], Cp[:, :3, 3]
    RC, tC = C[:, :3, :3], C[:, :3, 3]
    rho = rotvec_from_matrix(RC @ np.swapaxes(RCp, -1, -2))
    tau = tC - tCp
    e = np.concatenate([rho, tau], axis=1)
    I3 = np.eye(3)
    K = np.zeros((N, 6, 6))
    K[:, :3, :3] = RCp - I3
    K[:, 3:, :3] = skew_matrix(tCp) - skew_matrix(np.broadcast_to(tX, (N, 3))) + RCp @ skew_matrix(tX)
    K[:, 3:, 3:] = RCp - I3
    # noise Jacobians (eq. 38 right-multiplied noise on C_i and H_i)
    u_map = RX @ H[:, :3, :3]                              # eps_h -> u = R_X R_H eps_h
    J_c = np.zeros((N, 6, 6))
    J_c[:, :3, :3] = RC
    J_c[:, 3:, 3:] = RC
    J_h = np.zeros((N, 6, 6))
    J_h[:, :3, :3] = -u_map
    J_h[:, 3:, :3] = -skew_matrix(RCp @ tX) @ u_map
    J_h[:, 3:, 3:] = -u_map
    return e, K, J_c, J_h


def noise_jacobians(H, X) -> np.ndarray:
    """``dK_i / dxi_j`` (N, 6, 6, 6): derivative of the Jacobian ``K_i`` of
    :func:`linear_model` w.r.t. the six noise components ``xi = (u, m)`` of ``H_i`` (eq. 38
    noise right-multiplied on ``H_i``, expressed in frame a: ``u = R_X R_Hi eps``,
    ``m = R_X R_Hi n``; isotropic, per-component variance ``sigma_r^2 / 3`` and
    ``sigma_t^2``). ``K_i`` depends on ``H_i`` only through ``C_i' = X H_i X^-1``:
    ``dR_Ci' = [u]x R_Ci'``, ``dt_Ci' = m - [u]x R_Ci' t_X``; ``K`` is affine in both, so
    the derivative is exact."""
    N = H.shape[0]
    RX, tX = X[:3, :3], X[:3, 3]
    RCp = RX @ H[:, :3, :3] @ RX.T
    E = skew_matrix(np.eye(3))                             # E[j] = [e_j]x
    a = E[None] @ RCp[:, None]                             # (N, 3, 3, 3): [e_j]x R_Ci'
    dK = np.zeros((N, 6, 6, 6))
    dK[:, :3, :3, :3] = a
    dK[:, :3, 3:, 3:] = a
    dK[:, :3, 3:, :3] = skew_matrix(-(a @ tX)) + a @ skew_matrix(tX)
    dK[:, 3:, 3:, :3] = E[None]
    return dK


@dataclass(frozen=True)
class _NullTest:
    ratio: np.ndarray          # (6,) generalised eigenvalues of (F, F_noise), ascending
    directions: np.ndarray     # (6, 6) unit columns, tolerance coordinates
    dof: np.ndarray            # (6,) effective chi-square degrees of freedom
    threshold: np.ndarray      # (6,) F(dof, dof_noise) quantile 1 - NULL_LEVEL
    undetermined: np.ndarray   # (6,) bool: ratio <= threshold


def _noise_null_test(Kw, Bw, dsc, lag, dof_noise) -> _NullTest:
    """Generalised eigenproblem ``F g = r F_noise g`` (whitened stacks ``Kw`` (N,6,6) and
    ``Bw`` (N,6,6,6), tolerance scaling ``dsc``) as the SVD of the stacked data rows times
    ``R^-1`` (``F_noise = R^T R``; ``F_noise`` is well conditioned, noise over noise): small
    ratios keep their accuracy even when ``F`` spans 30 orders of magnitude (noise-free data
    at the floors), which ``eigh(F)`` would not."""
    # scipy.special, not scipy.stats: the same quantiles without ~0.5 s of import per process
    from scipy.special import chdtri, fdtri
    A = Kw.reshape(-1, 6) * dsc
    Bf = Bw.reshape(-1, 6)                                 # B = Bf diag(dsc), never formed:
    Fn = dsc[:, None] * (Bf.T @ Bf) * dsc                  # a long recording's is ~0.25 GB
    try:
        R = np.linalg.cholesky(0.5 * (Fn + Fn.T)).T       # Fn = R^T R
    except np.linalg.LinAlgError:
        R = np.linalg.qr(Bf * dsc, mode="r")
    M = np.linalg.solve(R.T, A.T).T                        # A R^-1
    _, s, Vt = np.linalg.svd(M, full_matrices=False)
    order = np.argsort(s)
    r = s[order] ** 2
    G = np.linalg.solve(R, Vt[order].T)                    # g = R^-1 v (F_noise-normalised)
    # Satterthwaite: g^T F g = sum_i |sum_j xi_ij b_ij|^2 under the null, a quadratic form
    # in Gaussian noise with per-motion Gram matrices M_i = [b_ij . b_il]
    mean, square = _gram_moments(Bf, dsc[:, None] * G, Bw.shape[0])
    dof = mean ** 2 / np.maximum(square, 1e-300)
    dof = np.maximum(dof / (1.0 + lag), 1.0)
    if math.isfinite(dof_noise):
        thr = fdtri(dof, max(dof_noise / (1.0 + lag), 1.0), 1.0 - NULL_LEVEL)
    else:
        thr = chdtri(dof, NULL_LEVEL) / dof
    G = G / np.linalg.norm(G, axis=0)
    return _NullTest(r, G, dof, thr, r <= thr)


def _gram_moments(Bf, G, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per direction ``d`` (column of ``G``): the sums over the ``n`` motions of
    ``trace(M_i)`` and ``|M_i|_F^2``, ``M_i = b_i b_i^T`` with ``b_i`` (6 noise, 6 rows)
    motion ``i``'s block of ``Bf @ G[:, d]`` (``Bf``: the (n * 36, 6) null rows). One
    direction at a time: a long recording's (6, n, 6, 6) Gram stack would be ~1 GB (140k
    motions)."""
    mean, square = np.empty(6), np.empty(6)
    for d in range(6):
        bd = (Bf @ G[:, d]).reshape(n, 6, 6)
        gram = bd @ np.swapaxes(bd, -1, -2)                 # (n, 6, 6)
        mean[d] = np.trace(gram, axis1=1, axis2=2).sum()
        square[d] = np.sum(gram * gram)
    return mean, square


def _span(blocks, tol: float = _PURE) -> np.ndarray:
    """Orthonormal basis (6, k) of the span of the columns of ``blocks`` (normalised first;
    singular values below ``tol`` dropped: nearly parallel columns count once)."""
    V = np.concatenate([np.zeros((6, 0)), *blocks], axis=1)
    if V.shape[1] == 0:
        return np.zeros((6, 0))
    V = V / np.linalg.norm(V, axis=0)
    U, s, _ = np.linalg.svd(V, full_matrices=False)
    return U[:, s > tol]


def _complement(U) -> np.ndarray:
    """Orthonormal basis of the orthogonal complement of the orthonormal columns ``U``."""
    if U.shape[1] == 0:
        return np.eye(6)
    Q, _ = np.linalg.qr(np.concatenate([U, np.eye(6)], axis=1))
    return Q[:, U.shape[1]:6]

def _dq_map(C, X, alpha):
    """T_i (N,8,6): DQ residual of cost (8), [A q; alpha (B q + A q')], as a linear function
    of the geometric residual e_i (sign of the DQ pair irrelevant: only T^T T is used)."""
    N = C.shape[0]
    qC, qCd = dual_quat_from_transform(C)
    qX, qXd = dual_quat_from_transform(X)
    Rq = quat_right_matrix(qC)[:, :, :3]                   # (rho,0) -> q_C-ish: 1/2 R(q_C)
    dq_rho = 0.5 * Rq                                      # d q_C / d rho
    tq = np.concatenate([C[:, :3, 3], np.zeros((N, 1))], axis=1)
    dqd_rho = 0.5 * quat_left_matrix(tq) @ dq_rho          # d q_C' / d rho
    dqd_tau = 0.5 * Rq                                     # d q_C' / d tau
    RqX = quat_right_matrix(qX)
    RqXd = quat_right_matrix(qXd)
    T = np.zeros((N, 8, 6))
    T[:, :4, :3] = RqX @ dq_rho
    T[:, 4:, :3] = alpha * (RqXd @ dq_rho + RqX @ dqd_rho)
    T[:, 4:, 3:] = alpha * (RqX @ dqd_tau)
    return T


def _prior_jacobians(X, prior):
    """Jacobians (3x6, 4x6) of vec(dq) and dq' (dq + eps dq' = Q_prior^* Q_X) w.r.t. delta."""
    q, _ = dual_quat_from_transform(X)
    qh, qhd = dual_quat_from_transform(prior.X)
    dq_dw = 0.5 * quat_right_matrix(q)[:, :3]              # d q / d omega
    tq = np.concatenate([X[:3, 3], [0.0]])
    dqd_dw = 0.5 * quat_left_matrix(tq) @ dq_dw
    dqd_dv = 0.5 * quat_right_matrix(q)[:, :3]
    Lh = quat_left_matrix(quat_conjugate(qh))
    Lhd = quat_left_matrix(quat_conjugate(qhd))
    Ja = np.zeros((4, 6))
    Ja[:, :3] = Lh @ dq_dw
    Jb = np.zeros((4, 6))
    Jb[:, :3] = Lhd @ dq_dw + Lh @ dqd_dw
    Jb[:, 3:] = Lh @ dqd_dv
    return Ja[:3], Jb


