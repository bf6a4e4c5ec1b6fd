"""Public solver API: :func:`solve`, :func:`solve_batch`, :class:`Solution`,
:class:`BatchSolution`, :class:`Prior`, :func:`dq_cost`.

Convention (docs/conventions.md): ``C_i X = X H_i`` with ``X = T_a_b`` (pose of sensor b in sensor a),
``C_i`` the relative motions of a and ``H_i`` those of b.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from simcalib.geometry import ORTHONORMAL_TOL, as_real_array, check_transforms, \
    dual_quat_from_transform
from simcalib.solvers import registry
from simcalib.solvers.kernels.batch import warm_up
from simcalib.solvers.kernels.gram import prior_penalty
from simcalib.solvers.problem import ALPHA_MAX, ALPHA_MIN, MotionProblem, SolverOutput, \
    alpha_range_error, batch_cost, check_weights, prepare_problem, problem_cost

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
    """Validate the weighting factor alpha (1/m): a real number in [ALPHA_MIN, ALPHA_MAX]."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.integer, np.floating)):
        if isinstance(alpha, np.ndarray) and alpha.ndim == 0:
            alpha = alpha.item()
        else:
            raise TypeError(f"alpha must be a real number; received {type(alpha).__name__} "
                            f"{alpha!r}")
    if isinstance(alpha, (complex, np.complexfloating)):
        raise TypeError(f"alpha must be a real number; received complex {alpha!r}")
    alpha = float(alpha)
    if not math.isfinite(alpha) or alpha <= 0:
        raise ValueError(f"alpha must be finite and > 0; received {alpha}")
    if not ALPHA_MIN <= alpha <= ALPHA_MAX:
        raise ValueError(alpha_range_error(alpha))
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
        return prepare_problem(*problem, alpha)
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
    sign-aligned by the one alignment rule of the solvers (docs/solvers.md).
    With ``prior`` the prior terms ``a |vec(dq)|^2 + b |dq'|^2`` are added (eq. 26).
    """
    alpha = check_alpha(alpha)
    problem = _as_problem(problem, alpha)
    q, qd = _as_dual_quat(X)
    cost = problem_cost(problem, q, qd, alpha)
    prior = _check_prior(prior)
    if prior is not None:
        cost += prior_penalty(q, qd, prior)
    return cost


# --------------------------------------------------------------------------- solution
class _Pending:
    """Marks a :class:`Solution` field whose value is computed on first read."""
    __slots__ = ()

    def __repr__(self) -> str:
        return "<pending>"

    def __reduce__(self):
        return "PENDING"


#: the value :func:`solve` gives ``cost`` and ``objective``: computed on first read
PENDING = _Pending()


class _LazyField:
    """Data descriptor for a :class:`Solution` field that may be given as :data:`PENDING`:
    the value is kept in the instance's ``__dict__`` under the field's own name (so pickles
    and ``dataclasses.replace`` see a plain field) and a pending one is computed by
    ``Solution._resolve`` on first read, once. No default (AttributeError on the class)."""

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:
            raise AttributeError(self.name)   # dataclasses: the field has no default
        val = obj.__dict__[self.name]
        if val is PENDING:
            obj._resolve()
            val = obj.__dict__[self.name]
        return val

    def __set__(self, obj, value):   # the dataclass __init__ (object.__setattr__)
        obj.__dict__[self.name] = value


@dataclass(frozen=True, eq=False)
class Solution:
    """Result of :func:`solve`.

    ``X``: estimate of ``T_a_b`` (4x4). ``cost``: paper cost (8) at ``X`` for ``alpha``
    (data term only, motions sign-aligned as in docs/solvers.md); ``objective``: cost plus the prior
    terms (equal to ``cost`` without a prior). ``runtime_s``: time from the ``(N, 4, 4)``
    arrays to ``X`` (validation + conversion + solver). ``success``/``message``.

    ``cost`` and ``objective`` are evaluated on first read (:func:`solve` passes
    :data:`PENDING`; the numbers are those an eager evaluation gives, from ``problem``).
    Diagnostics, computed on first access (simcalib.solvers.diagnostics):
    ``uncertainty`` (covariance of the error, the verdict), ``certificate`` (DQ methods
    only, else None), ``observability`` (motion geometry, descriptive). ``degenerate``,
    ``undetermined``, ``verdict``, ``covariance``, ``std`` follow from ``uncertainty``
    (issue 9); ``message`` combines everything. When ``degenerate`` is True, the components
    of ``X`` along the ``undetermined`` directions are not measurements (from the prior if
    ``determined_by_prior``, else fitted noise or arbitrary).
    """
    X: np.ndarray
    cost: float = _LazyField()
    objective: float = _LazyField()
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
    uncertainty_method: str = "sandwich"   # or "bootstrap" (solve(uncertainty=...))
    bootstrap_rng: np.random.Generator | None = field(default=None, repr=False, compare=False)
    bootstrap_samples: int = 200
    correlation_lag: int = 0        # motions share poses up to this lag (pairs k, k+step)
    pose_bias: object = field(default=None, repr=False, compare=False)  # uncertainty.PoseBias
    pose_pairs: np.ndarray | None = field(default=None, repr=False, compare=False)  # (N, 2)
    pose_error_basis: tuple | None = field(default=None, repr=False, compare=False)  # (Ba, Bb)
    pose_simulation: object = field(default=None, repr=False, compare=False)  # SimulatedError

    def _resolve(self) -> None:
        """Evaluate the pending ``cost`` and ``objective`` (cost (8) at ``X`` on the aligned
        ``problem``, plus the prior's terms): what :func:`solve` used to compute eagerly."""
        d = self.__dict__
        if d["cost"] is PENDING or d["objective"] is PENDING:
            cost, objective = _cost_and_objective(self.problem, self.X, self.alpha, self.prior)
            if d["cost"] is PENDING:
                d["cost"] = cost
            if d["objective"] is PENDING:
                d["objective"] = objective

    def __getstate__(self):
        self._resolve()   # a pickle holds numbers, never the marker
        return self.__dict__

    # ---- issue 9: uncertainty and the verdict that follows from it
    @cached_property
    def uncertainty(self):
        """:class:`simcalib.solvers.diagnostics.uncertainty.Uncertainty` of ``X`` (None if the solve
        failed): covariance of ``delta = (omega, v)`` (frame a), noise estimated from the
        residuals, verdict with ``tolerance_deg`` / ``tolerance_m``."""
        if not self.success or not np.isfinite(self.X).all():
            return None
        from simcalib.solvers.diagnostics.uncertainty import covariance
        try:
            u = covariance(self.problem.C, self.problem.H, self.X, self.alpha, self.prior,
                           weights=self.problem.weights, tolerance_deg=self.tolerance_deg,
                           tolerance_m=self.tolerance_m, correlation_lag=self.correlation_lag,
                           pose_bias=self.pose_bias, pose_pairs=self.pose_pairs,
                           pose_error_basis=self.pose_error_basis,
                           pose_simulation=self.pose_simulation)
        except ValueError:
            return None
        if self.uncertainty_method == "bootstrap":
            u = self._bootstrap(u)
        return u

    def _bootstrap(self, u):
        """``u`` with its covariance replaced by the bootstrap one (seeded resampling of the
        motions, each resample solved by the same method); the verdict (from the
        information) is kept, and undetermined axes stay inf."""
        import dataclasses as _dc
        from simcalib.solvers.diagnostics.uncertainty import bootstrap_covariance
        rng = self.bootstrap_rng if self.bootstrap_rng is not None \
            else np.random.default_rng(0)
        solver_rng = np.random.default_rng(rng.integers(2**63))

        def solve_fn(Cb, Hb):
            return solve_batch(Cb, Hb, method=self.method, alpha=self.alpha,
                               prior=self.prior, rng=solver_rng).X
        try:
            boot = bootstrap_covariance(self.problem.C, self.problem.H, self.X, solve_fn,
                                        self.bootstrap_samples, rng)
        except ValueError:
            return None
        inf_axes = ~np.isfinite(np.diag(u.covariance))
        cov = boot.copy()
        if u.bias_covariance is not None:   # a calibration bias no resampling can see
            cov = cov + u.bias_covariance
        cov[inf_axes, :] = 0.0
        cov[:, inf_axes] = 0.0
        cov[inf_axes, inf_axes] = np.inf
        return _dc.replace(u, covariance=cov, covariance_determined=np.where(
            np.isfinite(cov), cov, 0.0), method="bootstrap")

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
        """Geometry of the motions (:class:`simcalib.solvers.diagnostics.observability.
        Observability`: singular values of the linearised equations, ``motion`` in words).
        Descriptive only: the verdict (``degenerate``, ``undetermined``) comes from
        :attr:`uncertainty`."""
        from simcalib.solvers.diagnostics.observability import analyse
        return analyse(self.problem, self.X, self.alpha, self.prior, self.cost)

    @cached_property
    def certificate(self):
        if self.family != "dq" or not self.success:
            return None
        from simcalib.solvers.diagnostics.certificate import certify
        q, qd = dual_quat_from_transform(self.X)
        return certify(self.problem, self.alpha, self.prior, q, qd)

    @property
    def degenerate(self) -> bool:
        """True when any direction of ``X`` is undetermined or poorly determined (1-sigma
        above ``tolerance_deg`` / ``tolerance_m``), from :attr:`uncertainty`; also True for
        a failed solve (there is no estimate to trust)."""
        u = self.uncertainty
        return True if u is None else u.degenerate

    @property
    def undetermined(self) -> tuple:
        """The directions the motions do not determine within the tolerances
        (:class:`~simcalib.solvers.diagnostics.uncertainty.Direction`: ``description`` in
        words, camera-a frame, ``reason`` "undetermined" / "poorly determined", 1-sigma
        ``std_deg`` / ``std_m``, ``determined_by_prior``); empty when determined."""
        u = self.uncertainty
        return () if u is None else tuple(u.directions)

    @property
    def certified(self) -> bool:
        return self.certificate is not None and self.certificate.certified

    @property
    def message(self) -> str:
        parts = [f"{self.method}: " + ("ok" if self.success else "FAILED")
                 + (f" ({self.solver_message})" if self.solver_message else "")]
        if self.certificate is not None:
            parts.append(self.certificate.summary())
        u = self.uncertainty
        if u is not None:
            parts.append(u.summary())
        elif self.success:
            parts.append("uncertainty unavailable (residuals not finite)")
        return "; ".join(parts)

    def to_dict(self) -> dict:
        """JSON-ready summary (plain floats/lists/strings) for results files."""
        cert = self.certificate
        u = self.uncertainty
        try:
            obs = self.observability if self.success else None
        except Exception:  # noqa: BLE001 - descriptive only, never blocks the result
            obs = None
        return {
            "method": self.method, "alpha": self.alpha, "success": self.success,
            "X": np.asarray(self.X).tolist() if self.success else None,
            "cost": _num(self.cost),
            "objective": _num(self.objective), "runtime_s": self.runtime_s,
            "n_motions": self.n_motions, "message": self.message,
            "prior": None if self.prior is None else {
                "X": self.prior.X.tolist(), "a": self.prior.a, "b": self.prior.b},
            "degenerate": self.degenerate,
            "verdict": self.verdict,
            "undetermined": [d.summary() for d in self.undetermined],
            "singular_values": None if obs is None else obs.singular_values.tolist(),
            "residual_rms": None if obs is None else _num(obs.residual_rms),
            "certificate": None if cert is None else {
                "certified": cert.certified, "route": cert.route, "mu": cert.mu,
                "relative_gap": _num(cert.relative_gap), "kkt_residual": _num(cert.kkt_residual),
                "summary": cert.summary()},
            "sign_flips": int(self.diagnostics.get("sign_flips", 0)),
            "uncertainty": _uncertainty_dict(u),
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
    ``diagnostics`` (dict of (B,) arrays, method-specific).

    Per-problem uncertainty (issue 9, computed on first access): ``uncertainty`` (tuple of
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


def _uncertainty_dict(u) -> dict | None:
    if u is None:
        return None
    return {"verdict": u.verdict, "degenerate": u.degenerate,
            "std_deg": [_num(x) for x in u.std[:3]], "std_m": [_num(x) for x in u.std[3:]],
            "covariance": [[_num(x) for x in row] for row in u.covariance],
            "noise": {"sigma_r_rad": u.noise.sigma_r_rad, "sigma_t_m": u.noise.sigma_t_m,
                      "estimated": u.noise.estimated},
            "tolerance_deg": u.tolerance_deg, "tolerance_m": u.tolerance_m,
            "method": u.method,
            "pose_noise": None if u.pose_noise_test is None else u.pose_noise_test.to_dict(),
            "simulated_bias": None if u.simulated_bias is None   # null along undetermined axes
            else [_num(x) for x in u.simulated_bias_determined],
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
    if not _clearly_rigid(X):   # the exact check (and its message) near the tolerance
        try:
            check_transforms(X, "X")
        except ValueError as exc:
            return X, False, f"solver {method!r} returned a non-rigid X ({exc})", diag
    return X, success, message, diag


#: margin of the fast rigidity check: half of check_transforms' tolerance, far above the
#: rounding of either way of computing R^T R and det for near-unit entries (~1e-15)
_RIGID_FAST_TOL = 0.5 * ORTHONORMAL_TOL


def _clearly_rigid(X) -> bool:
    """A finite 4x4 ``X`` passes :func:`check_transforms` by a margin: bottom row, R^T R - I
    and det - 1 within half its tolerance (scalar arithmetic: ~3 us instead of ~60 us). A
    False only means "ask check_transforms", which decides and words the failure."""
    (a, b, c, tx), (d, e, f, ty), (g, h, i, tz), bottom = X.tolist()
    tol = _RIGID_FAST_TOL
    if not (abs(bottom[0]) <= tol and abs(bottom[1]) <= tol and abs(bottom[2]) <= tol
            and abs(bottom[3] - 1.0) <= tol):
        return False
    return (abs(a * a + d * d + g * g - 1.0) <= tol and abs(b * b + e * e + h * h - 1.0) <= tol
            and abs(c * c + f * f + i * i - 1.0) <= tol and abs(a * b + d * e + g * h) <= tol
            and abs(a * c + d * f + g * i) <= tol and abs(b * c + e * f + h * i) <= tol
            and abs(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) - 1.0)
            <= tol)


def _check_weights_supported(info, weights):
    if weights is not None and not info.supports_weights:
        able = [i.name for i in registry.infos() if i.supports_weights]
        raise ValueError(f"method {info.name!r} does not take per-motion weights; methods "
                         f"with weights: {', '.join(able)}")


def _check_prior_supported(info, prior):
    if prior is not None and not info.supports_prior:
        with_prior = [i.name for i in registry.infos() if i.supports_prior]
        raise ValueError(f"method {info.name!r} does not support a prior; methods with a "
                         f"prior: {', '.join(with_prior)}")


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
    :func:`simcalib.vision.pose_error_basis`); the simulation then draws them with the
    white pose noise the residuals leave beyond them (whether or not the white-noise test
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


def _check_method_inputs(info, prior, weights, rng) -> tuple:
    """The checked ``(prior, rng)``, once ``info`` is known to accept the prior and weights."""
    prior = _check_prior(prior)
    _check_prior_supported(info, prior)
    _check_weights_supported(info, weights)
    if rng is not None or info.stochastic:
        rng = _check_rng(rng)   # stochastic methods get default_rng(0) when none is given
    return prior, rng


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


def _cost_and_objective(problem, X, alpha, prior) -> tuple:
    """``(cost, objective)`` at ``X`` (inf when ``X`` is not finite)."""
    if np.isfinite(X).all():
        q, qd = dual_quat_from_transform(X)
        cost = problem_cost(problem, q, qd, alpha)
        objective = cost + (prior_penalty(q, qd, prior) if prior is not None else 0.0)
    else:
        cost = objective = math.inf
    return cost, objective


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
    w = check_weights(weights, (B, N))
    compile_s = warm_up(parallel=B > 1)
    t0 = time.perf_counter()
    if info.batch_fn is not None and info.extra.get("batch_validates", False):
        out = info.batch_fn(C, H, alphas, prior, w)
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
            out = _loop(info, C, H, alphas, prior, rng, w)
    runtime = time.perf_counter() - t0
    X = np.asarray(out["X"], dtype=np.float64)
    finite = np.isfinite(X).all(axis=(-2, -1))
    success = np.asarray(out.get("success", finite), dtype=bool) & finite
    reason = np.asarray(out.get("failure_reason", np.full(B, "", dtype=object)), dtype=object)
    reason = np.where(~finite & (reason == ""), "non-finite X", reason)
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
    diagnostics["failure_reason"] = np.where(success, "", reason)
    diagnostics["compile_s"] = compile_s
    return BatchSolution(X=X, cost=cost, objective=objective, success=success, alpha=alphas,
                         method=method, runtime_s=runtime, prior=prior,
                         diagnostics=diagnostics, C=C, H=H, weights=w,
                         tolerance_deg=tolerance_deg, tolerance_m=tolerance_m)


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
