"""``solve_batch``: ``B`` problems at once (one compiled kernel for the DQ methods, else
problem by problem through the method's solver function)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from simcalib.geometry import as_real_array, check_transforms, dual_quat_from_transform
from simcalib.solvers import registry
from simcalib.solvers.kernels.batch import warm_up
from simcalib.solvers.kernels.gram import prior_penalty
from simcalib.solvers.problem import (ALPHA_MAX, ALPHA_MIN, alpha_range_error, batch_cost,
    check_weights, prepare_problem, problem_cost)
from simcalib.solvers.validation import (
    Prior,
    _check_prior,
    _check_prior_supported,
    _check_rng,
    _check_weights_supported,
    _finish_output,
)

def solve_batch(C, H, method: str = "dqopt", alpha=1.0, prior: Prior | None = None,
                rng: np.random.Generator | None = None, weights=None, *,
                tolerance_deg: float = 1.0, tolerance_m: float = 0.01) -> BatchSolution:
    """Solve ``B`` problems at once: ``C``, ``H`` of shape ``(B, N, 4, 4)``; ``alpha`` a
    scalar or ``(B,)``; one optional ``prior`` for all; ``weights`` optional ``(B, N)``
    per-motion weights. Methods with a registered batch function run vectorised (DQ
    methods: one compiled kernel, parallel over problems); others loop over the method's
    solver function. ``X[b]`` equals ``solve(C[b], H[b], ...).X``. A problem whose solve
    fails or gives a non-finite X has ``success[b] = False`` (and
    ``diagnostics["failure_reason"][b]``).
    """
    info = registry.get(method)
    from simcalib.solvers.diagnostics.uncertainty import check_tolerances
    tolerance_deg, tolerance_m = check_tolerances(tolerance_deg, tolerance_m)
    prior = _check_prior(prior)
    _check_prior_supported(info, prior)
    _check_weights_supported(info, weights)
    if rng is not None:   # None: default_rng(0), made only for the methods that draw
        rng = _check_rng(rng)
    C, H = _checked_batch_arrays(C, H)
    B, N = C.shape[:2]
    alphas = _check_alphas(alpha, B)
    w = check_weights(weights, (B, N))
    compile_s = warm_up(parallel=B > 1)
    t0 = time.perf_counter()
    out = _run_method(info, C, H, alphas, prior, rng, w)
    runtime = time.perf_counter() - t0
    X = np.asarray(out["X"], dtype=np.float64)
    success, reason = _success_and_reasons(out, X, B)
    cost = out.get("cost")
    if cost is None:
        from simcalib.solvers.problem import prepare_batch
        cost = batch_cost(prepare_batch(C, H, alphas, w)[0], X, alphas, w)
    cost = np.where(success, cost, np.inf)
    X = np.where(success[:, None, None], X, np.nan) if not success.all() else X
    objective = cost.copy()
    if prior is not None:
        objective = objective + _prior_penalty_batch(X, prior)
    diagnostics = {k: v for k, v in out.items()
                   if k not in ("X", "cost", "success", "bad", "failure_reason")}
    diagnostics["failure_reason"] = reason
    diagnostics["compile_s"] = compile_s
    return BatchSolution(X=X, cost=cost, objective=objective, success=success, alpha=alphas,
                         method=method, runtime_s=runtime, prior=prior,
                         diagnostics=diagnostics, C=C, H=H, weights=w,
                         tolerance_deg=tolerance_deg, tolerance_m=tolerance_m)


def _success_and_reasons(out: dict, X: np.ndarray, B: int) -> tuple:
    """``success`` (B,): the method's and a finite X; the failure reasons (B, object; ""
    for a success): the method's, or "non-finite X" where it gave none. (The object arrays
    are compared only when a problem failed: ~0.1 ms per call at B = 1000.)"""
    finite = np.isfinite(X).all(axis=(-2, -1))
    success = finite if "success" not in out else np.asarray(out["success"], dtype=bool) & finite
    if success.all():
        return success, np.full(B, "", dtype=object)
    reason = out.get("failure_reason")
    reason = np.full(B, "", dtype=object) if reason is None else np.asarray(reason, dtype=object)
    reason = np.where(~finite & (reason == ""), "non-finite X", reason)
    return success, np.where(success, "", reason)


def _checked_batch_arrays(C, H) -> tuple:
    """``C``, ``H`` as C-contiguous float64 ``(B, N, 4, 4)`` of one shape, ``B >= 1``,
    ``N >= 2`` (ValueError saying what was received)."""
    C = _as_float_array(C, "C")
    H = _as_float_array(H, "H")
    for arr, name in ((C, "C"), (H, "H")):
        if arr.ndim != 4 or arr.shape[-2:] != (4, 4):
            raise ValueError(f"{name} must have shape (B, N, 4, 4); received shape {arr.shape}")
    if H.shape != C.shape:
        raise ValueError(f"C and H must have the same shape (B, N, 4, 4); received "
                         f"{C.shape} and {H.shape}")
    B, N = C.shape[:2]
    if B < 1:
        raise ValueError(f"C must hold at least one problem; received shape {C.shape}")
    if N < 2:
        raise ValueError(f"each problem needs at least 2 motions; received N = {N}")
    return C, H


def _run_method(info, C, H, alphas, prior, rng, w) -> dict:
    """The method's batch output: its batch function (a validating one checks rigidity in
    the kernel; the first bad problem is then checked again for the error's words), else
    the checked transforms problem by problem through its solver function."""
    if info.batch_fn is not None and info.extra.get("batch_validates", False):
        out = info.batch_fn(C, H, alphas, prior, w)
        bad = out["bad"]
        if (bad >= 0).any():
            b = int(np.argmax(bad >= 0))
            check_transforms(C[b], f"C[{b}]")
            check_transforms(H[b], f"H[{b}]")
            raise ValueError(f"problem {b}, motion {int(bad[b])}: C or H is not a rigid "
                             "transform")
        return out
    check_transforms(C, "C")
    check_transforms(H, "H")
    if info.batch_fn is None:
        return _loop(info, C, H, alphas, prior, _check_rng(rng), w)
    out = info.batch_fn(C, H, alphas, prior)
    return {"X": out} if isinstance(out, np.ndarray) else out


def _loop(info, C, H, alphas, prior, rng, w) -> dict:
    """Problem by problem through the method's solver function."""
    B = C.shape[0]
    X = np.full((B, 4, 4), np.nan)
    ok = np.zeros(B, dtype=bool)
    cost = np.full(B, np.inf)
    flips = np.zeros(B, dtype=np.int64)
    reason = np.full(B, "", dtype=object)
    for b in range(B):
        problem = prepare_problem(C[b], H[b], float(alphas[b]), None if w is None else w[b])
        flips[b] = problem.sign_flips
        try:
            res = info.fn(problem, float(alphas[b]), prior, rng)
        except Exception as exc:  # noqa: BLE001 - reported as a failed problem
            reason[b] = f"solver raised {type(exc).__name__}: {exc}"
            continue
        X[b], ok[b], msg, _ = _finish_output(res, info.name)
        if not ok[b]:
            reason[b] = msg or "failed"
        if np.isfinite(X[b]).all():
            cost[b] = problem_cost(problem, *dual_quat_from_transform(X[b]), float(alphas[b]))
    return {"X": X, "success": ok, "cost": cost, "sign_flips": flips, "failure_reason": reason}


