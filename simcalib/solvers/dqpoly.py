"""DQOptPoly (paper appendix B): the optimum from the real-root count of the mu polynomial.

The Lagrange conditions (10) of the cost (9) are ``K(lam, mu) z = 0`` with ``z = (q, q')`` and
the symmetric 8x8 pencil ::

    K(lam, mu) = [[S - lam I, W - mu I], [W^T - mu I, M]].

Its determinant ``P(lam, mu) = det K(lam, mu) = det(M) det(Z(mu) - lam I)`` is the paper's
curve polynomial p(lam, mu) of eq. (15) times the constant det(M) -- written this way it needs
no inverse of M (so it stays defined when M is singular, e.g. on noise-free data). It has
degree 4 in lam and 8 in mu (monic in mu); the coefficient of lam^m has degree 8 - 2m in mu:
25 coefficients in all.

Appendix B: for lam below the optimum lam* the degree-8 polynomial P(lam, .) has 8 real roots
in mu; at lam* two of them merge (the maximum of the concave smallest-eigenvalue curve
lambda_0(mu)) and above it only 6 remain. We

1. extract the 25 coefficients once: for lam_j on a circle of radius ~ the cost scale
   (8 points) the mu-coefficients are the characteristic polynomial of the 8x8 companion
   ``J K(lam_j)`` (J swaps the q and q' blocks; ``det(K - mu J) = det(J K - mu I)``),
   computed from its eigenvalues (robust for roots of very different magnitudes);
   a discrete Fourier transform over the circle gives the lam-dependence exactly
   (degree 4 < 8 points, no aliasing);
2. count real roots with a Sturm sequence P_0 = P, P_1 = P', P_{k+1} = -rem(P_{k-1}, P_k),
   evaluated at -inf and +inf, in a scaled variable mu / s (s = norm of the Gram matrix).
   A float Sturm chain breaks down here (the merging pair sits in a cluster of small roots
   while others are ~1e2 larger: odd counts appear within ~1e-4 of lam* at low noise), so the
   chain is run in exact integer arithmetic on the float coefficients (pseudo-remainders,
   primitive parts): the count is exact for the extracted polynomial;
3. bisect lam on the predicate "8 real roots" (exact integer Sturm chain on the float
   coefficients, so the count itself never suffers from cancellation) between a lower bound
   (the convex relaxation's lambda_min(Z0), the smallest root of the quartic P(lam, 0), when
   the count confirms it; else 0, or -b |q^'|^2 with a prior, where the cost is bounded
   below) and an upper bound (the cost of a feasible unit
   dual quaternion: the constrained combination of the two smallest eigenvectors of
   ``[[S, W], [W^T, M]]``, as in Daniilidis' method), to relative width ~1e-15;
4. take mu* as the root of dP/dmu(lam*, .) nearest to the merging pair (a simple root, so it
   is well conditioned even though the pair itself is not), and z = (q, q') as the
   constrained combination of the two smallest right singular vectors of K(lam*, mu*).

If the upper bound is already at rounding level (noise-free data: M singular, lam* = 0) the
feasible null-space point is returned directly; it is then the exact X.

It is an independent and slower route to the optimum of dqopt (no eigen-decomposition of
Z(mu), no root of f(mu)); ~6-15 ms per problem at N = 100 (docs/solvers-classic.md).
"""

from __future__ import annotations

from math import gcd

import numpy as np
from numpy.polynomial import polynomial as npoly

from simcalib.geometry import transform_from_dual_quat
from simcalib.solvers.classic import unit_dual_quat_from_span
from simcalib.solvers.kernels.gram import prior_terms, problem_matrices
from simcalib.solvers.problem import MotionProblem, SolverOutput
from simcalib.solvers.registry import register

__all__ = ["curve_coefficients", "sturm_real_root_count_exact", "dqoptpoly"]

_J = np.block([[np.zeros((4, 4)), np.eye(4)], [np.eye(4), np.zeros((4, 4))]])
_E = np.diag([1.0] * 4 + [0.0] * 4)
_N_LAM = 8           # sample points on the lam circle (degree 4 < 8)
_BISECT_MAX = 200
_BISECT_RTOL = 1e-14  # relative bracket width on lam at which bisection stops


