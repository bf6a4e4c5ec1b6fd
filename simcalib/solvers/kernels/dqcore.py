"""The dual-quaternion method core (numba): one problem given (S, W, M).

``_solve_core(method, S, W, M, q, qd, info)`` runs one of the paper's methods (section 3,
appendix A/C/E) on the 4x4 matrices of eq. 9 and writes the unit dual quaternion (q, q')
and the ``info`` vector (indices ``I_*``). ``_certificate_kernel`` evaluates what the
certificate of global optimality needs. Tests (``tests/test_solvers_kernels.py``) check
the core against numpy: the stationarity conditions of eq. 10 evaluated with numpy and, for
dqopt, the minimum over a dense numpy scan of the constraint set.

Scratch: ``_solve_core`` takes its 4x4 and 4-vector work arrays from ``wk`` (``(N_WORK, 4,
4)``, :func:`work_array`), made once per batch by the caller, so that a solve allocates
nothing (each allocation costs ~35 ns; a solve made ~20).
"""

from __future__ import annotations

import numpy as np
from simcalib.solvers.kernels.jit import njit

from simcalib.solvers.kernels.expansion import _second_order_lambda, _second_order_mu, _z_basis
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
#: 4x4 slots of the scratch ``wk`` of :func:`_solve_core`: V, WV, Z, E, (xi, lam, -, -),
#: eigen scratch a, tmp, E0, (pv, pu, pva, pua), (c, pv, za, -), Z1ab / K, Z2ab
N_WORK = 12


def work_array():
    """The scratch of :func:`_solve_core` (contents irrelevant)."""
    return np.empty((N_WORK, 4, 4))


@njit(cache=True, error_model="numpy")
def _m_eig(S, M, xi, V, a):
    """Eigen-decomposition of M with eigenvalues clipped to >= CLIP_REL * scale (scale = the
    largest eigenvalue of M, or trace(S)/4 when M is ~0); ``a``: 4x4 scratch.
    Returns how many were clipped (noise-free or degenerate data: M is singular)."""
    _eigh(M, xi, V, a)
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
def _f_df(E, lam, WV, V, xi, mu, pv, pu, pva, pua, za3):
    """f(mu) = q0 . q0' (eq. 18) and its derivative (first-order perturbation of q0);
    za3[a] (a = 1..3): the coupling of q0 to eigenvector a (:func:`_newton_last_step`)."""
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
        za3[a] = za
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
def _qdual(q, mu, WV, V, xi, qd, c, pv):
    """q' = M^-1 (mu - W^T) q (eq. 11), with the component along the smallest eigenvector
    of M taken from the constraint q . q' = 0 when that eigenvalue is small (stable for
    nearly singular M). ``c``, ``pv``: 4-vector scratch."""
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
def _normalize(q):
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        q[i] /= n


@njit(cache=True, error_model="numpy")
def _m_eig_wv(S, W, M, xi, V, WV, a):
    """Eigen-decomposition of M (clipped as in the solvers) and W @ V; returns the clip
    count (``a``: 4x4 scratch)."""
    nclip = _m_eig(S, M, xi, V, a)
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for k in range(4):
                acc += W[i, k] * V[k, j]
            WV[i, j] = acc
    return nclip


@njit(cache=True, error_model="numpy", inline="always")
def _z_eigen(S, WV, V, xi, mu, first, Z, E0, lam, E, a, tmp):
    """Z(mu) (eq. 12) and its eigen-decomposition (lam, E), warm-started from the previous
    eigenvectors E (identity when ``first``: then exactly _eigh); the iterations of dqopt
    and dqitr each call it at one site, so the compiled code holds one eigensolver each."""
    _zmat(S, WV, V, xi, mu, Z)
    for i in range(4):
        for j in range(4):
            E0[i, j] = (1.0 if i == j else 0.0) if first else E[i, j]
    _eigh_warm(Z, E0, lam, E, a, tmp)


