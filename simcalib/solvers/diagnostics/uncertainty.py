"""Uncertainty of a hand-eye estimate, the degeneracy verdict that follows from it, and a
data-driven choice of alpha. Pure numpy/scipy; no solver imports (any estimate ``X`` works).

Error convention: ``delta = (omega, v)`` with ``omega`` the rotation vector of
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
  (:func:`simcalib.sources.vision.error_model.calibration_pose_bias`).
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
  uncertainty_inputs.pose_error_basis`) and simulates once per run: the other solvers' headlines
  reuse the simulation (``pose_simulation=``, ``Uncertainty.simulation``), each adding its own
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

**Noise-made information.** ``F`` is evaluated at the *measured* motions.
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

import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import (
    check_transforms,
)


from simcalib.solvers.diagnostics.inputs import (  # noqa: F401
    NULL_LEVEL,
    NoiseModel,
    PoseBias,
    ROTATION_FLOOR_RAD,
    TOLERANCE_DEG,
    TOLERANCE_M,
    TRANSLATION_FLOOR_REL,
    _PURE,
    _UNDETERMINED_ROT_RAD,
    _check_X,
    _check_cov6,
    _check_noise,
    _check_weights,
    _coerce_pair,
    _real,
    _woodbury_information,
    check_pose_bias,
    check_tolerances,
    pose_bias_covariance,
    pose_bias_jacobians,
    pose_error,
)
from simcalib.solvers.diagnostics.linear_model import (  # noqa: F401
    _NullTest,
    _complement,
    _dq_map,
    _noise_null_test,
    _prior_jacobians,
    _span,
    linear_model,
    linear_model_jacobians,
    noise_covariance_parts,
    noise_jacobians,
)
from simcalib.solvers.diagnostics.results import (  # noqa: F401
    DIRECTION_STATES,
    Direction,
    Uncertainty,
    _fmt_std,
    _fmt_vec,
    _fmt_vec3,
    direction_sigma,
    direction_state,
)
from simcalib.solvers.diagnostics.covariance_steps import (  # noqa: F401
    WHITE_SHARE_FLOOR,
    _check_lag,
    _checked_inputs,
    _counting_information,
    _data_direction,
    _data_directions,
    _data_undetermined,
    _describe,
    _estimate_directions,
    _minimiser_step,
    _modes,
    _noise_level,
    _physical_basis,
    _pinv_cov,
    _pose_simulation,
    _range_ratio,
    _reported_covariances,
    _rescale_meat,
    _restricted_sandwich,
    _sandwich,
    _score_meats,
    _serial_correlation_corrected,
    _stacked_information,
    _std_with_prior,
    _stds_along,
    _sym_inv,
    _total_undetermined,
    _translation_scale,
    _whitened_rows,
    _with_offset,
    _with_pose_bias,
    _with_prior,
)

__all__ = [
    "linear_model", "linear_model_jacobians", "noise_covariance_parts", "NoiseModel", "PoseBias", "pose_bias_jacobians", "pose_bias_covariance",
    "Direction", "DIRECTION_STATES", "direction_state", "direction_sigma", "Uncertainty", "AlphaChoice", "covariance", "covariance_batch",
    "choose_alpha", "bootstrap_covariance", "pose_error", "check_tolerances",
    "check_pose_bias", "TOLERANCE_DEG", "TOLERANCE_M", "ROTATION_FLOOR_RAD",
    "TRANSLATION_FLOOR_REL", "NULL_LEVEL", "noise_jacobians"]



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
    w = _check_weights(weights, C.shape[0])
    fit = _fit_sandwich(C, H, X, alpha, prior, noise, w, tol_m, correlation_lag, bias,
                        pose_pairs, pose_error_basis, pose_simulation, simulation_rng)
    return _assess(fit, C, H, X, alpha, prior, w, tol_r, tol_m)


@dataclass(frozen=True)
class _Fit:
    """What :func:`covariance` computes before the verdict: the residual model (``e``,
    ``K``, the cost's ``S``), the fitted noise, the information (data ``F``, noise-made
    ``F_noise``, prior ``F_prior``, the whitened rows ``Kw``, ``Bw``) and the sandwich's
    bread ``Hs`` and meat ``Ms`` with every correction applied (serial correlation, pose
    simulation, pose bias, prior)."""
    e: np.ndarray
    K: np.ndarray
    S: np.ndarray
    L: float
    noise: NoiseModel
    dof_noise: float
    Kw: np.ndarray
    Bw: np.ndarray
    F: np.ndarray
    F_noise: np.ndarray
    F_prior: np.ndarray
    prior_cov: np.ndarray | None
    Hs: np.ndarray
    Ms: np.ndarray
    lag: int
    pose_test: object
    sim: object
    Sig_bias: np.ndarray | None


def _fit_sandwich(C, H, X, alpha, prior, noise, w, tol_m, correlation_lag, bias, pose_pairs,
                  pose_error_basis, pose_simulation, simulation_rng) -> _Fit:
    """The residual model, noise, information and sandwich of :func:`covariance` (checked
    inputs; see the module doc)."""
    N = C.shape[0]
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
    return _Fit(e, K, S, L, noise_out, dof_noise, Kw, Bw, F, F_noise, F_prior, prior_cov, Hs,
                Ms, lag, pose_test, sim, Sig_bias)


def _assess(fit: _Fit, C, H, X, alpha, prior, w, tol_r, tol_m) -> Uncertainty:
    """The verdict and the covariance of :func:`covariance` from its :class:`_Fit`."""
    L = fit.L
    sim_bias = None if fit.sim is None else fit.sim.bias
    # ---- tolerance-scaled coordinates
    dsc = np.array([tol_r] * 3 + [tol_m] * 3)              # delta = dsc * delta_tilde
    Ft, Fp_t, Ht, Mt = (A * np.outer(dsc, dsc) for A in (fit.F, fit.F_prior, fit.Hs, fit.Ms))
    Ftot = Ft + Fp_t
    range_sc = np.array([_UNDETERMINED_ROT_RAD] * 3 + [L] * 3) / dsc   # range in tol units
    # ---- undetermined by the data: information not above what the noise alone makes
    null = _noise_null_test(fit.Kw, fit.Bw, dsc, fit.lag, fit.dof_noise)
    Ud = _data_undetermined(null, Ft, range_sc)
    Bd = _complement(Ud)
    # ---- undetermined in total: within Ud only the prior informs; the range rule on all
    Ut = _total_undetermined(Ud, Fp_t, Ftot, range_sc)
    Bt = _complement(Ut)
    W, Blk = _counting_information(Bd, Ud, Ft, Fp_t)
    # ---- covariance of the estimate: the sandwich on the determined subspace Bt
    Sig_b, Hb_inv = _restricted_sandwich(Bt, Ht, Mt)        # None, None: Bt is empty
    step = None if prior is not None or Sig_b is None else _minimiser_step(
        C, H, X, alpha, w, fit.K, fit.S, fit.e, dsc, Bt, Hb_inv, sim_bias)
    cov_t, offset_t = _with_offset(Bt, Sig_b, step)
    cov_det, cov = _reported_covariances(cov_t, dsc, Ut)
    # ---- directions from the data information, then those only this estimate leaves
    raw = _data_directions(Ud, Bd, Ft)
    sp = [None if prior is None else _std_with_prior(u, Ut, W, Bt, Blk) for u, _, _ in raw]
    dirs = [_data_direction(*r, dsc, tol_r, tol_m, s_p) for r, s_p in zip(raw, sp)]
    dirs += _estimate_directions(cov_t, raw, dsc, tol_r, tol_m)
    dirs.sort(key=lambda d: d.reason != "undetermined")
    sim = fit.sim
    return Uncertainty(X=X, covariance=cov, covariance_determined=cov_det,
                       determined_basis=_physical_basis(Bt, dsc), information=fit.F,
                       prior_covariance=fit.prior_cov, noise=fit.noise, alpha=alpha,
                       tolerance_deg=math.degrees(tol_r), tolerance_m=tol_m,
                       directions=tuple(dirs), translation_scale_m=L, n_motions=C.shape[0],
                       offset=offset_t * dsc, bias_covariance=fit.Sig_bias,
                       noise_information=fit.F_noise, information_ratio=null.ratio,
                       ratio_threshold=null.threshold, pose_noise_test=fit.pose_test,
                       simulated_bias=sim_bias,
                       systematic_parameters=0 if sim is None else sim.systematic_parameters,
                       white_pose_noise=None if sim is None else sim.white, simulation=sim,
                       method="pose_simulation" if sim_bias is not None else "sandwich")


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
        return _noise_ratio_choice(C, X, Q, lo, hi, u, alpha_initial,
                                   fallback=how != "noise_ratio")
    grid = np.logspace(math.log10(lo), math.log10(hi), int(num))
    pred = _predicted_errors(C, H, X, Q, grid, dsc, basis)
    j = int(np.argmin(pred))
    return AlphaChoice(float(grid[j]), f"min_predicted_error: argmin over a log grid of the "
                       f"predicted squared error of the {basis.shape[1]} determined directions "
                       "in tolerance units (noise fitted at alpha_initial)",
                       u.noise.sigma_r_rad, u.noise.sigma_t_m, float(alpha_initial), grid, pred)


def _noise_ratio_choice(C, X, Q, lo, hi, u, alpha_initial, fallback: bool) -> AlphaChoice:
    """``choose_alpha(how="noise_ratio")``: alpha^2 = var(rotation residual) / var(dual
    residual) under the noise ``Q`` fitted at ``alpha_initial`` (``u``), clipped to
    ``[lo, hi]``; ``fallback``: min_predicted_error found no determined direction."""
    T1 = _dq_map(C, X, 1.0)
    TQT = T1 @ Q @ np.swapaxes(T1, -1, -2)
    var_r = float(np.mean(np.trace(TQT[:, :4, :4], axis1=1, axis2=2)))
    var_d = float(np.mean(np.trace(TQT[:, 4:, 4:], axis1=1, axis2=2)))
    a = math.sqrt(var_r / var_d) if var_d > 0 else hi
    a = float(np.clip(a, lo, hi))
    why = (" (min_predicted_error fell back to it: no direction is determined)"
           if fallback else "")
    return AlphaChoice(a, "noise_ratio: alpha = sqrt(var(rotation residual) / "
                       "var(dual residual)) of the noise fitted at alpha_initial" + why,
                       u.noise.sigma_r_rad, u.noise.sigma_t_m, float(alpha_initial))


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