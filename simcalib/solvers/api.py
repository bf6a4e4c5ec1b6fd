"""Public solver API: :func:`solve`, :func:`solve_batch`, :class:`Solution`,
:class:`BatchSolution`, :class:`Prior`, :func:`dq_cost`.

Convention (docs/conventions.md): ``C_i X = X H_i`` with ``X = T_a_b`` (pose of sensor b in sensor a),
``C_i`` the relative motions of a and ``H_i`` those of b.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from simcalib.solvers import registry
from simcalib.solvers.kernels.batch import warm_up
from simcalib.solvers.problem import SolverOutput, prepare_problem
from simcalib.solvers.validation import (  # noqa: F401
    Prior,
    _RIGID_FAST_TOL,
    _as_dual_quat,
    _as_problem,
    _check_method_inputs,
    _check_prior,
    _check_prior_supported,
    _check_rng,
    _check_weights_supported,
    _clearly_rigid,
    _cost_and_objective,
    _finish_output,
    check_alpha,
    dq_cost,
)
from simcalib.solvers.solution import (  # noqa: F401
    PENDING,
    Solution,
    _LazyField,
    _Pending,
    _num,
    _uncertainty_dict,
)
from simcalib.solvers.batch_solve import (  # noqa: F401
    BatchSolution,
    _as_float_array,
    _check_alphas,
    _loop,
    _prior_penalty_batch,
    solve_batch,
)


__all__ = ["Prior", "Solution", "BatchSolution", "solve", "solve_batch", "dq_cost",
           "check_alpha"]


def _solve_robust(C, H, method, alpha, robust, threshold, rng, *, tolerance_deg,
                  tolerance_m, weights, prior) -> Solution:
    """``solve(..., robust=...)``: the robust method's final solve, with its inlier mask and
    weights in ``diagnostics``."""
    from simcalib.solvers.robust import ROBUST_METHODS, robust_solve
    from simcalib.errors import unknown_choice
    if robust not in ROBUST_METHODS:
        raise unknown_choice("robust method", robust, ROBUST_METHODS, key="robust")
    if weights is not None or prior is not None:
        raise ValueError(f"robust={robust!r} sets the motions' weights itself and takes no "
                         f"prior; received weights={weights is not None}, "
                         f"prior={prior is not None}")
    if not registry.get(method).supports_weights:
        able = [i.name for i in registry.infos() if i.supports_weights]
        raise ValueError(f"robust={robust!r} needs a method that takes weights; received "
                         f"{method!r}; methods: {', '.join(able)}")
    options = {"alpha": alpha, "rng": rng}
    if robust == "ransac":
        options.update(final_method=method, threshold=threshold)
    elif robust == "irls":
        options.update(method=method)
        if threshold is not None:
            raise ValueError("robust_threshold applies to robust='ransac'; IRLS scales its "
                             f"weights from the residuals; received {threshold!r}")
    rs = robust_solve(C, H, robust, **options)
    sol = rs.solution
    sol = replace(sol, tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
                  diagnostics={**sol.diagnostics, "robust": robust,
                               "inlier_mask": np.asarray(rs.inlier_mask),
                               "weights": np.asarray(rs.weights),
                               "robust_threshold": float(rs.threshold),
                               "robust_message": rs.message})
    return sol


def solve(C, H, method: str = "dqopt", alpha: float = 1.0, prior: Prior | None = None,
          rng: np.random.Generator | None = None, weights=None, *, tolerance_deg: float = 1.0,
          tolerance_m: float = 0.01, uncertainty: str = "sandwich",
          bootstrap_samples: int = 200, correlation_lag: int = 0, robust: str = "none",
          robust_threshold: float | None = None, pose_bias=None, pose_pairs=None,
          pose_error_basis=None, pose_simulation=None) -> Solution:
    """Estimate ``X = T_a_b`` from relative motions with ``C_i X = X H_i``.

    ``C``, ``H``: array-like ``(N, 4, 4)``, N >= 2. ``method``: a name from
    ``simcalib.solvers.available()``. ``alpha`` (1/m, in [ALPHA_MIN, ALPHA_MAX]): weight of
    the translation equations. ``prior``: optional :class:`Prior` (DQ methods). ``rng``:
    Generator for stochastic methods (default ``default_rng(0)``). ``weights``: optional
    per-motion weights ``(N,)`` (finite, >= 0, not all 0) of the cost; methods with
    ``SolverInfo.supports_weights`` only. ``tolerance_deg`` / ``tolerance_m``: 1-sigma
    above which a direction is "poorly determined" (``Solution.verdict``).
    ``uncertainty``: "sandwich" (default: linearised covariance, noise from the residuals)
    or "bootstrap" (``bootstrap_samples`` seeded resamplings of the motions, each solved by
    ``method``; the generator is a child of ``rng``, default ``default_rng(0)``; for
    comparison: it costs ``bootstrap_samples`` solves). The verdict comes from the
    information in both cases. ``correlation_lag``: the motions are in time order and
    share poses up to this lag (pairs ``(k, k + step)`` of one pose stream: ``step``); the
    uncertainty then corrects for the serial correlation of their noise (0: independent).
    ``pose_bias``: the known calibration uncertainty of the cameras, a
    :class:`simcalib.solvers.diagnostics.uncertainty.PoseBias` or ``(cov_a, cov_b)``
    (6x6 covariances of each camera's run-constant pose error, camera frame, rotvec rad and
    translation m; None for none): added to the covariance, std and verdict.
    ``pose_pairs``: ``(N, 2)`` datapoint indices (start, end) of each motion when the motions
    come from two pose streams (motion ``k`` = the poses of datapoints ``start_k`` ->
    ``end_k``), so motions sharing a datapoint share its pose noise: when the residuals
    pass the white pose-noise test, the covariance is simulated with that structure,
    including the estimator's bias (:mod:`simcalib.solvers.diagnostics.pose_noise`;
    ``Solution.uncertainty.method == "pose_simulation"``; not with a prior or ``robust``).
    ``pose_error_basis``: with ``pose_pairs``, the known systematic pose errors of the
    datapoints, ``(Ba, Bb)`` of shape ``(n_datapoints, 6, P)`` (each camera's pose error,
    rotvec rad and translation m right-multiplied in the camera frame, per unit of ``P``
    shared standard-normal parameters: a marker map's and a lens calibration's errors,
    :func:`simcalib.sources.vision.error_model.pose_error_basis`); the simulation then draws
    them with the white pose noise the residuals leave beyond them (whether or not the
    white-noise test
    passes; without a prior). ``pose_simulation``: ``Solution.uncertainty.simulation`` of
    another estimate of the same motions at the same alpha, reused instead of simulating
    again (a run simulates once for all its solvers).

    ``robust``: ``"none"`` (default), ``"ransac"`` (hypotheses from minimal sets of motions,
    consensus by the per-motion screw residual — threshold ``robust_threshold`` or
    automatic — then ``method`` on the inliers) or ``"irls"`` (iteratively re-weighted
    ``method`` with Cauchy weights): :mod:`simcalib.solvers.robust`. The returned solution
    is the final solve; ``diagnostics["inlier_mask"]`` (N,) and ``diagnostics["weights"]``
    (N,) say which motions it kept and how much each counted.

    ``runtime_s`` never includes compilation: the compiled kernel is loaded (or compiled,
    once per machine) before the timed region; that time is ``diagnostics["compile_s"]``.
    """
    info = registry.get(method)
    alpha = check_alpha(alpha)
    pose_bias = _check_pose_options(pose_bias, pose_pairs, pose_error_basis, pose_simulation,
                                    alpha, robust)
    tolerance_deg, tolerance_m, correlation_lag = _check_uncertainty_options(
        tolerance_deg, tolerance_m, uncertainty, bootstrap_samples, correlation_lag)
    if robust != "none":
        if correlation_lag:
            raise ValueError(f"correlation_lag applies to consecutive motions; robust="
                             f"{robust!r} keeps a subset of them; received correlation_lag="
                             f"{correlation_lag}")
        sol = _solve_robust(C, H, method, alpha, robust, robust_threshold, rng,
                            tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
                            weights=weights, prior=prior)
        return replace(sol, pose_bias=pose_bias, uncertainty_method=uncertainty,
                       bootstrap_rng=_bootstrap_rng(uncertainty, rng),
                       bootstrap_samples=int(bootstrap_samples))
    boot_rng = _bootstrap_rng(uncertainty, rng)
    prior, rng = _check_method_inputs(info, prior, weights, rng)
    problem, out, runtime, compile_s = _run_solver(info, C, H, alpha, prior, rng, weights)
    pose_pairs, pose_error_basis = _check_pose_structure(pose_pairs, pose_error_basis,
                                                         pose_simulation, problem.n, alpha)
    X, success, message, diag = _finish_output(out, method)
    diag["sign_flips"] = problem.sign_flips
    diag["compile_s"] = compile_s
    if np.isfinite(X).all():   # cost and objective: evaluated on first read
        cost = objective = PENDING
    else:
        cost = objective = math.inf
        success = False
    return Solution(X=X, cost=cost, objective=objective, method=method, alpha=alpha,
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


def _bootstrap_rng(uncertainty, rng) -> np.random.Generator | None:
    """The bootstrap's generator (a child of ``rng``, else ``default_rng(0)``), or None."""
    boot_rng = None
    if uncertainty == "bootstrap":
        boot_rng = np.random.default_rng(_check_rng(rng).bit_generator.seed_seq.spawn(1)[0]) \
            if rng is not None else np.random.default_rng(0)
    return boot_rng


