"""The second-order expansions of the DQ2ndOrd methods about the relaxed solution (numba).

The relaxed problem's eigenbasis E of Z0 = Z(0) (``dqcore._relaxed``) and the matrices
Z1, Z2 of ``Z(mu) = Z0 + mu Z1 - mu^2 Z2`` in that basis (:func:`_z_basis`) give DQ2ndOrd
in Delta-mu (eq. 23, :func:`_second_order_mu`) and in Delta-lambda (appendix A, eqs.
35-36, :func:`_second_order_lambda`). Checked through the methods' results against numpy
(``tests/test_solvers_kernels.py``).
"""

from __future__ import annotations

import numpy as np
from simcalib.solvers.kernels.jit import njit


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _second_order_lambda(E, lam, Z1ab, Z2ab, q):
    """DQ2ndOrd in Delta-lambda (appendix A, eqs. 35-36, derived for Z = Z0 + mu Z1 - mu^2 Z2;
    the printed appendix uses the opposite sign of the Z2 term). Returns False when the
    expansion is undefined (q0 Z1 q0 = 0, i.e. noise-free: then q = q0)."""
    for i in range(4):
        q[i] = E[i, 0]
    if Z1ab[0, 0] == 0.0:
        return False
    c1a = np.zeros(4)
    c2a = np.zeros(4)
    k0, k1, k2 = _lambda_series(lam, Z1ab, Z2ab, c1a, c2a)
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


@njit(cache=True, error_model="numpy")
def _lambda_series(lam, Z1ab, Z2ab, c1a, c2a):
    """The Delta-lambda expansion of :func:`_second_order_lambda` (Z1ab[0, 0] != 0): the
    first- and second-order coefficients of q in the Z0 eigenbasis (c1a, c2a) and the
    quadratic k0 + k1 dl + k2 dl^2 = 0 whose root is the step. Returns (k0, k1, k2)."""
    z100 = Z1ab[0, 0]
    m1 = 1.0 / z100
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
    return k0, k1, k2
