"""The plain single-problem solve: checks, the timed solver call, the :class:`Solution`.

:func:`solve_single` is :func:`simcalib.solve` without outlier handling (``robust``): the
layer below both the public :func:`simcalib.solvers.api.solve` (which adds ``robust=``)
and :mod:`simcalib.solvers.robust` (which solves subsets and weighted problems through
it). Its options and their checks are those of ``simcalib.solve`` (documented there).
"""

from __future__ import annotations

import math
import time

import numpy as np

from simcalib.solvers import registry
from simcalib.solvers.kernels.batch import warm_up
from simcalib.solvers.problem import SolverOutput, prepare_problem, rotation_shortfall
from simcalib.solvers.solution import PENDING, Solution
from simcalib.solvers.validation import (_check_method_inputs, _check_rng, _finish_output,
                                         check_alpha)

__all__ = ["solve_single", "check_options", "solve_checked"]


def check_options(method, alpha, *, tolerance_deg, tolerance_m, uncertainty,
                  bootstrap_samples, correlation_lag, pose_bias, pose_pairs,
                  pose_error_basis, pose_simulation, robust="none") -> tuple:
    """The checked options that need no motions: ``(info, alpha, tolerance_deg,
    tolerance_m, correlation_lag, pose_bias)`` (the order of the checks, and so which
    error a call with several bad options gets, is that of ``simcalib.solve``)."""
    info = registry.get(method)
    alpha = check_alpha(alpha)
    pose_bias = _check_pose_options(pose_bias, pose_pairs, pose_error_basis, pose_simulation,
                                    alpha, robust)
    tolerance_deg, tolerance_m, correlation_lag = _check_uncertainty_options(
        tolerance_deg, tolerance_m, uncertainty, bootstrap_samples, correlation_lag)
    return info, alpha, tolerance_deg, tolerance_m, correlation_lag, pose_bias


def solve_single(C, H, method: str = "dqopt", alpha: float = 1.0, prior=None,
                 rng: np.random.Generator | None = None, weights=None, *,
                 tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                 uncertainty: str = "sandwich", bootstrap_samples: int = 200,
                 correlation_lag: int = 0, pose_bias=None, pose_pairs=None,
                 pose_error_basis=None, pose_simulation=None) -> Solution:
    """``simcalib.solve`` without ``robust``: the same options, checks and numbers."""
    info, alpha, tolerance_deg, tolerance_m, correlation_lag, pose_bias = check_options(
        method, alpha, tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
        uncertainty=uncertainty, bootstrap_samples=bootstrap_samples,
        correlation_lag=correlation_lag, pose_bias=pose_bias, pose_pairs=pose_pairs,
        pose_error_basis=pose_error_basis, pose_simulation=pose_simulation)
    return solve_checked(info, C, H, alpha, prior, rng, weights, tolerance_deg=tolerance_deg,
                         tolerance_m=tolerance_m, uncertainty=uncertainty,
                         bootstrap_samples=bootstrap_samples, correlation_lag=correlation_lag,
                         pose_bias=pose_bias, pose_pairs=pose_pairs,
                         pose_error_basis=pose_error_basis, pose_simulation=pose_simulation)


def solve_checked(info, C, H, alpha: float, prior, rng, weights, *, tolerance_deg,
                  tolerance_m, uncertainty, bootstrap_samples, correlation_lag, pose_bias,
                  pose_pairs, pose_error_basis, pose_simulation) -> Solution:
    """The solve once :func:`check_options` passed (``info``: the method's registry entry):
    checks of the method's inputs, the timed solve, the :class:`Solution` (cost, objective
    and diagnostics evaluated on first read)."""
    boot_rng = bootstrap_rng(uncertainty, rng)
    prior, rng = _check_method_inputs(info, prior, weights, rng)
    problem, out, runtime, compile_s, shortfall = _run_solver(info, C, H, alpha, prior, rng,
                                                              weights)
    pose_pairs, pose_error_basis = _check_pose_structure(pose_pairs, pose_error_basis,
                                                         pose_simulation, problem.n, alpha)
    X, success, message, diag = _finish_output(out, info.name)
    if shortfall is not None:       # the estimate stays (comparisons measure it), named so
        diag["rotation_shortfall"] = shortfall
        message = f"degenerate motions for {info.name}: {shortfall}" + (
            f"; {message}" if message else "")
    diag["sign_flips"] = problem.sign_flips
    diag["compile_s"] = compile_s
    if np.isfinite(X).all():   # cost and objective: evaluated on first read
        cost = objective = PENDING
    else:
        cost = objective = math.inf
        success = False
    return Solution(X=X, cost=cost, objective=objective, method=info.name, alpha=alpha,
                    runtime_s=runtime, success=success, solver_message=message,
                    n_motions=problem.n, family=info.family, prior=prior,
                    diagnostics=diag, problem=problem, tolerance_deg=tolerance_deg,
                    tolerance_m=tolerance_m, uncertainty_method=uncertainty,
                    bootstrap_rng=boot_rng, bootstrap_samples=int(bootstrap_samples),
                    correlation_lag=correlation_lag, pose_bias=pose_bias,
                    pose_pairs=pose_pairs, pose_error_basis=pose_error_basis,
                    pose_simulation=pose_simulation)


