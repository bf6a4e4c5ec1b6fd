"""The results of the solver API: :class:`Solution` (one solve; its diagnostics computed
when first asked for) and :class:`BatchSolution` (a batch)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from simcalib.geometry import dual_quat_from_transform
from simcalib.solvers.problem import MotionProblem
from simcalib.solvers.validation import (
    Prior,
    _cost_and_objective,
)

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
   ; ``message`` combines everything. When ``degenerate`` is True, the components
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
    tolerance_deg: float = 1.0      # verdict tolerances (1-sigma), see uncertainty.py
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

    # ---- uncertainty and the verdict that follows from it
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
            from simcalib.solvers.batch_solve import solve_batch
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
        a failed solve (there is no estimate to trust) and for a method whose rotation step
        the motions cannot feed (``diagnostics["rotation_shortfall"]``)."""
        u = self.uncertainty
        return True if u is None or self.diagnostics.get("rotation_shortfall") \
            else u.degenerate

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