def _run_solver(info, C, H, alpha, prior, rng, weights) -> tuple:
    """``(problem, solver output, runtime_s, compile_s)`` of the timed solve of ``(C, H)``."""
    compile_s = warm_up()
    t0 = time.perf_counter()
    problem = prepare_problem(C, H, alpha, weights)
    try:
        out = info.fn(problem, alpha, prior, rng)
    except Exception as exc:  # noqa: BLE001 - a solver failing on valid input is reported
        out = SolverOutput(X=np.full((4, 4), np.nan), success=False,
                           message=f"solver raised {type(exc).__name__}: {exc}")
    runtime = time.perf_counter() - t0
    return problem, out, runtime, compile_s


def _check_pose_structure(pose_pairs, pose_error_basis, pose_simulation, n: int,
                          alpha: float) -> tuple:
    """The checked ``(pose_pairs, pose_error_basis)`` for ``n`` motions."""
    if pose_pairs is None:   # _check_pose_options refused a basis or simulation without pairs
        return None, None
    from simcalib.solvers.diagnostics.pose_noise import check_pose_inputs
    pose_pairs, pose_error_basis, _ = check_pose_inputs(pose_pairs, pose_error_basis,
                                                        pose_simulation, n, alpha)
    return pose_pairs, pose_error_basis