def _as_float_array(a, name):
    return np.ascontiguousarray(as_real_array(a, name, "an array of 4x4 rigid transforms"))


def _prior_penalty_batch(X, prior: Prior) -> np.ndarray:
    finite = np.isfinite(X).all(axis=(-2, -1))
    q, qd = dual_quat_from_transform(np.where(finite[:, None, None], X, np.eye(4)))
    return np.where(finite, prior_penalty(q, qd, prior), np.inf)


def _check_alphas(alpha, B: int) -> np.ndarray:
    """alpha as (B,): a real scalar or (B,) array, every value in [ALPHA_MIN, ALPHA_MAX]."""
    if type(alpha) is float and ALPHA_MIN <= alpha <= ALPHA_MAX:   # the common call
        return np.full(B, alpha)
    raw = None if isinstance(alpha, (bool, str, bytes)) else np.asarray(alpha)
    if raw is None or raw.dtype.kind not in "iuf":
        kind = "complex" if raw is not None and raw.dtype.kind == "c" else type(alpha).__name__
        raise TypeError(f"alpha must be a real number or a real array of shape ({B},); "
                        f"received {kind} {alpha!r}")
    if raw.ndim > 1 or (raw.ndim == 1 and raw.shape[0] != B):
        raise ValueError(f"alpha must be a scalar or an array of shape ({B},); received "
                         f"shape {raw.shape}")
    arr = raw.astype(np.float64)
    bad = ~np.isfinite(arr) | (arr <= 0)
    if bad.any():
        raise ValueError(f"alpha must be finite and > 0; received {arr[bad].ravel()[0]}")
    out_of = (arr < ALPHA_MIN) | (arr > ALPHA_MAX)
    if out_of.any():
        raise ValueError(alpha_range_error(arr[out_of].ravel()[0]))
    return np.broadcast_to(arr, (B,)).astype(np.float64)


