"""Uncertainty of a hand-eye estimate, the degeneracy verdict that follows from it, and a
data-driven choice of alpha. Pure numpy/scipy; no solver imports (any estimate ``X`` works).

Error convention (issue 9): ``delta = (omega, v)`` with ``omega`` the rotation vector of
``R_true @ R_est.T`` (rad) and ``v = t_true - t_est`` (m), both in frame a (``X = T_a_b``),
order ``(wx, wy, wz, vx, vy, vz)``.

Model
-----
Per motion ``i`` the geometric residual ``e_i = (rho_i, tau_i)`` of ``C_i X = X H_i`` is
``rho_i = rotvec(R_Ci R_Ci'^T)``, ``tau_i = t_Ci - t_Ci'`` with ``C_i' = X H_i X^-1``.
Linearised: ``e_i(delta) = e_i + K_i delta``. The measurement noise is the paper's eq. 38 on
every ``C_i`` and ``H_i`` (rotation angle ~ N(0, sigma_r^2) about a uniform axis, translation
~ N(0, sigma_t^2 I)); propagated to first order it gives ``Cov(e_i) = Q_i`` (6x6, coupling
the rotation noise of ``H_i`` into ``tau_i`` through ``R_Ci' t_X``).

* ``sigma_r``, ``sigma_t`` are estimated from the residuals by the method of moments
  (rotation residuals give ``sigma_r``; translation residuals minus the rotation-noise part
  give ``sigma_t``), with a degrees-of-freedom factor ``N / (N - 1)``; a known
  :class:`NoiseModel` can be passed instead. A numerical floor is added in quadrature:
  ``sqrt(eps)`` rad and ``1e-9 L`` m (``L`` the translation scale of the data): DQ solvers
  square the motion matrices, so relative rotations below ~1e-8 rad carry no usable
  information even on noise-free data.
* **Calibration bias (a known input, ``pose_bias``)**: a pose error that is *constant*
  over the run (e.g. from an error of the camera intrinsics) is exactly a change of ``X``
  (``X' = N_a^-1 X N_b``) and leaves no trace in the residuals; no residual-based term can
  include it. The user states how well the cameras are calibrated instead: a
  :class:`PoseBias` holds the covariance ``P_c`` (6x6) of each camera's run-constant pose
  error ``N_c = exp(n_c)``, right-multiplied (``T_world_cam measured = T_world_cam N_c``,
  camera frame, ``n_c = (rotvec rad, translation m)``). To first order the error of ``X``
  it causes is ``delta = Ja n_a + Jb n_b`` with ``Ja = [[I, 0], [-[t_X], I]]``,
  ``Jb = -diag(R_X, R_X)`` (:func:`pose_bias_covariance`), so the estimator's error gets
  ``Sigma_bias = Ja P_a Ja^T + Jb P_b Jb^T``: added to the meat as ``H_d Sigma_bias H_d``
  (``H_d`` the data part of the bread: the data pull the estimate to ``X'``, a prior holds
  it back), and to the verdict's information as ``(F^-1 + Sigma_bias)^-1`` (Woodbury form,
  valid for singular ``F``). The pipeline derives ``P_c`` for ArUco streams from
  ``vision.intrinsics_error`` and the marker map's survey error
  (:func:`simcalib.vision.calibration_pose_bias`).
* **Covariance of the estimate** (the sandwich of the paper's cost at ``alpha``): the DQ
  residual of cost (8) is ``r_i ~= T_i e_i`` (8x6, with alpha on the dual rows), so the cost is
  ``sum e_i^T S_i e_i`` with ``S_i = T_i^T T_i``. Gauss-Newton / first-order perturbation of
  the minimiser: ``Sigma = H^-1 M H^-1`` with ``H = sum K^T S K (+ prior)`` and
  ``M = sum K^T S Q S K (+ prior)``. This is the covariance of the minimiser of the alpha
  cost; for other estimators (daniilidis, dq2steps, ...) it is used as an approximation,
  plus their bias: without a prior, the Gauss-Newton step ``s = -H^-1 g`` from ``X`` to the
  minimiser of the alpha cost (``g = sum K^T S e``, 0 for an exact minimiser) is added as
  ``s s^T`` (mean squared error; :attr:`Uncertainty.offset`). An estimator far from the
  optimum of the data (e.g. OpenCV's Daniilidis) is thus never reported tighter than it is.
* **Motions sharing poses** (``pose_pairs``, the datapoint pairs of motions formed from
  pose streams): the whitened residuals' autocorrelation is tested against white pose
  noise (:func:`simcalib.solvers.diagnostics.pose_noise.white_noise_test`); when it
  passes and there is no prior, the meat becomes ``H (S + b b^T) H`` with ``S``, ``b`` the
  covariance and bias of the alpha-cost minimiser simulated with that noise structure
  (:func:`~simcalib.solvers.diagnostics.pose_noise.simulate_error`), and the offset of a
  non-optimal estimator is the exact one (``minimiser_offset``) instead of the Gauss-Newton
  step of the linearised cost, which errs by second-order terms as large as that bias.
  ``Uncertainty.method`` is then ``"pose_simulation"``. The verdict's information ``F`` is
  unchanged.
* **Systematic pose errors (a known input, ``pose_error_basis``)**: pose errors shared by
  the poses through common parameters — a marker map's survey error and the lens
  calibrations' errors move every ArUco pose by an amount that depends on the markers it
  rests on and where they fall in the image — are constant over the run in part (a change
  of X, invisible) and drift with the viewpoint in part (serially correlated residuals,
  whose low frequencies no residual-based correction can reach). With their per-pose
  sensitivities ``(Ba, Bb)`` (``xi = B eta``, ``eta ~ N(0, I)`` shared by both cameras)
  the simulation draws them beside white pose noise, whether or not the white-noise test
  passes (no prior); the white level is the fitted one less the residual share the
  systematic errors explain at the re-estimated X
  (``pose_noise.systematic_residual_power``; at least ``WHITE_SHARE_FLOOR`` of it), and
  ``pose_bias`` (whose run-constant errors the basis holds) is not added. The pipeline
  derives the basis for ArUco cameras (marker map, calibrations) and ``robot_fk`` streams
  (the arm's DH table, ``robot.kinematic_error``) (:func:`simcalib.pipeline.
  pose_error_basis`) and simulates once per run: the other solvers' headlines reuse the
  simulation (``pose_simulation=``, ``Uncertainty.simulation``), each adding its own
  offset from the minimiser.
* **Information** (alpha-free, for the verdict): ``F = sum K^T Q^-1 K`` (Fisher information
  of the data under the noise model; alpha cancels exactly).
* **Prior** (paper eqs. 26-29): read as a pseudo-measurement of ``vec(dq)`` with weight ``a``
  and of ``dq'`` with weight ``b``, each in units of the per-component noise variance of the
  data residuals of the same kind (rotation part ``nu_a``, dual part without alpha ``nu_b``):
  (``sqrt(a) vec(dq)`` has the noise of one rotation residual component, so ``vec(dq)`` has
  variance ``nu_a / a``): information ``a Jpa^T Jpa / nu_a + b Jpb^T Jpb / nu_b``; in the
  sandwich it adds ``a Jpa^T Jpa + b Jpb^T Jpb`` to ``H`` and
  ``a nu_a Jpa^T Jpa + b nu_b Jpb^T Jpb`` to ``M``. :attr:`Uncertainty.prior_covariance` is the covariance this reading implies
  for the prior's own error.

Verdict
-------
Coordinates are scaled by the tolerances (``omega / tolerance_deg``, ``v / tolerance_m``).
Every rank decision is relative to the noise, never to the largest singular value.

**Noise-made information (issues 9, 14).** ``F`` is evaluated at the *measured* motions.
When the true motion is exactly degenerate along a direction ``g`` (planar: ``K_i g = 0``
for the vertical translation), the noise of ``H_i`` tilts the measured rotation axes and
``g^T F g`` is not 0 but a quadratic form in that noise: with ``dK_ij = dK_i/dxi_j``
(:func:`noise_jacobians`, exact since ``K_i`` is affine in ``C_i' = X H_i X^-1``) and the
fitted variances ``v_j`` (``sigma_r^2/3`` per rotation component, ``sigma_t^2`` per
translation component, floors included), its expectation is ``g^T F_noise g`` with

    F_noise = sum_i w_i sum_j v_j dK_ij^T Q_i^-1 dK_ij

(the second-order term of ``E[F]`` in the noise; :attr:`Uncertainty.noise_information`).
For an informative direction ``g^T F g / g^T F_noise g ~ 1 / sigma_r^2`` (thousands and
more); for a degenerate one it is ~1. The generalised eigenproblem ``F g = r F_noise g``
(:attr:`Uncertainty.information_ratio`, ascending; invariant to any linear change of
coordinates, hence to units, and alpha-free) gives the directions. A direction is
**undetermined** when ``r`` is not significantly above 1: under the null (no information),
``g^T F g`` is a Gaussian quadratic form with per-motion Gram matrices ``M_i = [b_ij .
b_il]`` (``b_ij = sqrt(w_i v_j) Q_i^-1/2 dK_ij g``), i.e. ``~ chi2(nu1) / nu1`` times its mean with
Satterthwaite's ``nu1 = (sum tr M_i)^2 / sum tr M_i^2`` (``2N`` for planar motion: two
tilt components per motion); and ``F_noise`` uses a fitted ``sigma_r^2`` with ``nu2 =
3 (N_eff - 1)`` degrees of freedom (``inf`` when the noise is given). So ``r ~
F(nu1, nu2)`` and the threshold is its ``1 - NULL_LEVEL`` quantile (0.999;
:attr:`Uncertainty.ratio_threshold`). Motions sharing poses (``correlation_lag`` > 0)
divide both by ``1 + lag`` (conservative: consecutive pairs of one stream correlate
with at most two others at -1/2, a variance factor 1.5). The smallest ratio over
directions is biased low under the null, which only errs towards "undetermined".
Noise-free data: the measured tilts are rounding (1e-16) against the floor ``sqrt(eps)``
of ``sigma_r``, so ``r ~ 1e-16``: undetermined for every estimator (the floor stands for
what DQ solvers, which square the motion matrices, cannot resolve). Ratios are computed
from the stacked whitened data rows (SVD, after whitening by ``F_noise``), not from
``eigh(F)``, whose rounding ``eps * |F|`` would swamp them when ``F`` spans 30 orders of
magnitude. The fitted noise includes model misfit; a noise model that overstates the
noise makes this test call more directions undetermined (conservative).

A direction is also **undetermined** when its 1-sigma from ``F`` exceeds the range of the
quantity: more than 1 rad of rotation or more than ``L`` of translation (``L`` = largest
of the RMS translation of the motions, ``|t_X|`` and ``tolerance_m``). The undetermined
subspace ``U_d`` of the data is the span of both kinds (directions within ~3 deg of it
count once). Outside it (orthogonal complement ``B_d``, tolerance coordinates) the
eigen-directions of ``B_d^T F B_d`` with 1-sigma ``s > 1`` (above the tolerance) are
**poorly determined**, reported with that ``s``; the undetermined ones get an infinite
1-sigma. With a prior: within ``U_d`` only the prior informs (the data information there
is noise-made); a direction stays undetermined in total when the prior's 1-sigma along it
also exceeds the range; ``determined_by_prior`` / ``std_with_prior`` use the data
information outside ``U_d`` plus the prior.

Covariance with undetermined directions: along the undetermined subspace ``U`` (of the total
information, data plus prior) the variance is infinite. The finite part is the sandwich
restricted to the determined subspace ``B`` (error along ``U`` held fixed). In
:attr:`Uncertainty.covariance` every axis with a component above 5 % in ``U`` (orthonormal
basis, tolerance coordinates; a noise-tilted undetermined direction has ~1e-5 components on
the other axes) gets ``inf`` variance and its off-diagonal entries are set to 0; the other
entries are those of the finite part.
:attr:`Uncertainty.covariance_determined` holds the finite part alone (0 along ``U``), and
:meth:`Uncertainty.mahalanobis2` / :meth:`Uncertainty.inside_region` use it with a
chi-square of ``k`` = number of determined directions degrees of freedom.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import (
    check_transforms,
    dual_quat_from_transform,
    invert_transform,
    quat_conjugate,
    quat_left_matrix,
    quat_right_matrix,
    rotvec_from_matrix,
    skew_matrix,
)

__all__ = [
    "linear_model", "linear_model_jacobians", "noise_covariance_parts", "NoiseModel", "PoseBias", "pose_bias_jacobians", "pose_bias_covariance",
    "Direction", "DIRECTION_STATES", "direction_state", "direction_sigma", "Uncertainty", "AlphaChoice", "covariance", "covariance_batch",
    "choose_alpha", "bootstrap_covariance", "pose_error", "check_tolerances",
    "check_pose_bias", "TOLERANCE_DEG", "TOLERANCE_M", "ROTATION_FLOOR_RAD",
    "TRANSLATION_FLOOR_REL", "NULL_LEVEL", "noise_jacobians"]

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


# ------------------------------------------------------------------------ linear model
def linear_model(C, H, X):
    """Residuals e (N,6), Jacobians K (N,6,6) w.r.t. delta, and the two noise-covariance
    parts Qr, Qt (N,6,6) with Cov(e_i) = sigma_r^2 Qr_i + sigma_t^2 Qt_i."""
    e, K, J_c, J_h = linear_model_jacobians(C, H, X)
    return (e, K, *noise_covariance_parts(J_c, J_h))


def noise_covariance_parts(J_c, J_h):
    """``(Qr, Qt)`` (N,6,6) of :func:`linear_model` from the noise Jacobians of
    :func:`linear_model_jacobians` (isotropic eq. 38 noise: per-component variance
    ``sigma_r^2 / 3`` on the rotation columns, ``sigma_t^2`` on the translation ones)."""
    def outer(J):
        return J @ np.swapaxes(J, -1, -2)
    Qr = (outer(J_c[..., :3]) + outer(J_h[..., :3])) / 3.0
    Qt = outer(J_c[..., 3:]) + outer(J_h[..., 3:])
    return Qr, Qt


def linear_model_jacobians(C, H, X):
    """Residuals e (N,6), Jacobians K (N,6,6) w.r.t. delta, and the first-order response
    of the residuals to the eq. 38 noise right-multiplied on C_i and on H_i: ``J_c``,
    ``J_h`` (N,6,6), columns (rotation eps, translation n)."""
    N = C.shape[0]
    RX, tX = X[:3, :3], X[:3, 3]
    Cp = X @ H @ invert_transform(X)                       # C_i' = X H_i X^-1
    RCp, tCp = Cp[:, :3, :3], Cp[:, :3, 3]
    RC, tC = C[:, :3, :3], C[:, :3, 3]
    rho = rotvec_from_matrix(RC @ np.swapaxes(RCp, -1, -2))
    tau = tC - tCp
    e = np.concatenate([rho, tau], axis=1)
    I3 = np.eye(3)
    K = np.zeros((N, 6, 6))
    K[:, :3, :3] = RCp - I3
    K[:, 3:, :3] = skew_matrix(tCp) - skew_matrix(np.broadcast_to(tX, (N, 3))) + RCp @ skew_matrix(tX)
    K[:, 3:, 3:] = RCp - I3
    # noise Jacobians (eq. 38 right-multiplied noise on C_i and H_i)
    u_map = RX @ H[:, :3, :3]                              # eps_h -> u = R_X R_H eps_h
    J_c = np.zeros((N, 6, 6))
    J_c[:, :3, :3] = RC
    J_c[:, 3:, 3:] = RC
    J_h = np.zeros((N, 6, 6))
    J_h[:, :3, :3] = -u_map
    J_h[:, 3:, :3] = -skew_matrix(RCp @ tX) @ u_map
    J_h[:, 3:, 3:] = -u_map
    return e, K, J_c, J_h


def noise_jacobians(H, X) -> np.ndarray:
    """``dK_i / dxi_j`` (N, 6, 6, 6): derivative of the Jacobian ``K_i`` of
    :func:`linear_model` w.r.t. the six noise components ``xi = (u, m)`` of ``H_i`` (eq. 38
    noise right-multiplied on ``H_i``, expressed in frame a: ``u = R_X R_Hi eps``,
    ``m = R_X R_Hi n``; isotropic, per-component variance ``sigma_r^2 / 3`` and
    ``sigma_t^2``). ``K_i`` depends on ``H_i`` only through ``C_i' = X H_i X^-1``:
    ``dR_Ci' = [u]x R_Ci'``, ``dt_Ci' = m - [u]x R_Ci' t_X``; ``K`` is affine in both, so
    the derivative is exact."""
    N = H.shape[0]
    RX, tX = X[:3, :3], X[:3, 3]
    RCp = RX @ H[:, :3, :3] @ RX.T
    E = skew_matrix(np.eye(3))                             # E[j] = [e_j]x
    a = E[None] @ RCp[:, None]                             # (N, 3, 3, 3): [e_j]x R_Ci'
    dK = np.zeros((N, 6, 6, 6))
    dK[:, :3, :3, :3] = a
    dK[:, :3, 3:, 3:] = a
    dK[:, :3, 3:, :3] = skew_matrix(-(a @ tX)) + a @ skew_matrix(tX)
    dK[:, 3:, 3:, :3] = E[None]
    return dK


@dataclass(frozen=True)
class _NullTest:
    ratio: np.ndarray          # (6,) generalised eigenvalues of (F, F_noise), ascending
    directions: np.ndarray     # (6, 6) unit columns, tolerance coordinates
    dof: np.ndarray            # (6,) effective chi-square degrees of freedom
    threshold: np.ndarray      # (6,) F(dof, dof_noise) quantile 1 - NULL_LEVEL
    undetermined: np.ndarray   # (6,) bool: ratio <= threshold


def _noise_null_test(Kw, Bw, dsc, lag, dof_noise) -> _NullTest:
    """Generalised eigenproblem ``F g = r F_noise g`` (whitened stacks ``Kw`` (N,6,6) and
    ``Bw`` (N,6,6,6), tolerance scaling ``dsc``) as the SVD of the stacked data rows times
    ``R^-1`` (``F_noise = R^T R``; ``F_noise`` is well conditioned, noise over noise): small
    ratios keep their accuracy even when ``F`` spans 30 orders of magnitude (noise-free data
    at the floors), which ``eigh(F)`` would not."""
    # scipy.special, not scipy.stats: the same quantiles without ~0.5 s of import per process
    from scipy.special import chdtri, fdtri
    A = Kw.reshape(-1, 6) * dsc
    B = Bw.reshape(-1, 6) * dsc
    Fn = B.T @ B
    try:
        R = np.linalg.cholesky(0.5 * (Fn + Fn.T)).T       # Fn = R^T R
    except np.linalg.LinAlgError:
        R = np.linalg.qr(B, mode="r")
    M = np.linalg.solve(R.T, A.T).T                        # A R^-1
    _, s, Vt = np.linalg.svd(M, full_matrices=False)
    order = np.argsort(s)
    r = s[order] ** 2
    G = np.linalg.solve(R, Vt[order].T)                    # g = R^-1 v (F_noise-normalised)
    # Satterthwaite: g^T F g = sum_i |sum_j xi_ij b_ij|^2 under the null, a quadratic form
    # in Gaussian noise with per-motion Gram matrices M_i = [b_ij . b_il]
    b = (B @ G).reshape(Bw.shape[0], 6, 6, 6)              # (N, 6 noise, 6 rows, 6 dirs)
    b = np.moveaxis(b, 3, 0)                               # (6 dirs, N, 6 noise, 6 rows)
    gram = b @ np.swapaxes(b, -1, -2)                      # (6, N, 6, 6)
    mean = np.trace(gram, axis1=2, axis2=3).sum(axis=1)
    dof = mean ** 2 / np.maximum(np.sum(gram * gram, axis=(1, 2, 3)), 1e-300)
    dof = np.maximum(dof / (1.0 + lag), 1.0)
    if math.isfinite(dof_noise):
        thr = fdtri(dof, max(dof_noise / (1.0 + lag), 1.0), 1.0 - NULL_LEVEL)
    else:
        thr = chdtri(dof, NULL_LEVEL) / dof
    G = G / np.linalg.norm(G, axis=0)
    return _NullTest(r, G, dof, thr, r <= thr)


def _span(blocks, tol: float = _PURE) -> np.ndarray:
    """Orthonormal basis (6, k) of the span of the columns of ``blocks`` (normalised first;
    singular values below ``tol`` dropped: nearly parallel columns count once)."""
    V = np.concatenate([np.zeros((6, 0)), *blocks], axis=1)
    if V.shape[1] == 0:
        return np.zeros((6, 0))
    V = V / np.linalg.norm(V, axis=0)
    U, s, _ = np.linalg.svd(V, full_matrices=False)
    return U[:, s > tol]


def _complement(U) -> np.ndarray:
    """Orthonormal basis of the orthogonal complement of the orthonormal columns ``U``."""
    if U.shape[1] == 0:
        return np.eye(6)
    Q, _ = np.linalg.qr(np.concatenate([U, np.eye(6)], axis=1))
    return Q[:, U.shape[1]:6]

def _dq_map(C, X, alpha):
    """T_i (N,8,6): DQ residual of cost (8), [A q; alpha (B q + A q')], as a linear function
    of the geometric residual e_i (sign of the DQ pair irrelevant: only T^T T is used)."""
    N = C.shape[0]
    qC, qCd = dual_quat_from_transform(C)
    qX, qXd = dual_quat_from_transform(X)
    Rq = quat_right_matrix(qC)[:, :, :3]                   # (rho,0) -> q_C-ish: 1/2 R(q_C)
    dq_rho = 0.5 * Rq                                      # d q_C / d rho
    tq = np.concatenate([C[:, :3, 3], np.zeros((N, 1))], axis=1)
    dqd_rho = 0.5 * quat_left_matrix(tq) @ dq_rho          # d q_C' / d rho
    dqd_tau = 0.5 * Rq                                     # d q_C' / d tau
    RqX = quat_right_matrix(qX)
    RqXd = quat_right_matrix(qXd)
    T = np.zeros((N, 8, 6))
    T[:, :4, :3] = RqX @ dq_rho
    T[:, 4:, :3] = alpha * (RqXd @ dq_rho + RqX @ dqd_rho)
    T[:, 4:, 3:] = alpha * (RqX @ dqd_tau)
    return T


def _prior_jacobians(X, prior):
    """Jacobians (3x6, 4x6) of vec(dq) and dq' (dq + eps dq' = Q_prior^* Q_X) w.r.t. delta."""
    q, _ = dual_quat_from_transform(X)
    qh, qhd = dual_quat_from_transform(prior.X)
    dq_dw = 0.5 * quat_right_matrix(q)[:, :3]              # d q / d omega
    tq = np.concatenate([X[:3, 3], [0.0]])
    dqd_dw = 0.5 * quat_left_matrix(tq) @ dq_dw
    dqd_dv = 0.5 * quat_right_matrix(q)[:, :3]
    Lh = quat_left_matrix(quat_conjugate(qh))
    Lhd = quat_left_matrix(quat_conjugate(qhd))
    Ja = np.zeros((4, 6))
    Ja[:, :3] = Lh @ dq_dw
    Jb = np.zeros((4, 6))
    Jb[:, :3] = Lhd @ dq_dw + Lh @ dqd_dw
    Jb[:, 3:] = Lh @ dqd_dv
    return Ja[:3], Jb


# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class Direction:
    """An eigen-direction of the (tolerance-scaled) information the data do not pin down.

    ``reason``: "undetermined" or "poorly determined"; ``rotation_axis_a`` /
    ``translation_dir_a``: unit 3-vectors in camera-a coordinates (zeros if that part is
    < 5 % of the direction); ``std_deg`` / ``std_m``: 1-sigma of the rotation / translation
    part along it from the data alone (inf when undetermined); ``std_with_prior_deg/_m``:
    the same with the prior; ``determined_by_prior``: the prior brings it within tolerance;
    ``description``: words.
    """
    reason: str
    kind: str
    rotation_axis_a: np.ndarray
    translation_dir_a: np.ndarray
    std_deg: float
    std_m: float
    std_with_prior_deg: float
    std_with_prior_m: float
    determined_by_prior: bool
    description: str

    with_prior: bool = False   # a prior was given (``std_with_prior_*`` are its sigma)

    @property
    def state(self) -> str:
        """``fixed by the prior``, ``poorly determined``, ``undetermined`` (see
        :func:`direction_state`)."""
        return direction_state(self.reason, self.determined_by_prior, self.with_prior,
                               math.isfinite(self.std_with_prior_deg)
                               and math.isfinite(self.std_with_prior_m))

    def sigma_text(self) -> str:
        """The 1-sigma that applies to this direction, in words: with the prior when one
        was given, else from the motions alone."""
        if self.with_prior:
            return direction_sigma(self.kind, self.std_with_prior_deg,
                                   self.std_with_prior_m, with_prior=True)
        return direction_sigma(self.kind, self.std_deg, self.std_m)

    def summary(self) -> str:
        """``<description>: <state> (<sigma>)``: the one rendering of a direction (console
        footnotes, results.json words, Solution.message)."""
        return f"{self.description}: {self.state} ({self.sigma_text()})"


#: the states a direction of X can be in, best first
DIRECTION_STATES = ("determined", "fixed by the prior", "poorly determined",
                    "poorly determined (prior only)", "undetermined")


def direction_state(reason: str, determined_by_prior: bool, with_prior: bool = False,
                    prior_sigma_finite: bool = False) -> str:
    """The state of a flagged direction, in the words every report uses: ``fixed by the
    prior`` (the prior brings it within tolerance), ``poorly determined (prior only)`` (the
    motions do not determine it, the prior bounds it but not within tolerance), else the
    motions' ``reason`` (``poorly determined`` / ``undetermined``)."""
    if determined_by_prior:
        return "fixed by the prior"
    if reason == "undetermined" and with_prior and prior_sigma_finite:
        return "poorly determined (prior only)"
    return reason


def direction_sigma(kind: str, std_deg: float, std_m: float, with_prior: bool = False
                    ) -> str:
    """``1-sigma 2.3 cm`` for a translation direction, ``1-sigma 0.5 deg`` for a rotation,
    both for a coupled one (only the parts that apply); ``no finite 1-sigma: ...`` when it
    is infinite."""
    parts = [(std_deg, "deg")] if kind in ("rotation", "coupled") else []
    parts += [(std_m, "m")] if kind in ("translation", "coupled") else []
    if not all(math.isfinite(x) for x, _ in parts):
        return ("no finite 1-sigma: neither the motions nor the prior constrain it"
                if with_prior else "no finite 1-sigma: the motions do not constrain it")
    return ("1-sigma " + ", ".join(_fmt_std(x, unit) for x, unit in parts)
            + (" with the prior" if with_prior else ""))


def _fmt_std(x, unit):
    if unit == "m" and math.isfinite(x) and x < 1.0:
        return f"{100 * x:.3g} cm"
    return "inf " + unit if not math.isfinite(x) else f"{x:.3g} {unit}"


def _fmt_vec(v) -> str:
    return "[" + ", ".join(f"{x:+.3f}" for x in v) + "]"


@dataclass(frozen=True, eq=False)
class Uncertainty:
    """Uncertainty of estimate ``X`` (see module doc). Arrays are 6x6 in the order
    ``(wx, wy, wz, vx, vy, vz)``, rad and m, frame a."""
    X: np.ndarray
    covariance: np.ndarray
    covariance_determined: np.ndarray
    determined_basis: np.ndarray
    information: np.ndarray
    prior_covariance: np.ndarray | None
    noise: NoiseModel
    alpha: float
    tolerance_deg: float
    tolerance_m: float
    directions: tuple
    translation_scale_m: float
    n_motions: int
    method: str = "sandwich"
    offset: np.ndarray | None = None   # Gauss-Newton step from X to the alpha-cost minimiser
    bias_covariance: np.ndarray | None = None   # part of covariance from pose_bias (6x6)
    # the noise-only information (verdict null, 6x6 like ``information``), the generalised
    # eigenvalues of (information, noise_information) ascending, and their thresholds
    noise_information: np.ndarray | None = None
    information_ratio: np.ndarray | None = None
    ratio_threshold: np.ndarray | None = None
    # motions from pose streams (``pose_pairs``): the white pose-noise test and, when it
    # passed, the simulated bias of the alpha-cost minimiser (delta coordinates, estimate
    # minus truth; its outer product is part of ``covariance``)
    pose_noise_test: object = None
    simulated_bias: np.ndarray | None = None
    # with ``pose_error_basis``: the number of systematic parameters the simulation drew
    # (0: none) and the white pose noise it added beyond them (per pose: rad, m)
    systematic_parameters: int = 0
    white_pose_noise: tuple | None = None
    # the simulation itself (pose_noise.SimulatedError), to reuse for other estimates of
    # the same motions (``covariance(..., pose_simulation=...)``)
    simulation: object = None

    @property
    def std(self) -> np.ndarray:
        """1-sigma per axis: (wx, wy, wz) in deg, (vx, vy, vz) in m (inf if undetermined)."""
        s = np.sqrt(np.diag(self.covariance))
        return np.concatenate([np.degrees(s[:3]), s[3:]])

    @property
    def simulated_bias_determined(self) -> np.ndarray | None:
        """``simulated_bias`` with NaN along the undetermined axes (a bias along a direction
        the data cannot determine means nothing); None without a simulation."""
        if self.simulated_bias is None:
            return None
        return np.where(np.isfinite(np.diag(self.covariance)), self.simulated_bias, np.nan)

    @property
    def std_deg(self) -> np.ndarray:
        return self.std[:3]

    @property
    def std_m(self) -> np.ndarray:
        return self.std[3:]

    @property
    def undetermined(self) -> tuple:
        return tuple(d for d in self.directions if d.reason == "undetermined")

    @property
    def poorly_determined(self) -> tuple:
        return tuple(d for d in self.directions if d.reason == "poorly determined")

    @property
    def degenerate(self) -> bool:
        """True when the motions leave any direction undetermined or poorly determined
        (even if a prior fixes it; see ``Direction.determined_by_prior``)."""
        return bool(self.directions)

    @property
    def verdict(self) -> str:
        if not self.directions:
            return "determined"
        if self.undetermined:
            return "undetermined"
        return "poorly determined"

    def summary(self) -> str:
        s = self.std
        head = (f"1-sigma rot {_fmt_vec3(s[:3])} deg, trans {_fmt_vec3(s[3:])} m "
                f"(noise {'estimated' if self.noise.estimated else 'given'}: "
                f"{math.degrees(self.noise.sigma_r_rad):.3g} deg, {self.noise.sigma_t_m:.3g} m)")
        if not self.directions:
            return (f"determined within {self.tolerance_deg:g} deg / {self.tolerance_m:g} m; "
                    + head)
        return (f"the motions leave X {self.verdict}: "
                + "; ".join(d.summary() for d in self.directions) + "; " + head)

    def mahalanobis2(self, X_candidate) -> float:
        """``d^T Sigma_det^+ d`` with ``d`` the error of ``X_candidate`` relative to ``X``,
        over the determined directions only."""
        d = pose_error(_check_X(X_candidate, "X_candidate"), self.X)
        B = self.determined_basis
        if B.shape[1] == 0:
            return 0.0
        c = B.T @ d
        S = B.T @ self.covariance_determined @ B
        return float(c @ np.linalg.lstsq(S, c, rcond=None)[0])

    @property
    def dof(self) -> int:
        return int(self.determined_basis.shape[1])

    def inside_region(self, X_candidate, level: float = 0.95) -> bool:
        """True if ``X_candidate`` lies in the ``level`` confidence region of ``X``: its
        squared Mahalanobis distance over the ``k`` determined directions is at most the
        chi-square(k) quantile. Undetermined directions are unconstrained."""
        level = _real("level", level)
        if not level < 1:
            raise ValueError(f"level must be in (0, 1); received {level}")
        if self.dof == 0:
            return True
        from scipy.special import chdtri
        return self.mahalanobis2(X_candidate) <= chdtri(self.dof, 1.0 - level)


def _fmt_vec3(v):
    return "[" + ", ".join("inf" if not math.isfinite(x) else f"{x:.3g}" for x in v) + "]"


# -------------------------------------------------------------------------- main entry
def covariance(C, H, X, alpha: float = 1.0, prior=None, noise=None, weights=None, *,
               tolerance_deg: float = TOLERANCE_DEG, tolerance_m: float = TOLERANCE_M,
               correlation_lag: int = 0, pose_bias=None, pose_pairs=None,
               simulation_rng: np.random.Generator | None = None, pose_error_basis=None,
               pose_simulation=None) -> Uncertainty:
    """Uncertainty of the estimate ``X`` (= ``T_a_b``) from motions ``C``, ``H`` (N,4,4),
    ``C_i X = X H_i``, for the paper's cost at ``alpha`` (1/m) with an optional
    :class:`simcalib.solvers.api.Prior`. ``noise``: a :class:`NoiseModel` or
    ``(sigma_r_rad, sigma_t_m)``; default estimated from the residuals. ``weights``: optional
    (N,) non-negative per-motion weights of the cost. ``pose_bias``: a :class:`PoseBias`
    or ``(cov_a, cov_b)``, the known covariance of each camera's run-constant pose error
    (calibration), added to the covariance and the verdict's information. ``pose_pairs``:
    ``(N, 2)`` datapoint indices (start, end) of each motion when the motions were formed
    from pose streams; if the residuals pass the white pose-noise test the covariance (no
    prior) is the simulated one of :mod:`simcalib.solvers.diagnostics.pose_noise`
    (``simulation_rng``: its generator, default ``default_rng(0)``). ``pose_error_basis``:
    with ``pose_pairs``, the known systematic pose errors of the datapoints ``(Ba, Bb)``
    (``(n_pose, 6, P)`` each, per unit of ``P`` shared standard-normal parameters such as
    the marker map's and the lens calibration's errors; ``pose_noise.check_systematic``):
    without a prior the covariance is then always simulated, with these errors plus white
    pose noise at the level the residuals leave beyond them, and ``pose_bias`` (whose
    run-constant errors the basis already holds) is not added. ``pose_simulation``: a
    :class:`~simcalib.solvers.diagnostics.pose_noise.SimulatedError` of the same motions at
    the same ``alpha`` (``Uncertainty.simulation`` of another estimate) used instead of
    simulating again (one simulation serves every solver of a run). See the module doc."""
    C, H, X, alpha, tol_r, tol_m, noise, bias = _checked_inputs(
        C, H, X, alpha, tolerance_deg, tolerance_m, noise, pose_bias, prior)
    N = C.shape[0]
    w = _check_weights(weights, N)
    with np.errstate(over="ignore", invalid="ignore"):    # a non-usable X raises below
        e, K, Qr, Qt = linear_model(C, H, X)
        L = _translation_scale(C, H, X, tol_m)
        s_r2, s_t2, noise_out, fit, dof_noise = _noise_level(e, Qr, Qt, w, noise, L)
        Q = s_r2 * Qr + s_t2 * Qt                          # (N,6,6), full rank (floors)
    if not (np.isfinite(e).all() and np.isfinite(Q).all()):   # also with the noise given
        raise ValueError(f"residuals of X are not finite; X is not a usable estimate "
                         f"(received X with translation {X[:3, 3].tolist()})")
    # ---- information (alpha-free) and the alpha-cost sandwich
    Linv, Qinv, Kw, Bw = _whitened_rows(H, X, K, Q, w, s_r2, s_t2)
    F, F_noise = _stacked_information(Kw), _stacked_information(Bw)
    T, S, Hs, Ms = _sandwich(C, X, alpha, K, Q, w)
    lag = _check_lag(correlation_lag, N)
    if lag:
        Ms, F = _serial_correlation_corrected(Ms, F, e, K, S, Qinv, w, lag)
    from simcalib.solvers.diagnostics.pose_noise import check_pose_inputs
    pose_pairs, systematic, pose_simulation = check_pose_inputs(
        pose_pairs, pose_error_basis, pose_simulation, N, alpha)
    pose_test = sim = None
    if pose_pairs is not None:
        Ms, pose_test, sim = _pose_simulation(
            C, X, alpha, pose_pairs, Linv, e, Hs, Ms, s_r2, s_t2, w, prior, simulation_rng,
            systematic, fit, pose_simulation)
    sim_bias = None if sim is None else sim.bias
    Sig_bias, Ms, F = _with_pose_bias(X, bias, Hs, Ms, F,
                                      systematic is not None and sim_bias is not None)
    Hs, Ms, F_prior, prior_cov = _with_prior(X, prior, T, Q, alpha, Hs, Ms)
    # ---- tolerance-scaled coordinates
    dsc = np.array([tol_r] * 3 + [tol_m] * 3)              # delta = dsc * delta_tilde
    Ft, Fp_t, Ht, Mt = (A * np.outer(dsc, dsc) for A in (F, F_prior, Hs, Ms))
    Ftot = Ft + Fp_t
    range_sc = np.array([_UNDETERMINED_ROT_RAD] * 3 + [L] * 3) / dsc   # range in tol units
    # ---- undetermined by the data: information not above what the noise alone makes
    null = _noise_null_test(Kw, Bw, dsc, lag, dof_noise)
    Ud = _data_undetermined(null, Ft, range_sc)
    Bd = _complement(Ud)
    # ---- undetermined in total: within Ud only the prior informs; the range rule on all
    Ut = _total_undetermined(Ud, Fp_t, Ftot, range_sc)
    Bt = _complement(Ut)
    W, Blk = _counting_information(Bd, Ud, Ft, Fp_t)
    # ---- covariance of the estimate: the sandwich on the determined subspace Bt
    Sig_b, Hb_inv = _restricted_sandwich(Bt, Ht, Mt)        # None, None: Bt is empty
    step = None if prior is not None or Sig_b is None else _minimiser_step(
        C, H, X, alpha, w, K, S, e, dsc, Bt, Hb_inv, sim_bias)
    cov_t, offset_t = _with_offset(Bt, Sig_b, step)
    cov_det, cov = _reported_covariances(cov_t, dsc, Ut)
    Bp = _physical_basis(Bt, dsc)
    # ---- directions from the data information, then those only this estimate leaves
    raw = _data_directions(Ud, Bd, Ft)
    sp = [None if prior is None else _std_with_prior(u, Ut, W, Bt, Blk) for u, _, _ in raw]
    dirs = [_data_direction(*r, dsc, tol_r, tol_m, s_p) for r, s_p in zip(raw, sp)]
    dirs += _estimate_directions(cov_t, raw, dsc, tol_r, tol_m)
    dirs.sort(key=lambda d: d.reason != "undetermined")
    return Uncertainty(X=X, covariance=cov, covariance_determined=cov_det,
                       determined_basis=Bp, information=F, prior_covariance=prior_cov,
                       noise=noise_out, alpha=alpha, tolerance_deg=math.degrees(tol_r),
                       tolerance_m=tol_m, directions=tuple(dirs), translation_scale_m=L,
                       n_motions=N, offset=offset_t * dsc, bias_covariance=Sig_bias,
                       noise_information=F_noise, information_ratio=null.ratio,
                       ratio_threshold=null.threshold, pose_noise_test=pose_test,
                       simulated_bias=sim_bias,
                       systematic_parameters=0 if sim is None else sim.systematic_parameters,
                       white_pose_noise=None if sim is None else sim.white, simulation=sim,
                       method="pose_simulation" if sim_bias is not None else "sandwich")


# ------------------------------------------------------------------- covariance steps
def _checked_inputs(C, H, X, alpha, tolerance_deg, tolerance_m, noise, pose_bias, prior):
    """Validated ``(C, H, X, alpha, tol_r, tol_m, noise, bias)`` of :func:`covariance`."""
    C = check_transforms(C, "C", min_count=2)
    H = check_transforms(H, "H", min_count=2)
    if C.shape != H.shape:
        raise ValueError(f"C and H must hold the same number of motions; received "
                         f"{C.shape[0]} and {H.shape[0]}")
    X = _check_X(X)
    alpha = _real("alpha", alpha)
    tol_r = math.radians(_real("tolerance_deg", tolerance_deg))
    tol_m = _real("tolerance_m", tolerance_m)
    noise = _check_noise(noise)
    bias = check_pose_bias(pose_bias)
    if prior is not None and not all(hasattr(prior, k) for k in ("X", "a", "b")):
        raise TypeError(f"prior must be a simcalib.Prior or None; received "
                        f"{type(prior).__name__}")
    return C, H, X, alpha, tol_r, tol_m, noise, bias


def _translation_scale(C, H, X, tol_m) -> float:
    """Translation scale ``L`` of the data (units follow the input)."""
    return float(max(np.sqrt(np.mean(np.sum(C[:, :3, 3] ** 2, axis=1))),
                     np.sqrt(np.mean(np.sum(H[:, :3, 3] ** 2, axis=1))),
                     np.linalg.norm(X[:3, 3]), tol_m))


def _noise_level(e, Qr, Qt, w, noise, L):
    """``(s_r2, s_t2, noise_out, fit, dof_noise)``: fitted or given noise variances, floors in."""
    n_eff = float(w.sum() ** 2 / np.sum(w * w))
    # degrees of freedom of the fitted rotation noise (3 residual components per motion)
    dof_noise = math.inf if noise is not None else max(3.0 * (n_eff - 1.0), 1.0)
    if noise is None:
        dof = n_eff / max(n_eff - 1.0, 1.0)
        wn = w / w.sum()
        rot2 = np.sum(wn * np.sum(e[:, :3] ** 2, axis=1)) * dof
        tr2 = np.sum(wn * np.sum(e[:, 3:] ** 2, axis=1)) * dof
        qr_rot = np.sum(wn * np.trace(Qr[:, :3, :3], axis1=1, axis2=2))
        qr_tr = np.sum(wn * np.trace(Qr[:, 3:, 3:], axis1=1, axis2=2))
        qt_tr = np.sum(wn * np.trace(Qt[:, 3:, 3:], axis1=1, axis2=2))
        s_r2 = rot2 / qr_rot
        # rotation noise leaks into tau through R_Ci' t_X; at least 10 % of the translation
        # residual is attributed to translation noise (a wrong X with a large t_X would
        # otherwise explain all of it by rotation noise and claim a perfect translation)
        s_t2 = max(tr2 - s_r2 * qr_tr, 0.1 * tr2) / qt_tr
        if not (math.isfinite(s_r2) and math.isfinite(s_t2)):
            raise ValueError("residuals of X are not finite; X is not a usable estimate")
        noise_out = NoiseModel(math.sqrt(s_r2), math.sqrt(s_t2), estimated=True)
        fit = (qr_rot, qr_tr, qt_tr)
    else:
        s_r2, s_t2 = noise.sigma_r_rad ** 2, noise.sigma_t_m ** 2
        noise_out = noise
        fit = None
    s_r2 += ROTATION_FLOOR_RAD ** 2
    s_t2 += (TRANSLATION_FLOOR_REL * L) ** 2
    return s_r2, s_t2, noise_out, fit, dof_noise


def _whitened_rows(H, X, K, Q, w, s_r2, s_t2):
    """``(Linv, Qinv, Kw, Bw)``: whitening of ``Q`` and the whitened data and null rows."""
    # whitened rows: Kw_i = sqrt(w_i) L_i^-1 K_i (Q_i = L_i L_i^T), F = sum Kw^T Kw; Bw: the
    # same for the derivatives of K_i w.r.t. the noise of H_i, scaled by its std (the null)
    Linv = np.linalg.inv(np.linalg.cholesky(0.5 * (Q + np.swapaxes(Q, -1, -2))))
    Qinv = np.swapaxes(Linv, -1, -2) @ Linv
    sw = np.sqrt(w)
    Kw = (Linv @ K) * sw[:, None, None]
    std_xi = np.sqrt(np.array([s_r2 / 3.0] * 3 + [s_t2] * 3))
    Bw = ((Linv[:, None] @ noise_jacobians(H, X))
          * (sw[:, None, None, None] * std_xi[None, :, None, None]))
    return Linv, Qinv, Kw, Bw


def _stacked_information(Aw) -> np.ndarray:
    """``A^T A`` (6x6) of the whitened rows ``Aw`` stacked into one (-1, 6) matrix ``A``."""
    Af = Aw.reshape(-1, 6)
    return Af.T @ Af


def _sandwich(C, X, alpha, K, Q, w):
    """``(T, S, Hs, Ms)``: DQ map, its ``T^T T``, and the bread and meat of the alpha cost."""
    T = _dq_map(C, X, alpha)
    S = np.einsum("nki,nkj->nij", T, T)                    # (N,6,6)
    Hs = np.einsum("n,nki,nkl,nlj->ij", w, K, S, K)
    SQS = S @ Q @ S
    Ms = np.einsum("n,nki,nkl,nlj->ij", w * w, K, SQS, K)
    return T, S, Hs, Ms


def _serial_correlation_corrected(Ms, F, e, K, S, Qinv, w, lag):
    """``(Ms, F)`` corrected for the serial correlation of motions sharing poses up to ``lag``."""
    # motions in time order that share poses (pairs (k, k + step) of one pose stream):
    # their noise is correlated up to lag = step. The model meat is rescaled, per
    # direction, by the ratio of the empirical meat with the cross terms up to the lag
    # (truncated kernel) to the one without (serial-correlation, HAC-type correction).
    Ms = _rescale_meat(Ms, *_score_meats(np.einsum("n,nki,nkl,nl->ni", w, K, S, e), lag))
    # the same correction of the alpha-free information (efficient weighting: the
    # meat is F itself, so the information becomes F Mc^-1 F)
    Fc = _rescale_meat(F, *_score_meats(np.einsum("n,nki,nkl,nl->ni", w, K, Qinv, e), lag))
    F = F @ _sym_inv(Fc) @ F
    F = 0.5 * (F + F.T)
    return Ms, F


def _with_pose_bias(X, bias, Hs, Ms, F, in_simulation):
    """``(Sig_bias, Ms, F)``: the calibration bias added to the meat and the information."""
    # none given, or its run-constant errors already drawn by a systematic simulation
    if bias is None or bias.is_zero or in_simulation:
        return None, Ms, F
    Sig_bias = pose_bias_covariance(X, bias.cov_a, bias.cov_b)
    Ms = Ms + Hs @ Sig_bias @ Hs
    F = _woodbury_information(F, Sig_bias)
    return Sig_bias, Ms, F


def _with_prior(X, prior, T, Q, alpha, Hs, Ms):
    """``(Hs, Ms, F_prior, prior_cov)`` with the prior's pseudo-measurements (if any) added."""
    if prior is None:
        return Hs, Ms, np.zeros((6, 6)), None
    Ja, Jb = _prior_jacobians(X, prior)
    TQT = T @ Q @ np.swapaxes(T, -1, -2)
    nu_a = float(np.mean(np.trace(TQT[:, :4, :4], axis1=1, axis2=2)) / 3.0)
    nu_b = float(np.mean(np.trace(TQT[:, 4:, 4:], axis1=1, axis2=2)) / 3.0) / alpha**2
    A = Ja.T @ Ja
    Bm = Jb.T @ Jb
    F_prior = prior.a * A / nu_a + prior.b * Bm / nu_b
    Hs = Hs + prior.a * A + prior.b * Bm
    Ms = Ms + prior.a * nu_a * A + prior.b * nu_b * Bm
    return Hs, Ms, F_prior, _pinv_cov(F_prior)


def _range_ratio(U, sig, range_sc) -> np.ndarray:
    """1-sigma along the columns of U relative to the range of rotation/translation."""
    return sig * np.sqrt(np.sum((U / range_sc[:, None]) ** 2, axis=0))


def _modes(Fm, range_sc):
    """``(lam, U, sig, range ratio)``: eigen-directions of ``Fm`` and their 1-sigma."""
    lam, U = np.linalg.eigh(0.5 * (Fm + Fm.T))
    sig = np.where(lam > 0, 1.0 / np.sqrt(np.maximum(lam, 1e-300)), np.inf)
    return lam, U, sig, _range_ratio(U, sig, range_sc)


def _data_undetermined(null, Ft, range_sc) -> np.ndarray:
    """Basis ``Ud`` of the directions the data leave to the noise or beyond the range."""
    _, U_d, _, rr_d = _modes(Ft, range_sc)
    return _span([null.directions[:, null.undetermined], U_d[:, rr_d > 1.0]])


def _total_undetermined(Ud, Fp_t, Ftot, range_sc) -> np.ndarray:
    """Basis ``Ut`` of the directions neither the prior (within ``Ud``) nor all determine."""
    if Ud.shape[1]:
        lam_p, V_p = np.linalg.eigh(0.5 * (Ud.T @ Fp_t @ Ud + (Ud.T @ Fp_t @ Ud).T))
        sig_p = np.where(lam_p > 0, 1.0 / np.sqrt(np.maximum(lam_p, 1e-300)), np.inf)
        Up = Ud @ V_p
        still = Up[:, _range_ratio(Up, sig_p, range_sc) > 1.0]
    else:
        still = np.zeros((6, 0))
    _, U_tt, _, rr_t = _modes(Ftot, range_sc)
    return _span([still, U_tt[:, rr_t > 1.0]])


def _counting_information(Bd, Ud, Ft, Fp_t):
    """``(W, Blk)``: basis ``[Bd, Ud]`` and the prior plus the data outside ``Ud`` in it."""
    # information that counts, in the basis W = [Bd, Ud]: data (outside Ud) plus prior
    W = np.concatenate([Bd, Ud], axis=1)
    kb = Bd.shape[1]
    Blk = W.T @ Fp_t @ W
    Blk[:kb, :kb] += Bd.T @ Ft @ Bd
    return W, Blk


def _restricted_sandwich(Bt, Ht, Mt):
    """``(Sig_b, Hb_inv)``: the sandwich restricted to ``Bt`` (PSD), its bread inverse."""
    if not Bt.shape[1]:
        return None, None
    Hb = Bt.T @ Ht @ Bt
    Mb = Bt.T @ Mt @ Bt
    Hb_inv = _sym_inv(Hb)
    Sig_b = Hb_inv @ Mb @ Hb_inv
    lb, Vb = np.linalg.eigh(0.5 * (Sig_b + Sig_b.T))
    Sig_b = (Vb * np.clip(lb, 0.0, None)) @ Vb.T        # PSD despite rounding
    return Sig_b, Hb_inv


def _minimiser_step(C, H, X, alpha, w, K, S, e, dsc, Bt, Hb_inv, sim_bias) -> np.ndarray:
    """Step from ``X`` to the alpha-cost minimiser in ``Bt`` coordinates (tol units)."""
    # X need not be the minimiser of the alpha cost (daniilidis, opencv, dq2steps,
    # an early stop): its Gauss-Newton offset from the minimiser is a bias of X
    # that the sandwich does not see; added as step step^T (mean squared error).
    if sim_bias is not None:   # the exact offset (the linearised one errs by
        # terms of second order in the noise, here as large as the bias itself)
        from simcalib.solvers.diagnostics.pose_noise import minimiser_offset
        return Bt.T @ (minimiser_offset(C, H, X, alpha, w) / dsc)
    g = np.einsum("n,nki,nkl,nl->i", w, K, S, e) * dsc
    return -Hb_inv @ (Bt.T @ g)


def _with_offset(Bt, Sig_b, step):
    """``(cov_t, offset_t)`` (tol units): ``Sig_b`` plus ``step step^T``, back from ``Bt``."""
    if Sig_b is None:
        return np.zeros((6, 6)), np.zeros(6)
    if step is None:
        return Bt @ Sig_b @ Bt.T, np.zeros(6)
    Sig_b = Sig_b + np.outer(step, step)
    return Bt @ Sig_b @ Bt.T, Bt @ step


def _reported_covariances(cov_t, dsc, Ut):
    """``(cov_det, cov)``: the finite part, and it with ``inf`` on the axes touching ``Ut``."""
    cov_det = cov_t * np.outer(dsc, dsc)
    cov_det = 0.5 * (cov_det + cov_det.T)
    cov = cov_det.copy()
    if Ut.shape[1]:
        touched = np.linalg.norm(Ut, axis=1) > _PURE
        cov[touched, :] = 0.0
        cov[:, touched] = 0.0
        cov[touched, touched] = np.inf
    return cov_det, cov


def _physical_basis(Bt, dsc) -> np.ndarray:
    """Determined basis orthonormalised in delta coordinates (6, k)."""
    if Bt.shape[1]:
        Bp, _ = np.linalg.qr(Bt * dsc[:, None])
    else:
        Bp = np.zeros((6, 0))
    return Bp


def _std_with_prior(u, Ut, W, Bt, Blk) -> float:
    """1-sigma (tol units) along u from the information that counts; inf if in Ut."""
    if Ut.shape[1] and np.linalg.norm(Ut.T @ u) > _PURE:
        return math.inf
    Bb = W.T @ Bt
    Sb = Bb @ _sym_inv(Bb.T @ Blk @ Bb) @ Bb.T
    ew = W.T @ u
    return math.sqrt(max(float(ew @ Sb @ ew), 0.0))


def _data_directions(Ud, Bd, Ft) -> list:
    """``(u, reason, 1-sigma tol units)`` of the undetermined and poorly determined directions."""
    dirs = []
    if Ud.shape[1]:                                       # undetermined: basis of Ud
        _, Vu = np.linalg.eigh(0.5 * (Ud.T @ Ft @ Ud + (Ud.T @ Ft @ Ud).T))
        for u in (Ud @ Vu).T:
            dirs.append((u, "undetermined", math.inf))
    if Bd.shape[1]:                                       # poorly determined: outside Ud
        lb_, Vb_ = np.linalg.eigh(0.5 * (Bd.T @ Ft @ Bd + (Bd.T @ Ft @ Bd).T))
        for k in range(Bd.shape[1]):
            s = 1.0 / math.sqrt(lb_[k]) if lb_[k] > 0 else math.inf
            if s > 1.0:
                dirs.append((Bd @ Vb_[:, k], "poorly determined", s))
    return dirs


def _stds_along(u, s, tol_r, tol_m) -> tuple[float, float]:
    """(deg, m) 1-sigma of u's rotation / translation parts at ``s`` (inf: parts over 5 %)."""
    nw, nt = np.linalg.norm(u[:3]), np.linalg.norm(u[3:])
    tot = math.hypot(nw, nt)
    if math.isfinite(s):
        return math.degrees(s * tol_r * nw), s * tol_m * nt
    return (math.inf if nw > _PURE * tot else 0.0), (math.inf if nt > _PURE * tot else 0.0)


def _data_direction(u, reason, s, dsc, tol_r, tol_m, st) -> Direction:
    """The :class:`Direction` of ``u`` at 1-sigma ``s``, ``st`` with the prior (None: none)."""
    sdeg, sm = _stds_along(u, s, tol_r, tol_m)
    if st is not None:
        by_prior = st <= 1.0
        swd, swm = _stds_along(u, st, tol_r, tol_m)
    else:
        by_prior, swd, swm = False, sdeg, sm
    return dataclasses.replace(_describe(u, dsc, reason, sdeg, sm, swd, swm, by_prior),
                               with_prior=st is not None)


def _estimate_directions(cov_t, raw, dsc, tol_r, tol_m) -> list:
    """Directions this estimate leaves beyond the tolerance that the motions would not."""
    # directions this estimate (covariance of the alpha-cost minimiser) leaves beyond the
    # tolerance although the information would allow better (a poorly chosen alpha or an
    # estimator that ignores part of the data); ``raw``: those already flagged
    flagged = np.array([u for u, _, _ in raw]).reshape(-1, 6).T
    dirs = []
    le, Ve = np.linalg.eigh(0.5 * (cov_t + cov_t.T))
    for k in range(6):
        if not le[k] > 1.0:
            continue
        u = Ve[:, k]
        if flagged.shape[1] and np.linalg.norm(u - flagged @ (flagged.T @ u)) < 0.5:
            continue
        sg = math.sqrt(le[k])
        sdeg = math.degrees(sg * tol_r * np.linalg.norm(u[:3]))
        sm = sg * tol_m * np.linalg.norm(u[3:])
        d = _describe(u, dsc, "poorly determined", sdeg, sm, sdeg, sm, False)
        dirs.append(dataclasses.replace(d, description=d.description + " by this estimate "
                                        "(the motions would determine it better)"))
        flagged = np.concatenate([flagged, u[:, None]], axis=1)
    return dirs


def _pose_simulation(C, X, alpha, pose_pairs, Linv, e, Hs, Ms, s_r2, s_t2, w, prior, rng,
                     systematic=None, fit=None, shared=None):
    """``(Ms, test, sim)``: the meat replaced by ``Hs (S + b b^T) Hs`` from the pose-noise
    simulation (``sim``, a ``pose_noise.SimulatedError``) when the test accepts white pose
    noise or a systematic basis explains the correlation (and there is no prior, whose cost
    the simulation does not model); otherwise ``Ms`` unchanged and ``sim`` None. With
    ``systematic`` the white level is what the residuals leave beyond the systematic
    errors' expected share (``fit``: the noise fit's ``(qr_rot, qr_tr, qt_tr)``; None when
    the noise was given). ``shared``: a SimulatedError of the same motions at the same
    alpha, used instead of simulating. ``pose_pairs``, ``systematic``, ``shared`` as
    checked by :func:`~simcalib.solvers.diagnostics.pose_noise.check_pose_inputs`."""
    from simcalib.solvers.diagnostics.pose_noise import (SimulatedError, simulate_error,
                                                          systematic_residual_power,
                                                          white_noise_test)
    P = pose_pairs
    test = white_noise_test(np.einsum("nij,nj->ni", Linv, e), P)
    if prior is not None or not (test.accepted or systematic is not None
                                 or shared is not None):
        return Ms, test, None
    if shared is not None:
        sim = shared
    else:
        if systematic is not None and fit is not None:
            qr_rot, qr_tr, qt_tr = fit
            rot2_s, tr2_s = systematic_residual_power(C, X, alpha, P, systematic, weights=w)
            sr2_s = rot2_s / qr_rot
            st2_s = max(tr2_s - sr2_s * qr_tr, 0.0) / qt_tr
            s_r2 = max(s_r2 - sr2_s, WHITE_SHARE_FLOOR * s_r2)
            s_t2 = max(s_t2 - st2_s, WHITE_SHARE_FLOOR * s_t2)
        white = (math.sqrt(s_r2 / 2.0), math.sqrt(s_t2 / 2.0))
        out = simulate_error(C, X, alpha, P, *white, weights=w, rng=rng, systematic=systematic)
        if out is None:
            return Ms, test, None
        sim = SimulatedError(out[0], out[1], float(alpha), white,
                             0 if systematic is None else int(systematic[0].shape[2]))
    Ms = Hs @ (sim.covariance + np.outer(sim.bias, sim.bias)) @ Hs
    return 0.5 * (Ms + Ms.T), test, sim


#: with a systematic pose-error basis, the white pose noise keeps at least this share of the
#: fitted noise variance (the basis never explains all of the residuals)
WHITE_SHARE_FLOOR = 0.05


def _check_lag(lag, n) -> int:
    if isinstance(lag, bool) or not isinstance(lag, (int, np.integer)) or lag < 0:
        raise ValueError(f"correlation_lag must be an integer >= 0; received {lag!r}")
    return int(min(lag, max(n - 1, 0)))



def _score_meats(g, lag):
    """``(M0, Mh)`` of the per-motion scores ``g`` (N, 6): the meat without and with the
    cross terms up to ``lag`` (truncated kernel)."""
    M0 = g.T @ g
    Mh = M0.copy()
    for lg in range(1, lag + 1):
        cross = g[:-lg].T @ g[lg:]
        Mh += cross + cross.T
    return M0, Mh

def _rescale_meat(Ms, M0, Mh):
    """``Ms`` with its spectrum rescaled, direction by direction (eigenvectors of ``M0``
    whitened by ``Ms``), by the ratio of the serial-correlated empirical meat ``Mh`` to the
    uncorrelated one ``M0``; ratios clipped to [0.05, 20]."""
    lam, V = np.linalg.eigh(0.5 * (Ms + Ms.T))
    lam = np.maximum(lam, 1e-300)
    W = V / np.sqrt(lam)                                   # whitening: W^T Ms W = I
    A0 = W.T @ M0 @ W
    Ah = W.T @ Mh @ W
    l0, U0 = np.linalg.eigh(0.5 * (A0 + A0.T))
    ratio = np.clip(np.einsum("ki,kl,li->i", U0, Ah, U0) / np.maximum(l0, 1e-300), 0.05, 20.0)
    Wi = V * np.sqrt(lam)                                  # inverse whitening
    R = U0 @ np.diag(ratio) @ U0.T
    out = Wi @ R @ Wi.T
    return 0.5 * (out + out.T)


def _sym_inv(A):
    lam, V = np.linalg.eigh(0.5 * (A + A.T))
    lam_inv = np.where(lam > 1e-300, 1.0 / np.maximum(lam, 1e-300), 0.0)
    return (V * lam_inv) @ V.T


def _pinv_cov(F):
    lam, V = np.linalg.eigh(0.5 * (F + F.T))
    lam_inv = np.where(lam > 1e-14 * max(lam[-1], 1e-300), 1.0 / np.maximum(lam, 1e-300), 0.0)
    return (V * lam_inv) @ V.T


def _describe(u, dsc, reason, sdeg, sm, swd, swm, by_prior) -> Direction:
    """Words for eigen-direction ``u`` (tolerance coordinates) in camera-a frame."""
    w, t = u[:3], u[3:]
    nw, nt = np.linalg.norm(w), np.linalg.norm(t)
    tot = math.hypot(nw, nt)
    ax = w / nw if nw > _PURE * tot else np.zeros(3)
    td = t / nt if nt > _PURE * tot else np.zeros(3)
    if not td.any():
        kind, desc = "rotation", f"rotation of X about {_fmt_vec(ax)} (camera-a frame)"
    elif not ax.any():
        kind, desc = "translation", f"translation of X along {_fmt_vec(td)} (camera-a frame)"
    else:
        kind = "coupled"
        desc = (f"rotation of X about {_fmt_vec(ax)} coupled with translation along "
                f"{_fmt_vec(td)} (camera-a frame)")
    return Direction(reason, kind, ax, td, float(sdeg), float(sm), float(swd), float(swm),
                     bool(by_prior), desc)


def covariance_batch(C, H, X, alpha=1.0, prior=None, noise=None, *,
                     tolerance_deg: float = TOLERANCE_DEG, tolerance_m: float = TOLERANCE_M,
                     weights=None, pose_bias=None) -> tuple:
    """:func:`covariance` per problem of a batch: ``C``, ``H`` (B, N, 4, 4), ``X`` (B, 4, 4),
    ``alpha`` scalar or (B,), ``weights`` None or (B, N). Problems whose ``X`` is not a finite rigid transform (failed
    solves) give None."""
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    if C.ndim != 4 or X.ndim != 3 or X.shape[0] != C.shape[0]:
        raise ValueError(f"C, H must be (B, N, 4, 4) and X (B, 4, 4); received {C.shape}, "
                         f"{H.shape}, {X.shape}")
    alphas = np.broadcast_to(np.asarray(alpha, dtype=np.float64), (C.shape[0],))
    out = []
    for b in range(C.shape[0]):
        if not np.isfinite(X[b]).all():
            out.append(None)
            continue
        try:
            out.append(covariance(C[b], H[b], X[b], float(alphas[b]), prior, noise,
                                  None if weights is None else weights[b],
                                  tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
                                  pose_bias=pose_bias))
        except ValueError:
            out.append(None)
    return tuple(out)


# ------------------------------------------------------------------------------- alpha
@dataclass(frozen=True)
class AlphaChoice:
    """``alpha`` (1/m) chosen from the data, ``how`` it was chosen, the residual noise levels
    it used and the estimate it was computed at (``X_initial``, at ``alpha_initial``)."""
    alpha: float
    how: str
    sigma_r_rad: float
    sigma_t_m: float
    alpha_initial: float
    candidates: np.ndarray | None = None
    predicted: np.ndarray | None = None


ALPHA_RANGE = (1e-2, 10 ** 1.7)
ALPHA_CHOICES = ("noise_ratio", "min_predicted_error")


def _predicted_errors(C, H, X, Q, grid, dsc, basis):
    """Predicted squared error ``tr(Sigma_B(alpha))`` (tolerance units) of the alpha-cost
    minimiser for every alpha of ``grid``, restricted to the subspace spanned by ``basis``
    (6 x k, tolerance coordinates, orthonormal; the error along its complement held fixed,
    as in :func:`covariance`). ``S(alpha) = S_r + alpha^2 S_d``, so ``H`` and ``M`` are
    polynomials in ``alpha^2``: one pass over the motions for the whole grid."""
    _, K, _, _ = linear_model(C, H, X)
    T1 = _dq_map(C, X, 1.0)
    Kt = K * dsc                                           # d e / d delta_tilde
    Tr, Td = T1[:, :4], T1[:, 4:]
    Sr = np.einsum("nki,nkj->nij", Tr, Tr)
    Sd = np.einsum("nki,nkj->nij", Td, Td)
    Kb = Kt @ basis                                        # (N, 6, k)
    Hr = np.einsum("nki,nkl,nlj->ij", Kb, Sr, Kb)
    Hd = np.einsum("nki,nkl,nlj->ij", Kb, Sd, Kb)
    Mrr = np.einsum("nki,nkl,nlj->ij", Kb, Sr @ Q @ Sr, Kb)
    Mrd = np.einsum("nki,nkl,nlj->ij", Kb, Sr @ Q @ Sd, Kb)
    Mdd = np.einsum("nki,nkl,nlj->ij", Kb, Sd @ Q @ Sd, Kb)
    a2 = np.asarray(grid, dtype=np.float64)[:, None, None] ** 2
    Hs = Hr + a2 * Hd
    Ms = Mrr + a2 * (Mrd + np.swapaxes(Mrd, -1, -2)) + a2 ** 2 * Mdd
    pred = np.empty(len(grid))
    for j in range(len(grid)):
        Hi = _sym_inv(Hs[j])
        pred[j] = np.trace(Hi @ Ms[j] @ Hi)
    return pred


def choose_alpha(C, H, X, alpha_initial: float = 1.0, how: str = "noise_ratio", *,
                 tolerance_deg: float = TOLERANCE_DEG, tolerance_m: float = TOLERANCE_M,
                 alpha_range=ALPHA_RANGE, num: int = 41) -> AlphaChoice:
    """Choose alpha from the residuals of an initial estimate ``X`` (e.g. dqopt at
    ``alpha_initial``), never from a ground truth.

    ``how="noise_ratio"`` (default): inverse-variance weighting of the cost (8). Its rotation
    residual has per-component variance ``var_r`` and its dual residual ``var_d``; equal
    weights per unit noise need ``alpha^2 = var_r / var_d``, computed from the noise model
    fitted to the residuals (:func:`covariance`).
    ``how="min_predicted_error"``: the alpha of a log grid of ``num`` values over
    ``alpha_range`` minimising the predicted mean squared error of the estimate over the
    **determined** directions, in tolerance units: ``tr(Sigma_B(alpha))``, ``Sigma_B`` the
    sandwich covariance of the alpha-cost minimiser restricted to the determined subspace
    ``B`` of the alpha-free information (as :attr:`Uncertainty.covariance_determined`,
    without the offset term), with the noise fitted to the residuals of ``X``. Undetermined
    directions are left out: their error is arbitrary at every alpha and their predicted
    variance (numerical floor) would otherwise decide the choice. With no determined
    direction it falls back to ``noise_ratio`` (and says so in ``how``).
    Both measure alike against the ground-truth oracle (docs/uncertainty.md, "alpha from the
    data"). The result is clipped to ``alpha_range`` (default: the paper's grid); the choice
    does not depend on the length unit when ``alpha_range`` and ``tolerance_m`` follow it.
    """
    if how not in ALPHA_CHOICES:
        raise ValueError(f"unknown alpha choice {how!r}; allowed: {', '.join(ALPHA_CHOICES)}")
    if isinstance(num, bool) or not isinstance(num, (int, np.integer)) or num < 2:
        raise ValueError(f"num must be an integer >= 2; received {num!r}")
    u = covariance(C, H, X, alpha_initial, tolerance_deg=tolerance_deg, tolerance_m=tolerance_m)
    lo, hi = (_real("alpha_range[0]", alpha_range[0]), _real("alpha_range[1]", alpha_range[1]))
    if not lo < hi:
        raise ValueError(f"alpha_range must be (low, high) with low < high; received "
                         f"{tuple(alpha_range)!r}")
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    _, _, Qr, Qt = linear_model(C, H, X)
    L = u.translation_scale_m
    Q = ((u.noise.sigma_r_rad ** 2 + ROTATION_FLOOR_RAD ** 2) * Qr
         + (u.noise.sigma_t_m ** 2 + (TRANSLATION_FLOOR_REL * L) ** 2) * Qt)
    dsc = np.array([math.radians(u.tolerance_deg)] * 3 + [u.tolerance_m] * 3)
    Bp = u.determined_basis
    basis = np.linalg.qr(Bp / dsc[:, None])[0] if Bp.shape[1] else np.zeros((6, 0))
    if how == "noise_ratio" or basis.shape[1] == 0:
        T1 = _dq_map(C, X, 1.0)
        TQT = T1 @ Q @ np.swapaxes(T1, -1, -2)
        var_r = float(np.mean(np.trace(TQT[:, :4, :4], axis1=1, axis2=2)))
        var_d = float(np.mean(np.trace(TQT[:, 4:, 4:], axis1=1, axis2=2)))
        a = math.sqrt(var_r / var_d) if var_d > 0 else hi
        a = float(np.clip(a, lo, hi))
        why = "" if how == "noise_ratio" else (" (min_predicted_error fell back to it: no "
                                                "direction is determined)")
        return AlphaChoice(a, "noise_ratio: alpha = sqrt(var(rotation residual) / "
                           "var(dual residual)) of the noise fitted at alpha_initial" + why,
                           u.noise.sigma_r_rad, u.noise.sigma_t_m, float(alpha_initial))
    grid = np.logspace(math.log10(lo), math.log10(hi), int(num))
    pred = _predicted_errors(C, H, X, Q, grid, dsc, basis)
    j = int(np.argmin(pred))
    return AlphaChoice(float(grid[j]), f"min_predicted_error: argmin over a log grid of the "
                       f"predicted squared error of the {basis.shape[1]} determined directions "
                       "in tolerance units (noise fitted at alpha_initial)",
                       u.noise.sigma_r_rad, u.noise.sigma_t_m, float(alpha_initial), grid, pred)


# --------------------------------------------------------------------------- bootstrap
def bootstrap_covariance(C, H, X, solve_fn, n_boot: int = 200,
                         rng: np.random.Generator | None = None) -> np.ndarray:
    """Bootstrap covariance (6x6) of ``delta`` around ``X``: ``n_boot`` resamplings of the
    motions with replacement, each solved by ``solve_fn(C_b, H_b) -> X_b`` (a callable, or
    ``solve_fn(Cb, Hb)`` batched over ``(n_boot, N, 4, 4)`` if it accepts 4-D input).
    Failed (non-finite) resamples are dropped. ``rng``: explicit Generator (required)."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 2:
        raise ValueError(f"n_boot must be an integer >= 2; received {n_boot!r}")
    C = check_transforms(C, "C", min_count=2)
    H = check_transforms(H, "H", min_count=2)
    X = _check_X(X)
    N = C.shape[0]
    idx = rng.integers(0, N, size=(int(n_boot), N))
    Xb = np.asarray(solve_fn(C[idx], H[idx]), dtype=np.float64)
    if Xb.shape != (int(n_boot), 4, 4):
        raise ValueError(f"solve_fn must return (n_boot, 4, 4) transforms; received {Xb.shape}")
    ok = np.isfinite(Xb).all(axis=(1, 2))
    if ok.sum() < 2:
        raise ValueError("fewer than 2 bootstrap resamples were solved")
    d = pose_error(Xb[ok], X)
    d = d - d.mean(axis=0)
    return d.T @ d / (d.shape[0] - 1)