@njit(cache=True, error_model="numpy", inline="always")
def _dqopt_newton(S, WV, V, xi, q, Z, lam, E, wk):
    """DQOpt (section 3.1): the root of f(mu) = q0 . q0' by safeguarded Newton inside the
    bracket, q = the eigenvector of Z(mu*) of the smallest eigenvalue (lam, E: the last
    eigen-decomposition). Returns (mu, iterations, status, lo, hi, f, f')."""
    pv, pu, pva, pua = wk[8, 0], wk[8, 1], wk[8, 2], wk[8, 3]
    za3 = wk[9, 2]
    E0, ea, etmp = wk[7], wk[5], wk[6]
    lo, hi = _dqopt_bracket(V, WV, xi, wk[10])
    mu = 0.0
    blo = lo
    bhi = hi
    iters = 0
    status = ST_OK
    f = np.nan
    df = np.nan
    for it in range(200):
        _z_eigen(S, WV, V, xi, mu, it == 0, Z, E0, lam, E, ea, etmp)
        f, df = _f_df(E, lam, WV, V, xi, mu, pv, pu, pva, pua, za3)
        iters += 1
        qdn = 0.0
        for k in range(4):
            qdn += (pu[k] / xi[k]) ** 2
        ftol = 4.0 * _EPS * (1.0 + np.sqrt(qdn))
        if abs(f) <= ftol:
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
            _newton_last_step(E, lam, mu, mu_new, za3, q)
            return mu_new, iters, status, lo, hi, f, df
        if not (mu_new > blo and mu_new < bhi):
            mu_new = 0.5 * (blo + bhi)
        if (abs(mu_new - mu) <= 2.0 * _EPS * abs(mu)
                or bhi - blo <= 4.0 * _EPS * max(abs(blo), abs(bhi))):
            break
        mu = mu_new
    else:
        status = ST_MAXITER
    for i in range(4):
        q[i] = E[i, 0]
    return mu, iters, status, lo, hi, f, df


@njit(cache=True, error_model="numpy", inline="always")
def _k_entry(V, WV, xi, a, b):
    """Entry (a, b) of K = sym(M^1/2 W M^-1/2) in M's eigenbasis (appendix C)."""
    wab = 0.0
    wba = 0.0
    for i in range(4):
        wab += V[i, a] * WV[i, b]
        wba += V[i, b] * WV[i, a]
    return 0.5 * (np.sqrt(xi[a] / xi[b]) * wab + np.sqrt(xi[b] / xi[a]) * wba)


@njit(cache=True, error_model="numpy", inline="always")
def _dqopt_bracket(V, WV, xi, K):
    """The bracket of mu* (appendix C): mu* lies in [k_min, k_max], the extreme eigenvalues
    of K = sym(M^1/2 W M^-1/2); here the cheaper valid bound |mu*| <= ||K||_F (the exact
    eigenvalue bracket is reported by the certificate). Returns (lo, hi). K: 4x4 scratch
    (K is symmetric to the bit: its upper triangle is computed, the lower one copied)."""
    for a in range(4):
        for b in range(a, 4):
            kab = _k_entry(V, WV, xi, a, b)
            K[a, b] = kab
            K[b, a] = kab
    kf = 0.0
    for a in range(4):
        for b in range(4):
            kf += K[a, b] * K[a, b]
    kf = np.sqrt(kf)
    return -kf * (1.0 + 1e-12) - 1e-300, kf * (1.0 + 1e-12) + 1e-300


@njit(cache=True, error_model="numpy", inline="always")
def _newton_last_step(E, lam, mu, mu_new, za3, q):
    """q = the eigenvector of Z(mu) moved to Z(mu_new) by first-order perturbation (za3:
    the couplings of the last f(mu), :func:`_f_df`)."""
    for i in range(4):
        q[i] = E[i, 0]
    dmu = mu_new - mu
    for a in range(1, 4):
        za = za3[a]
        gap = lam[0] - lam[a]
        if gap < 0.0:
            for i in range(4):
                q[i] += dmu * za / gap * E[i, a]


@njit(cache=True, error_model="numpy", inline="always")
def _dqitr_iterate(S, W, WV, V, xi, q, Z, lam, E, wk):
    """DQItr (appendix A): the fixed point of mu = mu~(q(mu)). Returns (mu, iterations,
    status)."""
    converged = False
    mu = 0.0
    iters = 0
    wscale = np.sqrt(xi[3])
    for i in range(4):
        for j in range(4):
            wscale = max(wscale, abs(W[i, j]) / max(np.sqrt(xi[3]), 1e-300))
    E0, ea, etmp = wk[7], wk[5], wk[6]
    for it in range(500):
        _z_eigen(S, WV, V, xi, mu, it == 0, Z, E0, lam, E, ea, etmp)
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
    return mu, iters, ST_OK if converged else ST_MAXITER