def curve_coefficients(S, W, M, lam_radius: float) -> np.ndarray:
    """Coefficients ``a[m, k]`` (5 x 9) of ``det K(lam, mu) = sum a[m, k] lam^m mu^k``."""
    K0 = np.block([[S, W], [W.T, M]]).astype(np.complex128)
    lam = lam_radius * np.exp(2j * np.pi * np.arange(_N_LAM) / _N_LAM)
    Ks = np.broadcast_to(K0, (_N_LAM, 8, 8)).copy()
    Ks[:, np.arange(4), np.arange(4)] -= lam[:, None]
    ev = np.linalg.eigvals(_J @ Ks)                                # (n_lam, 8) roots in mu
    # det(J K - mu I) = prod(ev - mu) = prod(mu - ev) (8 factors): monic in mu
    mu_coef = np.array([np.poly(e)[::-1] for e in ev])             # ascending in mu
    c = np.fft.fft(mu_coef, axis=0) / _N_LAM                        # c[m] = a[m] r^m
    a = c.real[:5] / (lam_radius ** np.arange(5))[:, None]
    # structure: coefficient of lam^m has degree <= 8 - 2m in mu
    for m in range(5):
        a[m, 9 - 2 * m:] = 0.0
    return a


def _mu_poly(a: np.ndarray, lam: float) -> np.ndarray:
    """Coefficients (ascending in mu) of P(lam, .)."""
    return a.T @ (lam ** np.arange(5))