@dataclass(frozen=True, eq=False)
class BatchSolution:
    """Result of :func:`solve_batch`: ``X`` (B, 4, 4), ``cost`` (B,), ``objective`` (B,),
    ``success`` (B,), ``alpha`` (B,), ``method``, ``runtime_s`` (whole batch),
    ``diagnostics`` (dict of (B,) arrays, method-specific).

    Per-problem uncertainty (computed on first access): ``uncertainty`` (tuple of
    :class:`~simcalib.solvers.diagnostics.uncertainty.Uncertainty`, None for a failed
    problem), ``covariance`` (B, 6, 6; NaN for a failed problem, inf on undetermined
    axes), ``std`` (B, 6; deg, m), ``degenerate`` (B,; True for a failed problem),
    ``verdict`` (B strings)."""
    X: np.ndarray
    cost: np.ndarray
    objective: np.ndarray
    success: np.ndarray
    alpha: np.ndarray
    method: str
    runtime_s: float
    prior: Prior | None = None
    diagnostics: dict = field(default_factory=dict)
    C: np.ndarray | None = field(default=None, repr=False)
    H: np.ndarray | None = field(default=None, repr=False)
    weights: np.ndarray | None = field(default=None, repr=False)
    tolerance_deg: float = 1.0
    tolerance_m: float = 0.01

    def __len__(self):
        return self.X.shape[0]

    @cached_property
    def uncertainty(self) -> tuple:
        if self.C is None:
            raise ValueError("this BatchSolution holds no motions (built by hand); use "
                             "simcalib.solve_batch")
        from simcalib.solvers.diagnostics.uncertainty import covariance_batch
        X = np.where(self.success[:, None, None], self.X, np.nan)
        return covariance_batch(self.C, self.H, X, self.alpha, self.prior,
                                tolerance_deg=self.tolerance_deg,
                                tolerance_m=self.tolerance_m, weights=self.weights)

    @property
    def covariance(self) -> np.ndarray:
        return np.stack([np.full((6, 6), np.nan) if u is None else u.covariance
                         for u in self.uncertainty])

    @property
    def std(self) -> np.ndarray:
        return np.stack([np.full(6, np.nan) if u is None else u.std for u in self.uncertainty])

    @property
    def degenerate(self) -> np.ndarray:
        return np.array([True if u is None else u.degenerate for u in self.uncertainty])

    @property
    def verdict(self) -> tuple:
        return tuple("FAILED" if u is None else u.verdict for u in self.uncertainty)
