"""The paper's dual-quaternion methods (Dekel et al., CVPR 2020, section 3 and appendix A):
registration only.

The cost (paper eq. 8) for unit dual quaternion ``q + eps q'`` of ``X``::

    sum_i w_i (|A_i q|^2 + alpha^2 |B_i q + A_i q'|^2),   |q| = 1,  q . q' = 0

is the quadratic form of eq. 9 (:mod:`simcalib.solvers.kernels.gram`); every method runs
in the fused compiled kernel :mod:`simcalib.solvers.kernels.batch` (one problem or a
batch), whose per-problem core is :mod:`simcalib.solvers.kernels.dqcore`.
"""

from __future__ import annotations

import numpy as np

from simcalib.solvers.kernels import batch as kernel_batch
from simcalib.solvers.kernels import dqcore
from simcalib.solvers.problem import MotionProblem, SolverOutput
from simcalib.solvers.registry import register

__all__ = ["DESCRIPTIONS", "solve_dq"]


def _prior_adds(prior):
    if prior is None:
        return None
    from simcalib.solvers.kernels.gram import prior_terms
    return prior_terms(prior)[:3]


def _diagnostics(method: str, info) -> dict:
    status = int(info[dqcore.I_STATUS])
    diag = {"mu": float(info[dqcore.I_MU]), "lambda0": float(info[dqcore.I_LAM0]),
            "lambda1": float(info[dqcore.I_LAM1]), "iterations": int(info[dqcore.I_ITERS]),
            "n_clipped": int(info[dqcore.I_NCLIP]), "status": status}
    if method == "dqopt":
        diag.update(bracket=(float(info[dqcore.I_LO]), float(info[dqcore.I_HI])),
                    f=float(info[dqcore.I_F]), df=float(info[dqcore.I_DF]))
    return diag


def solve_dq(method: str, problem: MotionProblem, alpha: float, prior=None) -> SolverOutput:
    """One paper DQ method on a prepared (aligned) problem: Gram blocks + the method."""
    code = dqcore.METHOD_CODES[method]
    kept = problem.kept_dqopt(float(alpha)) if code == dqcore.DQOPT and prior is None \
        else None
    if kept is not None:   # the alignment solved it already (same kernel code and motions)
        X, info = kept
    else:
        w = None if problem.weights is None else problem.weights[None]
        out = kernel_batch.run_batch(code, np.array([float(alpha)]), Q=problem.soa()[None],
                                     weights=w, prior_adds=_prior_adds(prior), align=False)
        X, info = out["X"][0], out["info"][0]
    status = int(info[dqcore.I_STATUS])
    return SolverOutput(X=X, diagnostics=_diagnostics(method, info),
                        success=status not in dqcore.FAILED_STATUSES,
                        message=dqcore.STATUS_TEXT.get(status, ""))


def _make_solver(method: str):
    def solve_one(problem: MotionProblem, alpha: float, prior, rng) -> SolverOutput:
        return solve_dq(method, problem, alpha, prior)
    solve_one.__name__ = f"_{method}"
    return solve_one


def _make_batch(method: str):
    code = dqcore.METHOD_CODES[method]

    def solve_many(C, H, alphas, prior, weights=None) -> dict:
        """C, H (B, N, 4, 4) float64 C-contiguous (validated in the kernel); alphas (B,);
        weights (B, N) or None."""
        out = kernel_batch.run_batch(code, alphas, C=C, H=H, weights=weights,
                                     prior_adds=_prior_adds(prior))
        info = out["info"]
        status = info[:, dqcore.I_STATUS].astype(np.int64)
        failed = out["bad"] >= 0
        for st in dqcore.FAILED_STATUSES:
            failed |= status == st
        reason = np.full(len(status), "", dtype=object)
        for b in np.flatnonzero(failed):   # text only for the (few) failed problems
            reason[b] = dqcore.STATUS_TEXT.get(int(status[b]), "")
        return {"X": out["X"], "cost": out["cost"], "bad": out["bad"],
                "success": ~failed, "failure_reason": reason, "mu": info[:, dqcore.I_MU],
                "iterations": info[:, dqcore.I_ITERS].astype(np.int64),
                "n_clipped": info[:, dqcore.I_NCLIP].astype(np.int64),
                "lambda0": info[:, dqcore.I_LAM0], "sign_flips": out["nflip"]}
    solve_many.__name__ = f"_{method}_batch"
    return solve_many


DESCRIPTIONS = {
    "dqopt": "optimal: root of the monotone f(mu) = q0.q0' (paper 3.2.1), appendix-C bracket, "
             "safeguarded Newton with the closed-form derivative; certified",
    "dq2steps": "two steps (3.2.2): rotation from M's smallest eigenvector, then q' by eq. 20",
    "dqconvrlx": "convex relaxation (3.2.3): smallest eigenvector of Z0, q' by eq. 20",
    "dq2ndord": "second-order expansion in mu around the relaxed solution (eq. 23)",
    "dq2ndord_lambda": "second-order expansion in Delta-lambda (appendix A, eqs. 35-36)",
    "dqitr": "fixed-point iteration mu <- mu~(q(mu)) (3.2.5, Algorithm 5)",
}
# expected cost of one solve at N = 100 (us), for planning experiment chunks; measured with
# `python -m simcalib bench` (order of magnitude, machine-dependent)
_EXPECTED_US = {"dqopt": 25.0, "dq2steps": 20.0, "dqconvrlx": 20.0, "dq2ndord": 20.0,
                "dq2ndord_lambda": 20.0, "dqitr": 60.0}

for _name in dqcore.METHOD_CODES:
    register(_name, family="dq", description=DESCRIPTIONS[_name], supports_prior=True,
             certified=(_name == "dqopt"), batch=_make_batch(_name), batch_validates=True,
             supports_weights=True, alpha_independent=(_name == "dq2steps"),
             needs_rotation=(_name == "dq2steps"),
             expected_cost_us=_EXPECTED_US[_name])(_make_solver(_name))
