"""Certificates of global optimality for DQ solutions (paper section 3.1.2); moved here
from the former ``simcalib.solvers.observability``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Certificate", "certify"]


# ------------------------------------------------------------------------- certificate
@dataclass(frozen=True)
class Certificate:
    """Certificate of global optimality of a DQ solution (paper section 3.1.2).

    Weak duality: for every mu, ``lambda0(mu)`` (smallest eigenvalue of ``Z(mu)``) is a lower
    bound of the constrained minimum, and ``lambda0`` is concave with its maximum where
    ``f(mu) = q0 . q0'`` (increasing in mu) changes sign. The solution is certified when

    * the root of f is bracketed: ``f(k_min) <= 0 <= f(k_max)`` on the appendix-C bracket,
      and unique: ``f' > 0`` (f is monotone);
    * ``lambda0(mu*)`` is the maximum: ``lambda0(mu* +- h) <= lambda0(mu*)``;
    * the eigenvalue is simple (``lambda1 - lambda0 > 0``, so q is unique up to sign);
    * the duality gap ``objective - lambda0(mu*)`` is at rounding level relative to the
      scale of the problem, and the KKT residuals of eq. (10) are at machine level.

    For noise-free data (M numerically singular, route "exact-fit") the bound used is 0
    (the cost is a sum of squares): certified when the cost itself is at rounding level.
    For approximate methods the same numbers are reported; ``certified`` is True only when
    their objective reaches the bound.
    """
    certified: bool
    route: str
    mu: float
    bracket: tuple
    f_at_bracket: tuple
    root_bracketed: bool
    f_monotone: bool
    df: float
    lambda0: float
    lambda1: float
    lambda0_is_max: bool
    objective: float
    lower_bound: float
    duality_gap: float
    relative_gap: float
    kkt_residual: float
    notes: str = ""

    def summary(self) -> str:
        if self.route == "exact-fit":
            return ("certificate: exact fit (cost %.3g at rounding level; lower bound 0), "
                    "global optimum" % self.objective if self.certified else
                    f"certificate: NOT certified ({self.notes})")
        head = "certified global optimum" if self.certified else "NOT certified"
        return (f"certificate: {head} (relative duality gap {self.relative_gap:.2g}, "
                f"KKT residual {self.kkt_residual:.2g}, mu* = {self.mu:.6g} in bracket "
                f"[{self.bracket[0]:.3g}, {self.bracket[1]:.3g}], "
                f"f' = {self.df:.3g} > 0, lambda1 - lambda0 = "
                f"{self.lambda1 - self.lambda0:.3g})" + (f"; {self.notes}" if self.notes else ""))

    def __str__(self) -> str:
        lines = [self.summary(),
                 f"  root bracketed: {self.root_bracketed}  f(k_min) = {self.f_at_bracket[0]:.3g}, "
                 f"f(k_max) = {self.f_at_bracket[1]:.3g}",
                 f"  f monotone (f'(mu*) = {self.df:.3g} > 0): {self.f_monotone}",
                 f"  lambda0(mu*) = {self.lambda0:.6g} is the maximum of the concave curve: "
                 f"{self.lambda0_is_max}",
                 f"  objective {self.objective:.10g} vs lower bound {self.lower_bound:.10g}: "
                 f"gap {self.duality_gap:.3g} (relative {self.relative_gap:.3g})",
                 f"  KKT residual (eq. 10, relative): {self.kkt_residual:.3g}"]
        return "\n".join(lines)


GAP_TOL = 1e-10
KKT_TOL = 1e-9


def certify(problem, alpha: float, prior, q, q_dual) -> Certificate:
    """Certificate for the DQ solution ``(q, q')`` of ``problem`` (see :class:`Certificate`)."""
    from simcalib.solvers.kernels.dqcore import I_MU, certificate_values
    from simcalib.solvers.kernels.gram import problem_matrices
    S, W, M = problem_matrices(problem, alpha, prior)
    q = np.asarray(q, dtype=np.float64)
    qd = np.asarray(q_dual, dtype=np.float64)
    obj = float(q @ S @ q + qd @ M @ qd + 2 * q @ W @ qd)
    scale = float(np.trace(S) / 4 + np.trace(M) / 4 + np.abs(W).max() + 1e-300)
    # the optimum's multiplier from the optimal solver, and Z evaluated at mu*, at the
    # bracket ends and at mu* -/+ h (one compiled call)
    _, _, info, lams, _, vals = certificate_values(S, W, M)
    mu = float(info[I_MU])
    lam = lams[0]
    f, df, nclip = float(vals[0, 0]), float(vals[0, 1]), int(vals[0, 2])
    kmin, kmax = float(vals[0, 3]), float(vals[0, 4])
    f_lo, f_hi = float(vals[1, 0]), float(vals[2, 0])
    lam_m, lam_p = float(lams[3, 0]), float(lams[4, 0])
    lam0 = float(lam[0])
    tol_l = 1e-13 * scale
    is_max = bool(lam_m <= lam0 + tol_l and lam_p <= lam0 + tol_l)
    bracketed = bool(f_lo <= 1e-13 * (1 + np.linalg.norm(qd)) and
                     f_hi >= -1e-13 * (1 + np.linalg.norm(qd)))
    monotone = bool(df > 0)
    # KKT residuals of eq. (10) at (q, q'), with lambda = objective, mu*
    r1 = S @ q + W @ qd - obj * q - mu * qd
    r2 = M @ qd + W.T @ q - mu * q
    kkt = float(max(np.abs(r1).max(), np.abs(r2).max(), abs(q @ qd)) /
                (scale * (1 + np.abs(qd).max())))
    if nclip > 0 and (prior is None):
        # M numerically singular: noise-free (or degenerate) data; bound = 0 (sum of
        # squares), the cost summed motion by motion (accurate near 0)
        from simcalib.solvers.problem import problem_cost
        cost = problem_cost(problem, q, qd, alpha)
        ok = bool(cost <= 1e-20 * scale * max(problem.n, 1))
        notes = ("M numerically singular (noise-free or degenerate data)" if ok else
                 f"M numerically singular but cost {cost:.3g} is not at rounding level; "
                 "optimality not proven")
        return Certificate(certified=ok, route="exact-fit", mu=mu, bracket=(kmin, kmax),
                           f_at_bracket=(f_lo, f_hi), root_bracketed=bracketed,
                           f_monotone=monotone, df=df, lambda0=lam0, lambda1=float(lam[1]),
                           lambda0_is_max=is_max, objective=cost, lower_bound=0.0,
                           duality_gap=cost, relative_gap=cost / scale, kkt_residual=kkt,
                           notes=notes)
    gap = obj - lam0
    rel = gap / max(abs(obj), abs(lam0), 1e-300 + 1e-16 * scale)
    ok = bool(bracketed and monotone and is_max and lam[1] > lam[0] and rel <= GAP_TOL
              and kkt <= KKT_TOL)
    notes = "" if ok else ", ".join(n for n, bad in [
        ("root not bracketed", not bracketed), ("f not increasing", not monotone),
        ("lambda0(mu*) not maximal", not is_max), ("degenerate eigenvalue", lam[1] <= lam[0]),
        (f"duality gap {rel:.2g} above {GAP_TOL:g}", rel > GAP_TOL),
        (f"KKT residual {kkt:.2g} above {KKT_TOL:g}", kkt > KKT_TOL)] if bad)
    if nclip > 0:
        notes = (notes + "; " if notes else "") + "M regularised (near-singular)"
    return Certificate(certified=ok, route="secular", mu=mu, bracket=(kmin, kmax),
                       f_at_bracket=(f_lo, f_hi), root_bracketed=bracketed,
                       f_monotone=monotone, df=df, lambda0=lam0, lambda1=float(lam[1]),
                       lambda0_is_max=is_max, objective=obj, lower_bound=lam0,
                       duality_gap=gap, relative_gap=rel, kkt_residual=kkt, notes=notes)
