"""Public solver API: :func:`solve`, :func:`solve_batch`, :class:`Solution`,
:class:`BatchSolution`, :class:`Prior`, :func:`dq_cost`.

Convention (docs/conventions.md): ``C_i X = X H_i`` with ``X = T_a_b`` (pose of sensor b in sensor a),
``C_i`` the relative motions of a and ``H_i`` those of b.

The top of the solver folder's layers (see :mod:`simcalib.solvers`): :func:`solve` is
:func:`simcalib.solvers.single.solve_single` plus outlier handling
(:mod:`simcalib.solvers.robust`, which itself solves through ``solve_single``).

Options of :func:`solve` beyond the method and alpha:

* ``prior``: a :class:`Prior` (DQ methods). ``rng``: Generator for stochastic methods
  (default ``default_rng(0)``). ``weights``: per-motion weights ``(N,)`` (finite, >= 0,
  not all 0) of the cost; methods with ``SolverInfo.supports_weights`` only.
* ``tolerance_deg`` / ``tolerance_m``: 1-sigma above which a direction is "poorly
  determined" (``Solution.verdict``).
* ``uncertainty``: "sandwich" (default: linearised covariance, noise from the residuals) or
  "bootstrap" (``bootstrap_samples`` seeded resamplings of the motions, each solved by
  ``method``; the generator is a child of ``rng``, default ``default_rng(0)``; for
  comparison: it costs ``bootstrap_samples`` solves). The verdict comes from the
  information in both cases.
* ``correlation_lag``: the motions are in time order and share poses up to this lag (pairs
  ``(k, k + step)`` of one pose stream: ``step``); the uncertainty then corrects for the
  serial correlation of their noise (0: independent).
* ``pose_bias``: the known calibration uncertainty of the cameras, a
  :class:`simcalib.solvers.diagnostics.uncertainty.PoseBias` or ``(cov_a, cov_b)`` (6x6
  covariances of each camera's run-constant pose error, camera frame, rotvec rad and
  translation m; None for none): added to the covariance, std and verdict.
* ``pose_pairs``: ``(N, 2)`` datapoint indices (start, end) of each motion when the motions
  come from two pose streams (motion ``k`` = the poses of datapoints ``start_k`` ->
  ``end_k``), so motions sharing a datapoint share its pose noise: when the residuals pass
  the white pose-noise test, the covariance is simulated with that structure, including
  the estimator's bias (:mod:`simcalib.solvers.diagnostics.pose_noise`;
  ``Solution.uncertainty.method == "pose_simulation"``; not with a prior or ``robust``).
* ``pose_error_basis``: with ``pose_pairs``, the known systematic pose errors of the
  datapoints, ``(Ba, Bb)`` of shape ``(n_datapoints, 6, P)`` (each camera's pose error,
  rotvec rad and translation m right-multiplied in the camera frame, per unit of ``P``
  shared standard-normal parameters: a marker map's and a lens calibration's errors,
  :func:`simcalib.sources.vision.error_model.pose_error_basis`); the simulation then draws them
  with the white pose noise the residuals leave beyond them (whether or not the
  white-noise test passes; without a prior).
* ``pose_simulation``: ``Solution.uncertainty.simulation`` of another estimate of the same
  motions at the same alpha, reused instead of simulating again (a run simulates once for
  all its solvers).
* ``robust``: ``"none"`` (default), ``"ransac"`` (hypotheses from minimal sets of motions,
  consensus by the per-motion screw residual — threshold ``robust_threshold`` or automatic
  — then ``method`` on the inliers) or ``"irls"`` (iteratively re-weighted ``method`` with
  Cauchy weights): :mod:`simcalib.solvers.robust`. The returned solution is the final
  solve; ``diagnostics["inlier_mask"]`` (N,) and ``diagnostics["weights"]`` (N,) say which
  motions it kept and how much each counted.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from simcalib.errors import unknown_choice
from simcalib.solvers import registry
from simcalib.solvers.robust import ROBUST_METHODS, robust_solve
from simcalib.solvers.single import bootstrap_rng, check_options, solve_checked
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
    the translation equations. The other options (prior, rng, per-motion weights, the
    verdict's tolerances, the uncertainty's method and pose structure, ``robust``) are
    described in this module's docstring (:mod:`simcalib.solvers.api`).

    ``runtime_s`` never includes compilation: the compiled kernel is loaded (or compiled,
    once per machine) before the timed region; that time is ``diagnostics["compile_s"]``.
    """
    info, alpha, tolerance_deg, tolerance_m, correlation_lag, pose_bias = check_options(
        method, alpha, tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
        uncertainty=uncertainty, bootstrap_samples=bootstrap_samples,
        correlation_lag=correlation_lag, pose_bias=pose_bias, pose_pairs=pose_pairs,
        pose_error_basis=pose_error_basis, pose_simulation=pose_simulation, robust=robust)
    if robust != "none":
        if correlation_lag:
            raise ValueError(f"correlation_lag applies to consecutive motions; robust="
                             f"{robust!r} keeps a subset of them; received correlation_lag="
                             f"{correlation_lag}")
        sol = _solve_robust(C, H, method, alpha, robust, robust_threshold, rng,
                            tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
                            weights=weights, prior=prior)
        return replace(sol, pose_bias=pose_bias, uncertainty_method=uncertainty,
                       bootstrap_rng=bootstrap_rng(uncertainty, rng),
                       bootstrap_samples=int(bootstrap_samples))
    return solve_checked(info, C, H, alpha, prior, rng, weights, tolerance_deg=tolerance_deg,
                         tolerance_m=tolerance_m, uncertainty=uncertainty,
                         bootstrap_samples=bootstrap_samples, correlation_lag=correlation_lag,
                         pose_bias=pose_bias, pose_pairs=pose_pairs,
                         pose_error_basis=pose_error_basis, pose_simulation=pose_simulation)