def _check_pose_options(pose_bias, pose_pairs, pose_error_basis, pose_simulation, alpha,
                        robust):
    """The checked ``pose_bias``, after the checks of the pose inputs that need no motions."""
    if pose_bias is None and pose_pairs is None and pose_error_basis is None \
            and pose_simulation is None:
        return None   # the defaults: nothing to check
    from simcalib.solvers.diagnostics.uncertainty import check_pose_bias
    pose_bias = check_pose_bias(pose_bias)
    from simcalib.solvers.diagnostics.pose_noise import check_pose_inputs
    check_pose_inputs(pose_pairs, pose_error_basis, pose_simulation, None, alpha)
    if pose_pairs is not None:
        if robust != "none":
            raise ValueError("pose_pairs cannot be combined with robust=" + repr(robust) +
                             ": the motions it rejects break the pose structure; pass "
                             "pose_pairs=None")
    return pose_bias


def _check_uncertainty_options(tolerance_deg, tolerance_m, uncertainty, bootstrap_samples,
                               correlation_lag) -> tuple:
    """The checked ``(tolerance_deg, tolerance_m, correlation_lag)`` of the uncertainty."""
    if not (type(tolerance_deg) is float and 0.0 < tolerance_deg < math.inf
            and type(tolerance_m) is float and 0.0 < tolerance_m < math.inf):
        # (a positive finite Python float passes check_tolerances unchanged)
        from simcalib.solvers.diagnostics.uncertainty import check_tolerances
        tolerance_deg, tolerance_m = check_tolerances(tolerance_deg, tolerance_m)
    if uncertainty not in ("sandwich", "bootstrap"):
        raise ValueError(f"uncertainty must be 'sandwich' or 'bootstrap'; received "
                         f"{uncertainty!r}")
    if isinstance(bootstrap_samples, bool) or not isinstance(
            bootstrap_samples, (int, np.integer)) or bootstrap_samples < 2:
        raise ValueError(f"bootstrap_samples must be an integer >= 2; received "
                         f"{bootstrap_samples!r}")
    if not (type(correlation_lag) is int and correlation_lag == 0):   # 0 passes as 0
        from simcalib.solvers.diagnostics.uncertainty import _check_lag
        correlation_lag = _check_lag(correlation_lag, 10**9)
    return tolerance_deg, tolerance_m, correlation_lag


def bootstrap_rng(uncertainty, rng) -> np.random.Generator | None:
    """The bootstrap's generator (a child of ``rng``, else ``default_rng(0)``), or None."""
    boot_rng = None
    if uncertainty == "bootstrap":
        boot_rng = np.random.default_rng(_check_rng(rng).bit_generator.seed_seq.spawn(1)[0]) \
            if rng is not None else np.random.default_rng(0)
    return boot_rng


def _run_solver(info, C, H, alpha, prior, rng, weights) -> tuple:
    """``(problem, solver output, runtime_s, compile_s, shortfall)`` of the timed solve of
    ``(C, H)``; ``shortfall``: why the motions' rotations cannot give X's rotation, for a
    method whose rotation step uses them alone (``needs_rotation``:
    :func:`~simcalib.solvers.problem.rotation_shortfall`), else None. Such a method still
    solves (its rotation is then fitted to the noise, as the paper's Table 2 measures on
    ``line``); the solution's message names the shortfall and ``degenerate`` is True."""
    compile_s = warm_up()
    t0 = time.perf_counter()
    problem = prepare_problem(C, H, alpha, weights)
    shortfall = rotation_shortfall(problem.C, problem.H) \
        if info.extra.get("needs_rotation") else None
    try:
        out = info.fn(problem, alpha, prior, rng)
    except Exception as exc:  # noqa: BLE001 - a solver failing on valid input is reported
        out = SolverOutput(X=np.full((4, 4), np.nan), success=False,
                           message=f"solver raised {type(exc).__name__}: {exc}")
    runtime = time.perf_counter() - t0
    return problem, out, runtime, compile_s, shortfall


def _check_pose_structure(pose_pairs, pose_error_basis, pose_simulation, n: int,
                          alpha: float) -> tuple:
    """The checked ``(pose_pairs, pose_error_basis)`` for ``n`` motions."""
    if pose_pairs is None:   # _check_pose_options refused a basis or simulation without pairs
        return None, None
    from simcalib.solvers.diagnostics.pose_noise import check_pose_inputs
    pose_pairs, pose_error_basis, _ = check_pose_inputs(pose_pairs, pose_error_basis,
                                                        pose_simulation, n, alpha)
    return pose_pairs, pose_error_basis