def _exact_integers(p) -> list[int]:
    """Float coefficients as integers with one common power-of-two scale (exact)."""
    fr = [float(v).as_integer_ratio() for v in p]
    den = max(d for _, d in fr)
    return [n * (den // d) for n, d in fr]


def _primitive(a: list[int]) -> list[int]:
    g = 0
    for v in a:
        g = gcd(g, v)
    return [v // g for v in a] if g > 1 else a


def sturm_real_root_count_exact(p: np.ndarray) -> int:
    """Sturm count in exact integer arithmetic on the float coefficients of ``p`` (ascending):
    the float values are represented exactly, the chain uses pseudo-remainders with the
    sign bookkeeping of -rem and primitive parts (positive scalings keep every sign), so the
    count is exact for the polynomial as given; ~0.2-0.5 ms for degree 8."""
    c = _exact_integers(np.asarray(p, dtype=np.float64))
    while c and c[-1] == 0:
        c.pop()
    if len(c) <= 1:
        return 0
    c = _primitive(c)
    seq = [c, _primitive([i * v for i, v in enumerate(c)][1:])]
    while len(seq[-1]) > 1:
        a, b = seq[-2], seq[-1]
        lb = b[-1]
        steps = 0
        while len(a) >= len(b):      # a <- lb * a - lead(a) x^sh b  (a = lb^steps * rem)
            f = a[-1]
            sh = len(a) - len(b)
            a = [lb * v for v in a]
            for i, v in enumerate(b):
                a[sh + i] -= f * v
            a.pop()
            steps += 1
            while a and a[-1] == 0:
                a.pop()
        if not a:
            break
        sign = -1 if (lb < 0 and steps % 2) else 1
        seq.append(_primitive([-sign * v for v in a]))
    plus = [1 if s_[-1] > 0 else -1 for s_ in seq]
    minus = [sg * (1 if (len(s_) - 1) % 2 == 0 else -1) for sg, s_ in zip(plus, seq)]

    def changes(v):
        return sum(1 for x, y in zip(v, v[1:]) if x * y < 0)
    return changes(minus) - changes(plus)


def _feasible_from_gram(G: np.ndarray):
    """Unit dual quaternion in the span of the two smallest eigenvectors of G, its value."""
    e, V = np.linalg.eigh(G)
    try:
        q, qd = unit_dual_quat_from_span(V[:, 0], V[:, 1])
    except ValueError:
        return None, np.inf, e
    z = np.concatenate([q, qd - (q @ qd) * q])
    return z, float(z @ G @ z), e


def _dual_given_q(S, W, M, q):
    """The best feasible ``q'`` for a fixed unit ``q``: minimise ``q'^T M q' + 2 q^T W q'``
    subject to ``q . q' = 0`` (KKT system, least squares when M is singular)."""
    A = np.zeros((5, 5))
    A[:4, :4] = M
    A[:4, 4] = q
    A[4, :4] = q
    rhs = np.concatenate([-W.T @ q, [0.0]])
    qd = np.linalg.lstsq(A, rhs, rcond=None)[0][:4]
    return np.concatenate([q, qd - (q @ qd) * q])


def _upper_bound(S, W, M, G):
    """The lowest cost among cheap feasible unit dual quaternions (each is an upper bound on
    lam*): the constrained null-space point of G (Daniilidis-like), and the best q' for
    q from the convex relaxation (smallest eigenvector of S - W M^+ W^T) and from the
    rotation equations alone (smallest eigenvector of M)."""
    z0, v0, eG = _feasible_from_gram(G)
    cands = [(v0, z0, "null space")]
    Z0 = S - W @ np.linalg.pinv(M, rcond=1e-15, hermitian=True) @ W.T
    for q, name in ((np.linalg.eigh(0.5 * (Z0 + Z0.T))[1][:, 0], "relaxation"),
                    (np.linalg.eigh(M)[1][:, 0], "rotation only")):
        z = _dual_given_q(S, W, M, q / np.linalg.norm(q))
        if np.isfinite(z).all():
            cands.append((float(z @ G @ z), z, name))
    cands = [c for c in cands if np.isfinite(c[0])]
    if not cands:
        raise ValueError("dqoptpoly: no feasible starting point (the cost matrices do not "
                         "involve the rotation)")
    v, z, name = min(cands, key=lambda c: c[0])
    return z, v, eG, name


def _cost_matrices(problem: MotionProblem, alpha: float, prior):
    """``(S, W, M)``, the symmetrised ``G = [[S, W], [W^T, M]]``, the prior constant, the scale."""
    S, W, M = problem_matrices(problem, alpha, prior)
    G = np.block([[S, W], [W.T, M]])
    G = 0.5 * (G + G.T)
    const = prior_terms(prior)[3] if prior is not None else 0.0
    scale = float(np.abs(np.linalg.eigvalsh(G)).max())
    if scale == 0.0:
        raise ValueError("dqoptpoly: the cost matrices are all zero (no motion information)")
    return S, W, M, G, const, scale


def _exact_data_output(problem: MotionProblem, G, z_feas, eG, hi: float, scale: float,
                       info: dict) -> SolverOutput:
    """The result on exact data: X from the null space of G (cost 0), flagged if not unique."""
    n_null = int(np.sum(eG <= 1e-10 * scale))
    if n_null > 2:
        from simcalib.solvers.classic import unit_dual_quat_from_null_space
        try:
            q, qd = unit_dual_quat_from_null_space(np.linalg.eigh(G)[1][:, :n_null].T)
            z_feas = np.concatenate([q, qd - (q @ qd) * q])
        except ValueError:
            from simcalib.solvers.classic import describe_motion_degeneracy
            return SolverOutput(np.full((4, 4), np.nan), info, success=False, message=(
                f"degenerate: {describe_motion_degeneracy(problem)}; no estimate"))
    X = transform_from_dual_quat(z_feas[:4], z_feas[4:])
    info.update(lam_star=hi, mu_star=0.0, iterations=0, route="null space (exact data)")
    msg = "exact data: optimum from the null space of [[S, W], [W^T, M]] (cost 0)"
    ok = n_null <= 2
    if not ok:
        from simcalib.solvers.classic import describe_motion_degeneracy
        msg = (f"degenerate: [[S, W], [W^T, M]] has {n_null} zero eigenvalues (a unique X "
               f"needs 2): {describe_motion_degeneracy(problem)}; X is one arbitrary "
               "exact solution")
    return SolverOutput(X, info, success=ok, message=msg)


def _nu_coefficients(a: np.ndarray, scale: float) -> np.ndarray:
    """Coefficients in the scaled variable ``nu = mu / scale`` (coefficient k times scale^k)."""
    return a * (scale ** np.arange(9))[None, :]


class _RootCounter:
    """Exact Sturm count of the real nu roots of P(lam, .) for ``a_nu``, counting its calls."""

    def __init__(self, a_nu: np.ndarray):
        self.a_nu = a_nu
        self.calls = 0

    def __call__(self, lam: float) -> int:
        self.calls += 1
        return sturm_real_root_count_exact(_mu_poly(self.a_nu, lam))


def _relaxation_lower_bound(count: _RootCounter, lo: float, hi: float, scale: float) -> float:
    """The convex relaxation's lambda_min(Z0) as the lower bound when the count confirms it."""
    # tighter lower bound: the convex relaxation lambda_min(Z0) (<= lam*), i.e. the smallest
    # real root of the quartic P(lam, 0) = det(M) det(Z0 - lam I); kept only if the exact
    # count confirms 8 real roots there
    quartic = np.trim_zeros(count.a_nu[:, 0], "b")
    if quartic.size > 1:
        r = np.roots(quartic[::-1])
        r = r[np.abs(r.imag) <= 1e-9 * np.maximum(np.abs(r), 1e-300)].real
        r = r[(r > lo) & (r < hi)]
        if r.size:
            lo_relax = float(r.min()) - 1e-14 * (abs(float(r.min())) + scale * 1e-16)
            if lo_relax > lo and count(lo_relax) == 8:
                lo = lo_relax
    return lo


def _bisect_root_count(count: _RootCounter, lo: float, hi: float, it: int):
    """Bisect lam on "8 real roots" (true at lo, false at hi) to relative width _BISECT_RTOL."""
    while it < _BISECT_MAX and hi - lo > _BISECT_RTOL * max(abs(hi), abs(lo)):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if count(mid) == 8:
            lo = mid
        else:
            hi = mid
        it += 1
    return lo, hi, it


def _first_bracket(count: _RootCounter, lo: float, hi: float, scale: float, info: dict):
    """Counts at the bounds, the relaxation lower bound, then bisection: ``lo, hi, it, n_hi``."""
    n_lo, n_hi = count(lo), count(hi)
    info.update(count_at_lower=n_lo, count_at_upper=n_hi)
    lo = _relaxation_lower_bound(count, lo, hi, scale)
    info["lam_lower_bisection"] = lo
    if n_lo != 8:
        raise RuntimeError(f"dqoptpoly: expected 8 real mu roots at the lower bound lam = {lo:.6g}"
                           f", found {n_lo} (numerically unresolved polynomial)")
    it = 0
    if n_hi == 8:          # the feasible point is (to rounding) already optimal
        lo = hi
    lo, hi, it = _bisect_root_count(count, lo, hi, it)
    return lo, hi, it, n_hi


def _rebracket_re_extracted(count: _RootCounter, S, W, M, scale: float, lo: float, hi: float,
                            it: int, info: dict):
    """Re-extract the coefficients near lam*, re-find the bracket and bisect: ``lo, hi, it, ok``."""
    # the coefficients are accurate for |lam| up to ~radius: if lam* came out much smaller,
    # re-extract them on a circle of radius ~lam*, find a bracket around the previous answer
    # with the new coefficients (widening it by factors of 10) and bisect again
    count.a_nu = _nu_coefficients(curve_coefficients(S, W, M, max(abs(lo), abs(hi), 1e-300)),
                                  scale)
    info["re_extracted"] = True
    verified = False
    w = 1e-13 * max(abs(lo), abs(hi), 1e-300)
    for _ in range(14):
        if count(lo - w) == 8 and count(hi + w) < 8:
            lo, hi, it = _bisect_root_count(count, lo - w, hi + w, it)
            verified = True
            break
        w *= 10.0
    return lo, hi, it, verified


def _nu_on_curve(a_nu: np.ndarray, lam_star: float, dp: np.ndarray) -> float:
    """The root of dP/dnu(lam*, .) on the curve through lam* (smallest |P / dP/dlam|)."""
    droots = np.roots(dp[::-1]).real
    a_dlam = a_nu[1:] * np.arange(1, 5)[:, None]
    pows = lam_star ** np.arange(5)
    dist = []
    for nu in droots:
        nup = nu ** np.arange(9)
        P = pows @ a_nu @ nup
        dP = pows[:4] @ a_dlam @ nup
        dist.append(abs(P / dP) if dP != 0 else np.inf)
    return float(droots[int(np.argmin(dist))])


def _newton_polish(dp: np.ndarray, nu_star: float) -> float:
    """Up to three Newton steps on dP/dnu(lam*, nu) = 0 (a simple root) from ``nu_star``."""
    ddp = npoly.polyder(dp)
    for _ in range(3):
        den = npoly.polyval(nu_star, ddp)
        if den == 0:
            break
        step = npoly.polyval(nu_star, dp) / den
        nu_star -= step
        if abs(step) <= 1e-16 * max(abs(nu_star), 1e-300):
            break
    return nu_star


def _mu_star(a_nu: np.ndarray, lam_star: float, scale: float) -> float:
    """mu* of the double root (lam*, mu*) of P: P = dP/dmu = 0."""
    # mu*: (lam*, mu*) is a double root, P = dP/dmu = 0. Among the roots of dP/dmu(lam*, .)
    # (the extrema of the curves lambda_i(mu) at ...) take the one on the curve through
    # lam*: smallest lam-distance |P / dP/dlam| (a Newton step in lam, evaluated at lam*
    # where the extracted coefficients are accurate).
    dp = npoly.polyder(_mu_poly(a_nu, lam_star))
    nu_star = _newton_polish(dp, _nu_on_curve(a_nu, lam_star, dp))
    return float(nu_star * scale)


def _dual_quat_at(G, lam_star: float, mu_star: float):
    """The best unit dual quaternion from the null vectors of K(lam*, mu*): ``z, value, sv``."""
    K = G - lam_star * _E - mu_star * _J
    _, sv, Vt = np.linalg.svd(K)
    q, qd = unit_dual_quat_from_span(Vt[-1], Vt[-2])
    cands = [np.concatenate([q, qd - (q @ qd) * q])]
    # the smallest singular vector alone (normalised) is the generic answer
    v = Vt[-1] / np.linalg.norm(Vt[-1][:4])
    v = v * np.sign(v[3] if v[3] != 0 else 1.0)
    cands.append(np.concatenate([v[:4], v[4:] - (v[:4] @ v[4:]) * v[:4]]))
    vals = [float(c @ G @ c) for c in cands]
    return cands[int(np.argmin(vals))], min(vals), sv


def dqoptpoly(problem: MotionProblem, alpha: float = 1.0, prior=None) -> SolverOutput:
    """The optimal X of cost (8) (+ prior) by appendix B's root counting."""
    S, W, M, G, const, scale = _cost_matrices(problem, alpha, prior)
    z_feas, hi, eG, hi_from = _upper_bound(S, W, M, G)
    lo = -const
    info = {"lam_upper_start": hi, "lam_upper_from": hi_from, "lam_lower_start": lo,
            "gram_eigenvalues": eG}
    # noise-free / exact case: the feasible point from the null space has zero cost; more
    # than 2 zero eigenvalues (exact, degenerate motions, e.g. pure translation) likewise,
    # where the feasible point found may miss the null space and the polynomial is flat
    if hi - lo <= 1e-13 * scale or int(np.sum(eG <= 1e-10 * scale)) > 2:
        return _exact_data_output(problem, G, z_feas, eG, hi, scale, info)

    radius = max(abs(hi), abs(lo), 1e-300)
    a = curve_coefficients(S, W, M, radius)
    count = _RootCounter(_nu_coefficients(a, scale))
    lo, hi, it, n_hi = _first_bracket(count, lo, hi, scale, info)
    verified = True
    if n_hi != 8 and max(abs(lo), abs(hi)) < radius / 16:
        lo, hi, it, verified = _rebracket_re_extracted(count, S, W, M, scale, lo, hi, it, info)
    lam_star = 0.5 * (lo + hi)
    mu_star = _mu_star(count.a_nu, lam_star, scale)
    z, objective, sv = _dual_quat_at(G, lam_star, mu_star)
    X = transform_from_dual_quat(z[:4], z[4:])
    info.update(lam_star=lam_star, mu_star=mu_star, iterations=it, route="sturm bisection",
                sturm_counts=count.calls,
                coefficients=a, objective=objective, K_singular_values=sv)
    if not verified:
        return SolverOutput(X, info, success=False, message=(
            f"dqoptpoly: the 8 -> 6 root-count bracket [{lo:.6g}, {hi:.6g}] was not confirmed "
            "by coefficients re-extracted near lam* (numerically unresolved polynomial); "
            "use dqopt"))
    return SolverOutput(X, info, success=True,
                        message=f"lam* = {lam_star:.12g} (8 -> 6 real mu roots), mu* = "
                                f"{mu_star:.6g}, {it} Sturm bisection steps")


@register("dqoptpoly", family="dq", uses_alpha=True, supports_prior=True,
          supports_weights=True, expected_cost_us=8000.0,
          description="optimal DQ solution by Sturm root counting of the degree-8 mu "
                      "polynomial (appendix B); slower, independent of dqopt")
def _dqoptpoly(problem, alpha, prior, rng):
    return dqoptpoly(problem, alpha, prior)
