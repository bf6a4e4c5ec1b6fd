"""Inputs of the uncertainty model (:mod:`simcalib.solvers.diagnostics.uncertainty`):
the checks of tolerances, noise models, pose biases, weights and ``X``; the pose error
convention ``delta = (omega, v)``; the tolerance and floor constants."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import (
    check_transforms,
    rotvec_from_matrix,
    skew_matrix,
)


TOLERANCE_DEG = 1.0
TOLERANCE_M = 0.01
ROTATION_FLOOR_RAD = math.sqrt(np.finfo(float).eps)
TRANSLATION_FLOOR_REL = 1e-9
_UNDETERMINED_ROT_RAD = 1.0
NULL_LEVEL = 1e-3
_PURE = 0.05



# ----------------------------------------------------------------------------- inputs
def _real(name, val, *, positive=True, allow_zero=False) -> float:
    if isinstance(val, np.ndarray) and val.ndim == 0:
        val = val.item()
    if isinstance(val, bool) or not isinstance(val, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number; received {type(val).__name__} {val!r}")
    val = float(val)
    ok = math.isfinite(val) and (val > 0 or (allow_zero and val == 0))
    if not ok:
        raise ValueError(f"{name} must be finite and {'>= 0' if allow_zero else '> 0'}; "
                         f"received {val}")
    return val


def check_tolerances(tolerance_deg, tolerance_m) -> tuple[float, float]:
    """Validate the verdict tolerances (finite, > 0); returns them as floats."""
    return _real("tolerance_deg", tolerance_deg), _real("tolerance_m", tolerance_m)


@dataclass(frozen=True)
class NoiseModel:
    """Eq. 38 noise on every motion of both sensors: rotation angle std ``sigma_r_rad``
    (about a uniform random axis), translation std per axis ``sigma_t_m``.
    ``estimated``: True when fitted to the residuals (then ``n_motions`` is the sample)."""
    sigma_r_rad: float
    sigma_t_m: float
    estimated: bool = False

    def __post_init__(self):
        object.__setattr__(self, "sigma_r_rad",
                           _real("sigma_r_rad", self.sigma_r_rad, allow_zero=True))
        object.__setattr__(self, "sigma_t_m", _real("sigma_t_m", self.sigma_t_m, allow_zero=True))


def _coerce_pair(value, cls, name: str, pair: str):
    """``value`` as a ``cls``: None and ``cls`` pass, a 2-sequence builds one, else
    TypeError naming what ``name`` allows."""
    if value is None or isinstance(value, cls):
        return value
    if isinstance(value, (tuple, list)) and len(value) == 2:
        return cls(value[0], value[1])
    raise TypeError(f"{name} must be a {cls.__name__}, a {pair} pair or None; "
                    f"received {type(value).__name__}")


def _check_noise(noise) -> NoiseModel | None:
    return _coerce_pair(noise, NoiseModel, "noise", "(sigma_r_rad, sigma_t_m)")


def _check_cov6(name, P) -> np.ndarray:
    if P is None:
        return np.zeros((6, 6))
    try:
        A = np.array(P, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a 6x6 covariance matrix (array of numbers) or None; "
                        f"received {type(P).__name__}") from None
    if A.shape != (6, 6):
        raise ValueError(f"{name} must be a 6x6 covariance (rotvec rad, translation m); "
                         f"received shape {A.shape}")
    if not np.isfinite(A).all():
        raise ValueError(f"{name} must be finite; received non-finite entries")
    scale = float(np.max(np.abs(A)))
    if np.max(np.abs(A - A.T)) > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric; max |P - P^T| = "
                         f"{np.max(np.abs(A - A.T)):.3g} (max |P| = {scale:.3g})")
    A = 0.5 * (A + A.T)
    lam = np.linalg.eigvalsh(A) if scale > 0 else np.zeros(6)
    if lam[0] < -1e-9 * max(lam[-1], 0.0) or (lam[-1] <= 0 and lam[0] < 0):
        raise ValueError(f"{name} must be positive semi-definite; smallest eigenvalue "
                         f"{lam[0]:.3g}")
    A.setflags(write=False)
    return A


@dataclass(frozen=True, eq=False)
class PoseBias:
    """Known covariance of each camera's pose error that is constant over the run (a
    calibration error of the camera, e.g. its intrinsics): ``cov_a``, ``cov_b`` (6x6, or
    None for none), of ``n_c = (rotvec rad, translation m)`` with
    ``T_world_cam measured = T_world_cam true @ exp(n_c)`` (right-multiplied, camera frame,
    the order of the error ``delta``). Symmetric, positive semi-definite, finite."""
    cov_a: np.ndarray | None = None
    cov_b: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "cov_a", _check_cov6("pose_bias cov_a", self.cov_a))
        object.__setattr__(self, "cov_b", _check_cov6("pose_bias cov_b", self.cov_b))

    @property
    def is_zero(self) -> bool:
        return not (np.any(self.cov_a) or np.any(self.cov_b))


def check_pose_bias(pose_bias) -> PoseBias | None:
    """``pose_bias`` as a :class:`PoseBias` (None, a PoseBias or ``(cov_a, cov_b)``)."""
    return _coerce_pair(pose_bias, PoseBias, "pose_bias", "(cov_a, cov_b) of 6x6 covariances")


def pose_bias_jacobians(X) -> tuple[np.ndarray, np.ndarray]:
    """``(Ja, Jb)`` (6x6 each): first-order error ``delta`` of ``X`` (convention of
    :func:`pose_error`, vs the true ``X``) when the estimate converges to
    ``X' = exp(n_a)^-1 X exp(n_b)`` (run-constant pose errors ``n_a``, ``n_b`` of the
    cameras, right-multiplied): ``delta = Ja n_a + Jb n_b``."""
    X = _check_X(X)
    R, t = X[:3, :3], X[:3, 3]
    Ja = np.eye(6)
    Ja[3:, :3] = -skew_matrix(t)
    Jb = np.zeros((6, 6))
    Jb[:3, :3] = -R
    Jb[3:, 3:] = -R
    return Ja, Jb


def pose_bias_covariance(X, cov_a, cov_b) -> np.ndarray:
    """Covariance (6x6) of the error ``delta`` of ``X`` caused by run-constant camera pose
    errors with covariances ``cov_a``, ``cov_b`` (see :class:`PoseBias`)."""
    pb = PoseBias(cov_a, cov_b)
    Ja, Jb = pose_bias_jacobians(X)
    S = Ja @ pb.cov_a @ Ja.T + Jb @ pb.cov_b @ Jb.T
    return 0.5 * (S + S.T)


def _woodbury_information(F, Sig):
    """``(F^-1 + Sig)^-1`` for PSD ``F`` (possibly singular) and PSD ``Sig``:
    ``F - F G (I + G^T F G)^-1 G^T F`` with ``Sig = G G^T``."""
    lam, V = np.linalg.eigh(0.5 * (Sig + Sig.T))
    G = V * np.sqrt(np.clip(lam, 0.0, None))
    FG = F @ G
    out = F - FG @ np.linalg.solve(np.eye(G.shape[1]) + G.T @ FG, FG.T)
    return 0.5 * (out + out.T)


def _check_X(X, name="X") -> np.ndarray:
    X = check_transforms(X, name)
    if X.shape != (4, 4):
        raise ValueError(f"{name} must be one 4x4 transform; received shape {X.shape}")
    return X


def _check_weights(weights, n) -> np.ndarray:
    if weights is None:
        return np.ones(n)
    try:
        w = np.asarray(weights, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"weights must be {n} non-negative numbers; received "
                        f"{type(weights).__name__}") from None
    if w.shape != (n,) or not np.isfinite(w).all() or (w < 0).any() or not (w > 0).any():
        raise ValueError(f"weights must be {n} finite numbers >= 0, not all 0; received "
                         f"shape {w.shape}")
    return w




def pose_error(X_true, X_est) -> np.ndarray:
    """``delta = (omega, v)``: rotvec of ``R_true R_est^T`` (rad) and ``t_true - t_est`` (m),
    batched over ``(..., 4, 4)``."""
    X_true = np.asarray(X_true, dtype=np.float64)
    X_est = np.asarray(X_est, dtype=np.float64)
    om = rotvec_from_matrix(X_true[..., :3, :3] @ np.swapaxes(X_est[..., :3, :3], -1, -2))
    return np.concatenate([om, X_true[..., :3, 3] - X_est[..., :3, 3]], axis=-1)


