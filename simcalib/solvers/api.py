"""Public solver API: :func:`solve`, :func:`solve_batch`, :class:`Solution`,
:class:`BatchSolution`, :class:`Prior`, :func:`dq_cost`.

Convention (NOTES.md): ``C_i X = X H_i`` with ``X = T_a_b`` (pose of sensor b in sensor a),
``C_i`` the relative motions of a and ``H_i`` those of b.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from simcalib.geometry import check_transforms, dual_quat_from_transform
from simcalib.solvers import registry
from simcalib.solvers.problem import MotionProblem, SolverOutput

__all__ = ["Prior", "Solution", "BatchSolution", "solve", "solve_batch", "dq_cost",
           "check_alpha"]


# ------------------------------------------------------------------------------ prior
@dataclass(frozen=True)
class Prior:
    """Prior on ``X`` (paper eqs. 26-29): penalty ``a |vec(dq)|^2 + b |dq'|^2`` where
    ``dq + eps dq' = Q_prior^* Q_X`` is the deviation from the prior.

    ``X``: 4x4 rigid transform (the prior guess of ``T_a_b``); ``a`` (dimensionless) weights
    the rotation deviation, ``b`` (1/m^2 scale of ``dq'``, i.e. half the translation) the
    translation deviation. Both finite and >= 0, not both 0.
    """
    X: np.ndarray
    a: float = 1.0
    b: float = 1.0

    def __post_init__(self):
        try:
            X = np.array(self.X, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"Prior.X must be a 4x4 rigid transform; could not convert "
                            f"{type(self.X).__name__} to float64 ({exc})") from None
        if X.shape != (4, 4):
            raise ValueError(f"Prior.X must be one 4x4 rigid transform; received shape {X.shape}")
        check_transforms(X[None], "Prior.X")
        X.setflags(write=False)
        object.__setattr__(self, "X", X)
        for name in ("a", "b"):
            val = getattr(self, name)
            if isinstance(val, bool) or not isinstance(val, (int, float, np.integer, np.floating)):
                raise TypeError(f"Prior.{name} must be a real number; received "
                                f"{type(val).__name__} {val!r}")
            val = float(val)
            if not math.isfinite(val) or val < 0:
                raise ValueError(f"Prior.{name} must be finite and >= 0; received {val}")
            object.__setattr__(self, name, val)
        if self.a == 0 and self.b == 0:
            raise ValueError("Prior weights a and b are both 0; at least one must be > 0 "
                             "(omit the prior instead)")


def _check_prior(prior) -> Prior | None:
    if prior is None or isinstance(prior, Prior):
        return prior
    raise TypeError(f"prior must be a simcalib.Prior or None; received {type(prior).__name__}")


def check_alpha(alpha) -> float:
    """Validate the weighting factor alpha (1/m): a finite real number > 0."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.integer, np.floating)):
        if isinstance(alpha, np.ndarray) and alpha.ndim == 0:
            alpha = alpha.item()
        else:
            raise TypeError(f"alpha must be a real number; received {type(alpha).__name__} "
                            f"{alpha!r}")
    alpha = float(alpha)
    if not math.isfinite(alpha) or alpha <= 0:
        raise ValueError(f"alpha must be finite and > 0; received {alpha}")
    return alpha


def _check_rng(rng) -> np.random.Generator:
    if rng is None:
        return np.random.default_rng(0)
    if isinstance(rng, np.random.Generator):
        return rng
    raise TypeError(f"rng must be a numpy.random.Generator or None; received "
                    f"{type(rng).__name__}")


# ------------------------------------------------------------------------------- cost
def _as_problem(problem, alpha: float = 1.0) -> MotionProblem:
    if isinstance(problem, MotionProblem):
        return problem
    if isinstance(problem, tuple) and len(problem) == 2:
        return _fast_problem(*problem, alpha)
    raise TypeError(f"problem must be a MotionProblem or a (C, H) tuple; received "
                    f"{type(problem).__name__}")


def _as_dual_quat(X):
    if isinstance(X, tuple) and len(X) == 2:
        q = np.asarray(X[0], dtype=np.float64)
        qd = np.asarray(X[1], dtype=np.float64)
        if q.shape != (4,) or qd.shape != (4,):
            raise ValueError(f"(q, q') must be two 4-vectors; received shapes {q.shape}, {qd.shape}")
        return q, qd
    X = check_transforms(X, "X")
    if X.shape != (4, 4):
        raise ValueError(f"X must be one 4x4 transform; received shape {X.shape}")
    return dual_quat_from_transform(X)


def dq_cost(X, problem, alpha: float, prior: Prior | None = None) -> float:
    """Paper cost (8) ``sum_i |A_i q|^2 + alpha^2 |B_i q + A_i q'|^2`` at ``X``.

    ``X``: a 4x4 transform or a dual quaternion ``(q, q')`` (used as given, not
    normalised). ``problem``: a :class:`MotionProblem` or ``(C, H)``; the motions are
    sign-aligned per NOTES.md (scalar parts of q_C and q_H of equal sign).
    With ``prior`` the prior terms ``a |vec(dq)|^2 + b |dq'|^2`` are added (eq. 26).
    """
    from simcalib.geometry import quat_left_matrix, quat_right_matrix
    alpha = check_alpha(alpha)
    problem = _as_problem(problem, alpha)
    q, qd = _as_dual_quat(X)
    A = quat_left_matrix(problem.q_C) - quat_right_matrix(problem.q_H)
    B = quat_left_matrix(problem.q_C_dual) - quat_right_matrix(problem.q_H_dual)
    r1 = A @ q
    r2 = B @ q + A @ qd
    cost = float(np.sum(r1 * r1) + alpha**2 * np.sum(r2 * r2))
    prior = _check_prior(prior)
    if prior is not None:
        cost += _prior_penalty(q, qd, prior)
    return cost


def _prior_penalty(q, qd, prior: Prior) -> float:
    from simcalib.geometry import quat_conjugate, quat_multiply
    q_hat, q_hat_dual = dual_quat_from_transform(prior.X)
    dq = quat_multiply(quat_conjugate(q_hat), q)
    dqd = quat_multiply(quat_conjugate(q_hat_dual), q) + quat_multiply(quat_conjugate(q_hat), qd)
    return float(prior.a * np.sum(dq[:3] ** 2) + prior.b * np.sum(dqd**2))


# --------------------------------------------------------------------------- solution
@dataclass(frozen=True, eq=False)
class Solution:
    """Result of :func:`solve`.

    ``X``: estimate of ``T_a_b`` (4x4). ``cost``: paper cost (8) at ``X`` for ``alpha``
    (data term only, motions sign-aligned per NOTES.md); ``objective``: cost plus the prior
    terms (equal to ``cost`` without a prior). ``runtime_s``: time from the ``(N, 4, 4)``
    arrays to ``X`` (validation + conversion + solver). ``success``/``message``.

    Diagnostics, computed on first access:
    ``observability`` (:class:`simcalib.solvers.observability.Observability`: singular
    values, ``degenerate``, ``undetermined`` directions in words, camera-a frame);
    ``certificate`` (:class:`simcalib.solvers.observability.Certificate`, DQ methods only,
    else None). ``degenerate`` and ``undetermined`` are shortcuts; ``message`` combines
    everything. When ``degenerate`` is True, the components of ``X`` along the
    ``undetermined`` directions are not measurements (they come from the prior if one is
    given, else they are arbitrary).
    """
    X: np.ndarray
    cost: float
    objective: float
    method: str
    alpha: float
    runtime_s: float
    success: bool
    solver_message: str
    n_motions: int
    family: str = ""
    prior: Prior | None = None
    diagnostics: dict = field(default_factory=dict, repr=False)
    problem: MotionProblem | None = field(default=None, repr=False, compare=False)
    tolerance_deg: float = 1.0      # issue 9: verdict tolerances (1-sigma), see uncertainty.py
    tolerance_m: float = 0.01

    # ---- issue 9: uncertainty and the verdict that follows from it
    @cached_property
    def uncertainty(self):
        """:class:`simcalib.solvers.uncertainty.Uncertainty` of ``X`` (None if the solve
        failed): covariance of ``delta = (omega, v)`` (frame a), noise estimated from the
        residuals, verdict with ``tolerance_deg`` / ``tolerance_m``."""
        if not self.success or not np.isfinite(self.X).all():
            return None
        from simcalib.solvers.uncertainty import covariance
        try:
            return covariance(self.problem.C, self.problem.H, self.X, self.alpha, self.prior,
                              tolerance_deg=self.tolerance_deg, tolerance_m=self.tolerance_m)
        except ValueError:
            return None

    @property
    def covariance(self) -> np.ndarray:
        """6x6 covariance of (wx, wy, wz, vx, vy, vz) in rad and m (inf: undetermined)."""
        u = self.uncertainty
        return np.full((6, 6), np.inf) if u is None else u.covariance

    @property
    def std(self) -> np.ndarray:
        """1-sigma per axis: rotation (deg) about x, y, z and translation (m), frame a."""
        u = self.uncertainty
        return np.full(6, np.inf) if u is None else u.std

    @property
    def verdict(self) -> str:
        """"determined", "poorly determined", "undetermined" or "FAILED"."""
        u = self.uncertainty
        return "FAILED" if u is None else u.verdict

    def inside_region(self, X_candidate, level: float = 0.95) -> bool:
        """Whether ``X_candidate`` lies in the ``level`` confidence region of ``X``."""
        u = self.uncertainty
        if u is None:
            raise ValueError(f"{self.method} failed; there is no confidence region")
        return u.inside_region(X_candidate, level)

    @cached_property
    def observability(self):
        from simcalib.solvers.observability import analyse
        return analyse(self.problem, self.X, self.alpha, self.prior, self.cost)

    @cached_property
    def certificate(self):
        if self.family != "dq" or not self.success:
            return None
        from simcalib.solvers.observability import certify
        q, qd = dual_quat_from_transform(self.X)
        return certify(self.problem, self.alpha, self.prior, q, qd)

    @property
    def degenerate(self) -> bool:
        return self.observability.degenerate

    @property
    def undetermined(self) -> tuple:
        return self.observability.undetermined

    @property
    def certified(self) -> bool:
        return self.certificate is not None and self.certificate.certified

    @property
    def message(self) -> str:
        parts = [f"{self.method}: " + ("ok" if self.success else "FAILED")
                 + (f" ({self.solver_message})" if self.solver_message else "")]
        if self.certificate is not None:
            parts.append(self.certificate.summary())
        parts.append(self.observability.summary())
        return "; ".join(parts)

    def to_dict(self) -> dict:
        """JSON-ready summary (plain floats/lists/strings) for results files."""
        obs = self.observability
        cert = self.certificate
        return {
            "method": self.method, "alpha": self.alpha, "success": self.success,
            "X": np.asarray(self.X).tolist(), "cost": _num(self.cost),
            "objective": _num(self.objective), "runtime_s": self.runtime_s,
            "n_motions": self.n_motions, "message": self.message,
            "prior": None if self.prior is None else {
                "X": self.prior.X.tolist(), "a": self.prior.a, "b": self.prior.b},
            "degenerate": obs.degenerate,
            "undetermined": [{"kind": d.kind, "reason": d.reason, "dims": d.dims,
                              "description": d.description,
                              "rotation_axis_a": d.rotation_axis_a.tolist(),
                              "translation_dir_a": d.translation_dir_a.tolist(),
                              "std": _num(d.std), "determined_by_prior": d.determined_by_prior}
                             for d in obs.undetermined],
            "singular_values": obs.singular_values.tolist(),
            "residual_rms": _num(obs.residual_rms),
            "certificate": None if cert is None else {
                "certified": cert.certified, "route": cert.route, "mu": cert.mu,
                "relative_gap": _num(cert.relative_gap), "kkt_residual": _num(cert.kkt_residual),
                "summary": cert.summary()},
            "sign_flips": int(self.diagnostics.get("sign_flips", 0)),
            "uncertainty": _uncertainty_dict(self.uncertainty),
        }

    def __str__(self) -> str:
        from simcalib.geometry import rotvec_from_matrix
        rv = np.degrees(rotvec_from_matrix(self.X[:3, :3]))
        return (f"Solution({self.method}, alpha={self.alpha:g}, N={self.n_motions}): "
                f"t = {np.round(self.X[:3, 3], 6).tolist()} m, rotvec = "
                f"{np.round(rv, 4).tolist()} deg, cost = {self.cost:.6g}, "
                f"{self.runtime_s * 1e6:.0f} us\n{self.message}")


@dataclass(frozen=True, eq=False)
class BatchSolution:
    """Result of :func:`solve_batch`: ``X`` (B, 4, 4), ``cost`` (B,), ``objective`` (B,),
    ``success`` (B,), ``alpha`` (B,), ``method``, ``runtime_s`` (whole batch),
    ``diagnostics`` (dict of (B,) arrays, method-specific)."""
    X: np.ndarray
    cost: np.ndarray
    objective: np.ndarray
    success: np.ndarray
    alpha: np.ndarray
    method: str
    runtime_s: float
    prior: Prior | None = None
    diagnostics: dict = field(default_factory=dict)

    def __len__(self):
        return self.X.shape[0]


def _uncertainty_dict(u) -> dict | None:
    if u is None:
        return None
    return {"verdict": u.verdict, "degenerate": u.degenerate,
            "std_deg": [_num(x) for x in u.std[:3]], "std_m": [_num(x) for x in u.std[3:]],
            "covariance": [[_num(x) for x in row] for row in u.covariance],
            "noise": {"sigma_r_rad": u.noise.sigma_r_rad, "sigma_t_m": u.noise.sigma_t_m,
                      "estimated": u.noise.estimated},
            "tolerance_deg": u.tolerance_deg, "tolerance_m": u.tolerance_m,
            "directions": [{"reason": d.reason, "kind": d.kind, "description": d.description,
                            "rotation_axis_a": d.rotation_axis_a.tolist(),
                            "translation_dir_a": d.translation_dir_a.tolist(),
                            "std_deg": _num(d.std_deg), "std_m": _num(d.std_m),
                            "determined_by_prior": d.determined_by_prior}
                           for d in u.directions]}


def _num(x):
    """float, with non-finite values as None (JSON has no inf/nan)."""
    x = float(x)
    return x if math.isfinite(x) else None


# ------------------------------------------------------------------------------ solve
def _finish_output(out, method: str):
    """Normalise a solver function's return value to (X, success, message, diagnostics)."""
    if isinstance(out, SolverOutput):
        X, success, message, diag = out.X, bool(out.success), out.message, dict(out.diagnostics)
    else:
        X, success, message, diag = out, True, "", {}
    X = np.asarray(X, dtype=np.float64)
    if X.shape != (4, 4) or not np.isfinite(X).all():
        return (np.full((4, 4), np.nan), False,
                f"solver {method!r} returned no valid transform ({message or 'non-finite'})", diag)
    from simcalib.solvers.dq import is_rigid
    if not is_rigid(X):
        try:
            check_transforms(X, "X")
            why = "not rigid"
        except ValueError as exc:
            why = str(exc)
        return X, False, f"solver {method!r} returned a non-rigid X ({why})", diag
    return X, success, message, diag


def solve(C, H, method: str = "dqopt", alpha: float = 1.0, prior: Prior | None = None,
          rng: np.random.Generator | None = None, *, tolerance_deg: float = 1.0,
          tolerance_m: float = 0.01) -> Solution:
    """Estimate ``X = T_a_b`` from relative motions with ``C_i X = X H_i``.

    ``C``, ``H``: array-like ``(N, 4, 4)``, N >= 2. ``method``: a name from
    ``simcalib.solvers.available()``. ``alpha`` (1/m, > 0): weight of the translation
    equations. ``prior``: optional :class:`Prior` (DQ methods). ``rng``: Generator for
    stochastic methods (default ``default_rng(0)``). ``tolerance_deg`` / ``tolerance_m``:
    1-sigma above which a direction is "poorly determined" (``Solution.verdict``).
    """
    info = registry.get(method)
    alpha = check_alpha(alpha)
    from simcalib.solvers.uncertainty import check_tolerances
    tolerance_deg, tolerance_m = check_tolerances(tolerance_deg, tolerance_m)
    prior = _check_prior(prior)
    if prior is not None and not info.supports_prior:
        with_prior = [i.name for i in registry.infos() if i.supports_prior]
        raise ValueError(f"method {method!r} does not support a prior; methods with a "
                         f"prior: {', '.join(with_prior)}")
    if rng is not None or info.stochastic:
        rng = _check_rng(rng)   # stochastic methods get default_rng(0) when none is given
    t0 = time.perf_counter()
    problem, flips = _fast_problem(C, H, alpha, return_flips=True)
    try:
        out = info.fn(problem, alpha, prior, rng)
    except Exception as exc:  # noqa: BLE001 - a solver failing on valid input is reported
        out = SolverOutput(X=np.full((4, 4), np.nan), success=False,
                           message=f"solver raised {type(exc).__name__}: {exc}")
    runtime = time.perf_counter() - t0
    X, success, message, diag = _finish_output(out, method)
    diag["sign_flips"] = flips
    if np.isfinite(X).all():
        from simcalib.solvers.dq import data_cost, dual_quat_fast
        q, qd = dual_quat_fast(X)
        cost = data_cost(problem, q, qd, alpha)
        objective = cost + (_prior_penalty(q, qd, prior) if prior is not None else 0.0)
    else:
        cost = objective = math.inf
    return Solution(X=X, cost=cost, objective=objective, method=method, alpha=alpha,
                    runtime_s=runtime, success=success, solver_message=message,
                    n_motions=problem.n, family=info.family, prior=prior,
                    diagnostics=diag, problem=problem, tolerance_deg=tolerance_deg,
                    tolerance_m=tolerance_m)


def _fast_problem(C, H, alpha: float = 1.0, return_flips: bool = False):
    """build_problem (compiled path) + sign re-alignment of near-180-degree motion pairs
    (see simcalib.solvers.dq.fast_build_problem)."""
    from simcalib.solvers.dq import fast_build_problem
    return fast_build_problem(C, H, alpha, return_flips)


def solve_batch(C, H, method: str = "dqopt", alpha=1.0, prior: Prior | None = None,
                rng: np.random.Generator | None = None) -> BatchSolution:
    """Solve ``B`` problems at once: ``C``, ``H`` of shape ``(B, N, 4, 4)``; ``alpha`` a
    scalar or ``(B,)``; one optional ``prior`` for all. Methods with a registered batch
    function run vectorised (DQ methods: compiled, parallel over problems); others loop over
    the method's solver function. ``X[b]`` equals ``solve(C[b], H[b], ...).X`` (to ~1e-12).
    """
    info = registry.get(method)
    prior = _check_prior(prior)
    if prior is not None and not info.supports_prior:
        with_prior = [i.name for i in registry.infos() if i.supports_prior]
        raise ValueError(f"method {method!r} does not support a prior; methods with a "
                         f"prior: {', '.join(with_prior)}")
    rng = _check_rng(rng)
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
    alphas = _check_alphas(alpha, B)
    diagnostics = {}
    t0 = time.perf_counter()
    if info.batch_fn is not None and info.extra.get("batch_validates", False):
        out = info.batch_fn(C, H, alphas, prior)
        bad = out["bad"]
        if (bad >= 0).any():
            b = int(np.argmax(bad >= 0))
            check_transforms(C[b], f"C[{b}]")
            check_transforms(H[b], f"H[{b}]")
            raise ValueError(f"problem {b}, motion {int(bad[b])}: C or H is not a rigid "
                             "transform")
    else:
        check_transforms(C, "C")
        check_transforms(H, "H")
        if info.batch_fn is not None:
            out = info.batch_fn(C, H, alphas, prior)
            if isinstance(out, np.ndarray):
                out = {"X": out}
        else:
            from simcalib.solvers.dq import data_cost, dual_quat_fast
            X = np.full((B, 4, 4), np.nan)
            ok = np.zeros(B, dtype=bool)
            cost = np.full(B, np.inf)
            flips = np.zeros(B, dtype=np.int64)
            for b in range(B):
                problem, flips[b] = _fast_problem(C[b], H[b], float(alphas[b]), True)
                try:
                    res = info.fn(problem, float(alphas[b]), prior, rng)
                except Exception:  # noqa: BLE001 - reported as a failed problem
                    continue
                X[b], ok[b], _, _ = _finish_output(res, method)
                if np.isfinite(X[b]).all():
                    cost[b] = data_cost(problem, *dual_quat_fast(X[b]), float(alphas[b]))
            out = {"X": X, "success": ok, "cost": cost, "sign_flips": flips}
    runtime = time.perf_counter() - t0
    X = np.asarray(out["X"], dtype=np.float64)
    success = np.asarray(out.get("success", np.isfinite(X).all(axis=(-2, -1))), dtype=bool)
    cost = out.get("cost")
    if cost is None:
        from simcalib.solvers.dq import batch_data_cost
        cost = batch_data_cost(C, H, X, alphas)
    cost = np.where(success, cost, np.inf)
    objective = cost.copy()
    if prior is not None:
        objective = objective + _prior_penalty_batch(X, prior)
    for k, v in out.items():
        if k not in ("X", "cost", "success", "bad"):
            diagnostics[k] = v
    return BatchSolution(X=X, cost=cost, objective=objective, success=success, alpha=alphas,
                         method=method, runtime_s=runtime, prior=prior,
                         diagnostics=diagnostics)


def _as_float_array(a, name):
    try:
        return np.ascontiguousarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of 4x4 rigid transforms; could not convert "
                        f"{type(a).__name__} to float64 ({exc})") from None


def _prior_penalty_batch(X, prior: Prior) -> np.ndarray:
    from simcalib.geometry import quat_conjugate, quat_multiply
    q, qd = dual_quat_from_transform(X)
    q_hat, q_hat_dual = dual_quat_from_transform(prior.X)
    dq = quat_multiply(quat_conjugate(q_hat), q)
    dqd = quat_multiply(quat_conjugate(q_hat_dual), q) + quat_multiply(quat_conjugate(q_hat), qd)
    return prior.a * np.sum(dq[..., :3] ** 2, axis=-1) + prior.b * np.sum(dqd**2, axis=-1)


def _check_alphas(alpha, B: int) -> np.ndarray:
    try:
        arr = np.asarray(alpha, dtype=np.float64) if not isinstance(alpha, bool) else None
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] != B):
        raise ValueError(f"alpha must be a scalar or an array of shape ({B},); received "
                         f"{alpha!r}")
    bad = ~np.isfinite(arr) | (arr <= 0)
    if bad.any():
        raise ValueError(f"alpha must be finite and > 0; received {arr[bad].ravel()[0]}")
    return np.broadcast_to(arr, (B,)).astype(np.float64)
