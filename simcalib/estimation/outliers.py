"""Outlier handling of the estimation path: which robust method a set of motions gets
(:func:`robust_fit`), for the path's fit (:mod:`simcalib.estimation.path`), each stretch of
a changed mount (:mod:`simcalib.estimation.mount`) and a simulated scenario's streams
(:mod:`simcalib.estimation.streams`)."""

from __future__ import annotations

import numpy as np

__all__ = ["robust_fit"]


def robust_fit(C, H, robust, *, alpha, method, seed, options):
    """``(RobustSolution, why)``: ``robust`` ``auto`` takes RANSAC where the motions
    supply minimal sets, IRLS (no minimal sets needed) where they do not (e.g. every
    rotation about one axis), and no rejection with fewer than 8 motions."""
    from simcalib.errors import SolverError
    from simcalib.solvers.robust import robust_solve
    n = C.shape[0]
    opts = dict(options or {})
    if robust == "auto":
        if n < 8:
            return (robust_solve(C, H, "none", alpha=alpha, method=method),
                    f"{n} motions are too few to reject outliers among them")
        try:
            return (robust_solve(C, H, "ransac", alpha=alpha, final_method=method,
                                 rng=np.random.default_rng(seed), **opts),
                    "RANSAC over minimal sets of motions")
        except (SolverError, ValueError) as exc:
            why = str(exc).splitlines()[0]
            return (robust_solve(C, H, "irls", alpha=alpha, method=method, init="none",
                                 rng=np.random.default_rng(seed)),
                    f"IRLS (Cauchy), as RANSAC could not run: {why}")
    if robust in ("ransac", "irls"):
        opts.setdefault("rng", np.random.default_rng(seed))
    opts.setdefault("final_method" if robust == "ransac" else "method", method)
    return robust_solve(C, H, robust, alpha=alpha, **opts), f"{robust} (given)"
