"""Checks of the solver API's inputs (:class:`Prior`, alpha, rng, weights and prior
support of a method, a solver function's output) and :func:`dq_cost`, shared by
:func:`simcalib.solve` and :func:`simcalib.solve_batch`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import ORTHONORMAL_TOL, check_transforms, dual_quat_from_transform
from simcalib.solvers import registry
from simcalib.solvers.kernels.gram import prior_penalty
from simcalib.solvers.problem import (ALPHA_MAX, ALPHA_MIN, MotionProblem, SolverOutput,
    alpha_range_error, prepare_problem, problem_cost)

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



def _check_method_inputs(info, prior, weights, rng) -> tuple:
    """The checked ``(prior, rng)``, once ``info`` is known to accept the prior and weights."""
    prior = _check_prior(prior)
    _check_prior_supported(info, prior)
    _check_weights_supported(info, weights)
    if rng is not None or info.stochastic:
        rng = _check_rng(rng)   # stochastic methods get default_rng(0) when none is given
    return prior, rng



def _cost_and_objective(problem, X, alpha, prior) -> tuple:
    """``(cost, objective)`` at ``X`` (inf when ``X`` is not finite)."""
    if np.isfinite(X).all():
        q, qd = dual_quat_from_transform(X)
        cost = problem_cost(problem, q, qd, alpha)
        objective = cost + (prior_penalty(q, qd, prior) if prior is not None else 0.0)
    else:
        cost = objective = math.inf
    return cost, objective