@njit(cache=True, error_model="numpy", inline="always")
def _relaxed(method, S, WV, V, xi, q, Z, lam, E, wk):
    """The methods from the relaxed problem Z0 = Z(0): DQConvRlx (its eigenvector), DQ2ndOrd
    and DQ2ndOrd-lambda (second-order expansions about it). Returns (mu, status)."""
    status = ST_OK
    _zmat(S, WV, V, xi, 0.0, Z)
    _eigh(Z, lam, E, wk[5])
    if method == DQCONVRLX:
        for i in range(4):
            q[i] = E[i, 0]
    else:
        Z1ab = wk[10]
        Z2ab = wk[11]
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
    return _mu_tilde(q, WV, V, xi), status


@njit(cache=True, error_model="numpy")
def _solve_core(method, S, W, M, q, qd, info, wk):
    """One DQ problem given (S, W, M) (eq. 9, prior included). Writes q, q' and info;
    ``wk``: the scratch of :func:`work_array`."""
    V, WV, Z, E = wk[0], wk[1], wk[2], wk[3]
    xi, lam = wk[4, 0], wk[4, 1]
    nclip = _m_eig_wv(S, W, M, xi, V, WV, wk[5])
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
        lam[0] = np.nan  # no eigen-decomposition of Z is needed
        lam[1] = np.nan
    elif method == DQOPT:
        mu, iters, status, lo, hi, f, df = _dqopt_newton(S, WV, V, xi, q, Z, lam, E, wk)
    elif method == DQITR:
        mu, iters, status = _dqitr_iterate(S, W, WV, V, xi, q, Z, lam, E, wk)
    else:
        mu, status = _relaxed(method, S, WV, V, xi, q, Z, lam, E, wk)
    _normalize(q)
    _qdual(q, mu, WV, V, xi, qd, wk[9, 0], wk[9, 1])
    _write_info(S, W, M, q, qd, info, mu, lam, iters, nclip, lo, hi, f, df, status, xi)


@njit(cache=True, error_model="numpy", inline="always")
def _write_info(S, W, M, q, qd, info, mu, lam, iters, nclip, lo, hi, f, df, status, xi):
    """The info vector (indices I_*) of a solution (q, q'), with its objective (the
    quadratic form of eq. 9 with these S, W, M); a non-finite (q, q') is ST_NONFINITE."""
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
    sa = np.empty((4, 4))
    nclip = _m_eig_wv(S, W, M, xi, V, WV, sa)
    Z = np.empty((4, 4))
    _zmat(S, WV, V, xi, mu, Z)
    _eigh(Z, lam, E, sa)
    pv = np.empty(4)
    pu = np.empty(4)
    pva = np.empty(4)
    pua = np.empty(4)
    f, df = _f_df(E, lam, WV, V, xi, mu, pv, pu, pva, pua, np.empty(4))
    out[0] = f
    out[1] = df
    out[2] = nclip
    K = np.empty((4, 4))
    for a in range(4):
        for b in range(4):
            K[a, b] = _k_entry(V, WV, xi, a, b)
    kw = np.empty(4)
    KV = np.empty((4, 4))
    _eigh(K, kw, KV, sa)
    out[3] = kw[0]
    out[4] = kw[3]


@njit(cache=True, error_model="numpy")
def _certificate_kernel(opt, S, W, M, q, qd, info, lam, E, out):
    """Everything the certificate evaluates, in one compiled entry: the dqopt solution of
    (S, W, M) (q, qd, info), then Z's eigen-decomposition and f, f' at mu*, at the bracket
    ends k_min, k_max and at mu* -/+ h (rows 0..4 of lam (5, 4), E (5, 4, 4), out (5, 5))."""
    _solve_core(opt, S, W, M, q, qd, info, np.empty((N_WORK, 4, 4)))
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
    _solve_core(METHOD_CODES[method], _c(S), _c(W), _c(M), q, qd, info, work_array())
    return q, qd, info
