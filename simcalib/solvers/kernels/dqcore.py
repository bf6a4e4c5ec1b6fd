"""The dual-quaternion method core (numba): one problem given (S, W, M).

``_solve_core(method, S, W, M, q, qd, info)`` runs one of the paper's methods (section 3,
appendix A/C/E) on the 4x4 matrices of eq. 9 and writes the unit dual quaternion (q, q')
and the ``info`` vector (indices ``I_*``). ``_certificate_kernel`` evaluates what the
certificate of global optimality needs. Tests (``tests/test_solvers_kernels.py``) check
the core against numpy: the stationarity conditions of eq. 10 evaluated with numpy and, for
dqopt, the minimum over a dense numpy scan of the constraint set.
"""

from __future__ import annotations

import numpy as np
from simcalib.solvers.kernels.jit import njit

from simcalib.solvers.kernels.linalg import _eigh, _eigh_warm

__all__ = ["METHOD_CODES", "CLIP_REL", "N_INFO", "solve_matrices", "certificate_values",
           "STATUS_TEXT"]

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
ST_OK, ST_MAXITER, ST_FALLBACK, ST_NONFINITE = 0, 1, 2, 3
STATUS_TEXT = {ST_OK: "", ST_MAXITER: "iteration limit reached",
               ST_FALLBACK: "expansion undefined (noise-free data): relaxed solution used",
               ST_NONFINITE: "non-finite result (the motions carry no usable information, "
                             "e.g. all identity)"}
#: statuses that mean the solve failed
FAILED_STATUSES = (ST_MAXITER, ST_NONFINITE)


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _zmat(S, WV, V, xi, mu, Z):
    """Z(mu) = S - (W - mu) M^-1 (W - mu)^T = Z0 + mu Z1 - mu^2 Z2 (eq. 12)."""
    for i in range(4):
        for j in range(i, 4):
            acc = S[i, j]
            for k in range(4):
                acc -= (WV[i, k] - mu * V[i, k]) * (WV[j, k] - mu * V[j, k]) / xi[k]
            Z[i, j] = acc
            Z[j, i] = acc


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _f_df(E, lam, WV, V, xi, mu, pv, pu, pva, pua):
    """f(mu) = q0 . q0' (eq. 18) and its derivative (first-order perturbation of q0)."""
    _proj(E, np.int64(0), WV, V, mu, pv, pu)   # np.int64: no Literal[0] specialisation
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _normalize(q):
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        q[i] /= n


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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
    E0 = np.empty((4, 4))
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
        for it in range(200):
            _zmat(S, WV, V, xi, mu, Z)
            # warm start from the previous eigenvectors (identity at first: then exactly
            # _eigh); one call site keeps one copy of the eigensolver in the compiled code
            for i in range(4):
                for j in range(4):
                    E0[i, j] = (1.0 if i == j else 0.0) if it == 0 else E[i, j]
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
        wscale = np.sqrt(xi[3])
        for i in range(4):
            for j in range(4):
                wscale = max(wscale, abs(W[i, j]) / max(np.sqrt(xi[3]), 1e-300))
        E0 = np.empty((4, 4))
        for it in range(500):
            _zmat(S, WV, V, xi, mu, Z)
            # warm start from the previous eigenvectors (identity at first: then exactly
            # _eigh); one call site keeps one copy of the eigensolver in the compiled code
            for i in range(4):
                for j in range(4):
                    E0[i, j] = (1.0 if i == j else 0.0) if it == 0 else E[i, j]
            _eigh_warm(Z, E0, lam, E)
            iters += 1
            for i in range(4):
                q[i] = E[i, 0]
            mu_new = _mu_tilde(q, WV, V, xi)
            # converged: relative change at rounding level, or an absolute change at
            # rounding level of the matrices' scale (exact data: mu* = 0 and the iterates
            # wander at 1e-17 without a relative fixed point)
            if (abs(mu_new - mu) <= 1e-14 * abs(mu_new) or mu_new == mu
                    or abs(mu_new - mu) <= 64.0 * _EPS * wscale):
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
    for i in range(4):
        if not (np.isfinite(q[i]) and np.isfinite(qd[i])):
            status = ST_NONFINITE
    info[I_STATUS] = status
    info[I_XI0] = xi[0]
    info[I_XI3] = xi[3]
    info[I_COST] = cost


@njit(cache=True, error_model="numpy")
def _eval_mu(S, W, M, mu, lam, E, out):
    """Z(mu) eigen-decomposition (M clipped as in the solvers), f, f' at mu, the clip count
    and the exact appendix-C bracket (eigenvalues of K = sym(M^1/2 W M^-1/2)) into out."""
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


@njit(cache=True, error_model="numpy")
def _certificate_kernel(opt, S, W, M, q, qd, info, lam, E, out):
    """Everything the certificate evaluates, in one compiled entry: the dqopt solution of
    (S, W, M) (q, qd, info), then Z's eigen-decomposition and f, f' at mu*, at the bracket
    ends k_min, k_max and at mu* -/+ h (rows 0..4 of lam (5, 4), E (5, 4, 4), out (5, 5))."""
    _solve_core(opt, S, W, M, q, qd, info)
    mu = info[I_MU]
    h = 0.0
    for r in range(5):   # one call site of _eval_mu
        if r == 0:
            at = mu
        elif r == 1:
            at = out[0, 3]
        elif r == 2:
            at = out[0, 4]
        else:
            at = mu - h if r == 3 else mu + h
        _eval_mu(S, W, M, at, lam[r], E[r], out[r])
        if r == 0:
            h = 1e-4 * max(out[0, 4] - out[0, 3], 1e-300)


def _c(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def certificate_values(S, W, M):
    """``(q*, q*', info, lam (5, 4), E (5, 4, 4), out (5, 5))`` of :func:`_certificate_kernel`:
    rows evaluate Z at mu*, k_min, k_max, mu* - h, mu* + h; out columns are f, f', number
    of clipped eigenvalues of M, k_min, k_max."""
    q = np.empty(4)
    qd = np.empty(4)
    info = np.empty(N_INFO)
    lam = np.empty((5, 4))
    E = np.empty((5, 4, 4))
    out = np.empty((5, 5))
    _certificate_kernel(DQOPT, _c(S), _c(W), _c(M), q, qd, info, lam, E, out)
    return q, qd, info, lam, E, out


def solve_matrices(method: str, S, W, M):
    """Run one DQ method on (S, W, M). Returns ``(q, q', info)`` (info: see I_* indices).
    Compiles ``_solve_core`` as its own entry: meant for tests and analysis, not the solve
    path (which runs through :mod:`simcalib.solvers.kernels.batch`)."""
    q = np.empty(4)
    qd = np.empty(4)
    info = np.empty(N_INFO)
    _solve_core(METHOD_CODES[method], _c(S), _c(W), _c(M), q, qd, info)
    return q, qd, info
