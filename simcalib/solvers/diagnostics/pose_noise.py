"""Motions that share poses: a test for white pose noise, and the error of the alpha-cost
minimiser under it by simulation (bias and covariance). Pure numpy; no solver imports.

Why. Motions formed from pose streams, pairs ``(start_k, end_k)`` of datapoints
(``pose_pairs``; consecutive pairs ``(k, k + step)`` of one stream), share poses: the noise
of pose ``p`` enters the motion that ends at ``p`` and the one that starts there, with
opposite signs. Along a smooth path the two contributions nearly cancel in the estimate,
so the error of X is much smaller than independent motion noise would make it (on the
``3d`` arm path with 1 cm / 0.57 deg pose noise: ~4x in sigma), and a first-order
propagation evaluated at the *measured* motions does not see the cancellation fully
either: the measured motions carry the noise, the true ones vary smoothly (~1.5x too large).
Small motions with large rotation noise also bias the estimate (errors in variables: the
translation of X is attenuated along directions its rotations barely determine; ~10 mm on
``3d``, ~1.8 sigma).

Test (:func:`white_noise_test`). Under independent ("white") pose noise the whitened
motion residuals ``r_k`` are serially correlated only through shared poses: motions ``m``
and ``n`` sharing a pose as end/start correlate at -1/2, as start/start or end/end at +1/2
(equal contributions of the two poses; exact for small motions). The empirical
autocorrelation ``a_l = sum_k r_k . r_{k+l} / sum_k |r_k|^2`` at lags ``l = 1..L``
(``L = 2 x`` the largest pose-index span of a motion, at most 20) is compared with the
expected one: ``Q = N d sum_l (a_l - E a_l)^2`` (``d`` = 6 residual components, each
``a_l`` averages them), accepted when ``Q`` is below the ``1 - level``
quantile of ``chi2(L)`` scaled by 1.5 (the MA(step) structure inflates the variance of
each ``a_l`` by up to 1.5). Pose errors that vary smoothly with the viewpoint (ArUco:
marker map, lens, rolling shutter) correlate neighbouring motions (``a_1`` ~ +0.3 on
``3d``) and are rejected: there the residual-based serial-correlation correction
(``correlation_lag``) stays.

Simulation (:func:`simulate_error`). With the pose noise accepted as white, its level per
pose is the fitted motion noise over sqrt(2) (each motion carries two poses' noise). The
data are re-simulated around the estimate: the measured motions ``C_k`` and
``H_k* = X^-1 C_k X`` play the truth, every datapoint's pose of each camera gets eq. 38 noise
(right-multiplied, shared by the motions using that pose), and each simulated data set is
solved for the minimiser of the exact alpha cost (8) (``sum w_k |M_k Q|^2``, ``Q`` the dual
quaternion of X: Gauss-Newton on the unit dual quaternions from the estimate, three steps;
it reproduces dqopt's optimum on the measured data to ~1e-13). Because the measured motions
already carry noise (so the simulated ones carry it twice), the simulation is repeated
from truths one more noise draw away and the bias and covariance are extrapolated to no
noise (SIMEX, Cook & Stefanski 1994: ``b = 2 b_1 - b_2``; covariance ``2 S_1 - S_2`` taken
in the metric of ``S_1``, its eigenvalue ratios clipped to [0.2, 1]). The Monte-Carlo uses
its own generator (default ``default_rng(0)``: a numerical integration, fixed so the same
data give the same covariance). Systematic pose errors
(``simulate_error(..., systematic=(Ba, Bb))``): errors shared by the poses through common
standard-normal parameters (``xi_pose = B[pose] @ eta``; a marker map, lens calibrations,
an arm's DH table), drawn once per simulated data set for both cameras and composed with
the white draw (:func:`check_systematic`; :func:`systematic_residual_power` for the share
of the residuals they explain). Measured on ``3d`` with ``source=noisy`` (100 data sets):
coverage of the 95 % region 0.92-0.95 and predicted sigma / RMS 1.05-1.31 (the first-order
model with the serial-correlation correction: 0.89 and up to 1.95).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import (dual_quat_from_transform, matrix_from_rotvec, quat_conjugate,
                               quat_left_matrix, quat_multiply, quat_right_matrix)
from simcalib.solvers.diagnostics.inputs import pose_error

__all__ = ["WhiteNoiseTest", "check_pose_pairs", "expected_autocorrelation",
           "white_noise_test", "simulate_error", "check_systematic", "systematic_residual_power",
           "SimulatedError", "minimiser_offset", "N_SIM", "N_TRUTHS", "WHITE_LEVEL"]

#: simulated data sets at the first noise level, and truths (one more draw each) at the second
N_SIM = 256
N_TRUTHS = 8
#: false-rejection rate of the white-noise test
WHITE_LEVEL = 1e-3
_MAX_LAG = 20


@dataclass(frozen=True, eq=False)
class SimulatedError:
    """What the simulation of :func:`simcalib.solvers.diagnostics.uncertainty.covariance`
    found for one data set: ``bias`` (6,) and ``covariance`` (6, 6) of the alpha-cost
    minimiser (delta coordinates), at ``alpha``, with the white pose noise ``white``
    ``(sigma_r_rad, sigma_t_m)`` per pose and ``systematic_parameters`` shared ones. Other
    estimates of the same motions at the same alpha may reuse it (``pose_simulation=``):
    it describes the minimiser near X, not one estimate (each estimate's own offset from
    the minimiser is added separately)."""
    bias: np.ndarray
    covariance: np.ndarray
    alpha: float
    white: tuple
    systematic_parameters: int = 0


def check_pose_inputs(pose_pairs, pose_error_basis, pose_simulation, n: int | None,
                      alpha: float) -> tuple:
    """``(P, systematic, pose_simulation)``: the pose-structure inputs of
    :func:`simcalib.solve` and :func:`simcalib.solvers.diagnostics.uncertainty.covariance`
    checked together — ``pose_simulation`` a :class:`SimulatedError` at ``alpha``,
    ``pose_simulation`` and ``pose_error_basis`` only with ``pose_pairs``, and (``n``: the
    number of motions; None: not known yet, only these checks) ``P`` by
    :func:`check_pose_pairs`, ``systematic`` by :func:`check_systematic` (None when not
    given). TypeError / ValueError naming what was received otherwise."""
    if pose_simulation is not None:
        if not isinstance(pose_simulation, SimulatedError):
            raise TypeError(f"pose_simulation must be a SimulatedError (Solution.uncertainty."
                            f"simulation); received {type(pose_simulation).__name__}")
        if pose_simulation.alpha != alpha:
            raise ValueError(f"pose_simulation was simulated at alpha = "
                             f"{pose_simulation.alpha:g}; this estimate is at alpha = "
                             f"{alpha:g}")
    for name, given in (("pose_simulation", pose_simulation),
                        ("pose_error_basis", pose_error_basis)):
        if given is not None and pose_pairs is None:
            raise ValueError(f"{name} needs pose_pairs (the datapoints of each motion); "
                             "received pose_pairs=None")
    if pose_pairs is None or n is None:
        return pose_pairs, pose_error_basis, pose_simulation
    P = check_pose_pairs(pose_pairs, n)
    systematic = None if pose_error_basis is None else \
        check_systematic(pose_error_basis, int(P.max()) + 1)
    return P, systematic, pose_simulation


def check_pose_pairs(pose_pairs, n: int) -> np.ndarray:
    """``(n, 2)`` int64 datapoint indices ``(start, end)`` of each motion; ValueError
    naming what was received otherwise."""
    P = np.asarray(pose_pairs)
    if P.ndim != 2 or P.shape != (n, 2):
        raise ValueError(f"pose_pairs must have shape ({n}, 2) (start and end datapoint of "
                         f"each motion); received shape {P.shape}")
    if not np.issubdtype(P.dtype, np.integer):
        if not (np.issubdtype(P.dtype, np.floating) and np.all(np.isfinite(P))
                and np.all(P == np.round(P))):
            raise ValueError(f"pose_pairs must hold integer indices; received dtype {P.dtype}")
    P = P.astype(np.int64)
    if P.size and (P.min() < 0):
        raise ValueError(f"pose_pairs must be >= 0; received minimum {int(P.min())}")
    if np.any(P[:, 0] == P[:, 1]):
        k = int(np.flatnonzero(P[:, 0] == P[:, 1])[0])
        raise ValueError(f"pose_pairs: motion {k} starts and ends at datapoint "
                         f"{int(P[k, 0])}; a motion needs two poses")
    return P


def _lags(P: np.ndarray) -> int:
    span = int(np.max(np.abs(P[:, 1] - P[:, 0]))) if P.size else 1
    return int(min(max(2 * span, 2), _MAX_LAG, max(P.shape[0] - 2, 1)))


def expected_autocorrelation(pose_pairs: np.ndarray, n_lags: int) -> np.ndarray:
    """``(n_lags,)`` expected residual autocorrelation at lags 1..n_lags under white pose
    noise (see the module doc)."""
    P = np.asarray(pose_pairs)
    N = P.shape[0]
    out = np.zeros(n_lags)
    for lag in range(1, n_lags + 1):
        a, b = P[:-lag], P[lag:]
        c = (-0.5 * ((a[:, 1] == b[:, 0]) | (a[:, 0] == b[:, 1]))
             + 0.5 * ((a[:, 0] == b[:, 0]) | (a[:, 1] == b[:, 1])))
        out[lag - 1] = c.sum() / N
    return out


@dataclass(frozen=True)
class WhiteNoiseTest:
    """Result of :func:`white_noise_test`: empirical and expected autocorrelation of the
    whitened residuals at lags 1..L, the statistic ``Q``, its threshold, the verdict."""
    autocorrelation: np.ndarray
    expected: np.ndarray
    statistic: float
    threshold: float
    accepted: bool

    def to_dict(self, digits: int | None = None) -> dict:
        """JSON form: ``white``, ``statistic`` (None when not finite), ``threshold``,
        ``autocorrelation`` and ``expected`` (rounded to ``digits`` when given)."""
        num = float if digits is None else (lambda x: round(float(x), digits))  # noqa: E731
        stat = float(self.statistic)
        return {"white": bool(self.accepted),
                "statistic": stat if math.isfinite(stat) else None,
                "threshold": float(self.threshold),
                "autocorrelation": [num(x) for x in self.autocorrelation],
                "expected": [num(x) for x in self.expected]}

    def summary(self) -> str:
        word = "white (independent per pose)" if self.accepted else "correlated between poses"
        return (f"pose noise {word}: residual autocorrelation lags 1-{self.expected.size} "
                f"{np.array2string(self.autocorrelation, precision=2, separator=' ')} vs "
                f"{np.array2string(self.expected, precision=2, separator=' ')} expected, "
                f"Q = {self.statistic:.3g} (threshold {self.threshold:.3g})")


def white_noise_test(residuals_whitened: np.ndarray, pose_pairs: np.ndarray,
                     level: float = WHITE_LEVEL) -> WhiteNoiseTest:
    """Are the whitened residuals ``(N, d)`` (motions in time order) consistent with white
    pose noise shared through ``pose_pairs``? See the module doc."""
    from scipy.special import chdtri
    r = np.asarray(residuals_whitened, dtype=np.float64)
    N = r.shape[0]
    L = _lags(pose_pairs)
    den = float(np.sum(r * r))
    if not (math.isfinite(den) and den > 0) or N < 3 * L:
        return WhiteNoiseTest(np.zeros(L), expected_autocorrelation(pose_pairs, L), math.inf,
                              0.0, False)
    acf = np.array([np.sum(r[:-lag] * r[lag:]) / den for lag in range(1, L + 1)])
    exp = expected_autocorrelation(pose_pairs, L)
    Q = float(N * r.shape[1] * np.sum((acf - exp) ** 2))
    thr = 1.5 * float(chdtri(L, level))
    return WhiteNoiseTest(acf, exp, Q, thr, bool(Q <= thr))


# ----------------------------------------------------------------------------- simulation
def _dq_mul(a, ad, b, bd):
    return quat_multiply(a, b), quat_multiply(a, bd) + quat_multiply(ad, b)


def _pose_noise(shape, sigma_r, sigma_t, rng):
    """Unit dual quaternions of eq. 38 perturbations ``[dR | dt]`` (angle ~ N(0, sigma_r^2)
    about a uniform axis, dt ~ N(0, sigma_t^2 I)), shape ``shape + (4,)`` each."""
    axis = rng.standard_normal(shape + (3,))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = rng.normal(0.0, sigma_r, size=shape)
    t = rng.normal(0.0, sigma_t, size=shape + (3,))
    return _dq_from_xi(np.concatenate([axis * angle[..., None], t], axis=-1))


def _perturb(qm, qmd, P, noise):
    """Motions ``(qm, qmd)`` (…, N, 4) with pose noise ``noise = (e, ed)`` (B, n_pose, 4):
    ``E_start^-1 (x) Q_motion (x) E_end`` (B, N, 4)."""
    e, ed = noise
    s, sd = quat_conjugate(e[:, P[:, 0]]), quat_conjugate(ed[:, P[:, 0]])
    a, ad = _dq_mul(s, sd, np.broadcast_to(qm, s.shape), np.broadcast_to(qmd, s.shape))
    return _dq_mul(a, ad, e[:, P[:, 1]], ed[:, P[:, 1]])


def _gram(qC, qCd, qH, qHd, alpha, w):
    """``(..., 8, 8)`` matrix ``G`` of the alpha cost ``sum w |M Q|^2 = Q^T G Q`` (the blocks
    of :mod:`simcalib.solvers.kernels.gram`, the one place of that formula)."""
    from simcalib.solvers.kernels.gram import assemble, gram_blocks
    S, W, M = assemble(*gram_blocks(qC, qCd, qH, qHd, w), alpha)
    return np.concatenate([np.concatenate([S, W], -1),
                           np.concatenate([np.swapaxes(W, -1, -2), M], -1)], -2)


def _signed_gram(C, H, X, alpha, w):
    """:func:`_gram` of the motions ``C``, ``H`` (…, N, 4, 4), each motion's dual-quaternion
    pair signed to fit ``X`` (the sign a minimiser near ``X`` sees)."""
    qC, qCd = dual_quat_from_transform(C)
    qH, qHd = dual_quat_from_transform(H)
    qX, _ = dual_quat_from_transform(X)
    fit = np.sum(quat_multiply(qC, np.broadcast_to(qX, qC.shape))
                 * quat_multiply(np.broadcast_to(qX, qH.shape), qH), axis=-1)
    sgn = np.where(fit < 0, -1.0, 1.0)[..., None]
    return _gram(qC, qCd, qH * sgn, qHd * sgn, alpha, w)


def _q_and_jacobian(X):
    """Dual quaternion ``Q`` (…, 8) of ``X`` and ``dQ/d delta`` (…, 8, 6) for
    ``R <- exp(omega) R``, ``t <- t + v``."""
    q, qd = dual_quat_from_transform(X)
    dq_dw = 0.5 * quat_right_matrix(q)[..., :, :3]
    tq = np.concatenate([X[..., :3, 3], np.zeros(X.shape[:-2] + (1,))], -1)
    D = np.zeros(X.shape[:-2] + (8, 6))
    D[..., :4, :3] = dq_dw
    D[..., 4:, :3] = 0.5 * quat_left_matrix(tq) @ dq_dw
    D[..., 4:, 3:] = 0.5 * quat_right_matrix(q)[..., :, :3]
    return np.concatenate([q, qd], -1), D


def _minimise(G, X0, steps: int = 3):
    """Gauss-Newton on the unit dual quaternions: the minimiser of ``Q^T G Q`` near ``X0``
    for each ``G`` (…, 8, 8)."""
    X = np.array(np.broadcast_to(X0, G.shape[:-2] + (4, 4)))
    for _ in range(steps):
        Q, D = _q_and_jacobian(X)
        GD = G @ D
        Hm = np.swapaxes(D, -1, -2) @ GD
        Hm += (1e-12 * np.trace(Hm, axis1=-2, axis2=-1) / 6.0)[..., None, None] * np.eye(6)
        g = np.einsum("...ki,...k->...i", GD, Q)
        d = -np.linalg.solve(Hm, g[..., None])[..., 0]
        X[..., :3, :3] = matrix_from_rotvec(d[..., :3]) @ X[..., :3, :3]
        X[..., :3, 3] += d[..., 3:]
    return X


def _consistent_h(qC, qCd, X):
    """``H* = X^-1 C X`` as dual quaternions (…, 4) each: the motions of camera b that fit
    ``X`` exactly, for truths ``(qC, qCd)``."""
    qX, qXd = dual_quat_from_transform(X)
    cX, cXd = quat_conjugate(qX), quat_conjugate(qXd)
    a, ad = _dq_mul(np.broadcast_to(cX, qC.shape), np.broadcast_to(cXd, qC.shape), qC, qCd)
    return _dq_mul(a, ad, np.broadcast_to(qX, qC.shape), np.broadcast_to(qXd, qC.shape))


def _simulated(truth_c, truth_h, X, alpha, P, noise_a, noise_b, w):
    """Deviations (B, 6) of the minimisers from ``X`` for truths ``truth_c`` and
    ``truth_h = H*`` (dual-quaternion pairs, (B,) N, 4) with pose noise draws ``noise_a``,
    ``noise_b`` (B, n_pose)."""
    Cb = _perturb(*truth_c, P, noise_a)
    Hb = _perturb(*truth_h, P, noise_b)
    # estimate minus truth in delta coordinates: (rotvec(R_est R^T), t_est - t)
    return pose_error(_minimise(_gram(*Cb, *Hb, alpha, w), X), X)


def check_systematic(systematic, n_pose: int) -> tuple[np.ndarray, np.ndarray]:
    """``(Ba, Bb)``: per datapoint pose, the systematic pose error of camera a and b per unit
    of ``P`` shared parameters, ``(n_pose, 6, P)`` each (``xi = B @ eta``, ``eta ~ N(0, I)``;
    ``xi = (rotvec, t)`` right-multiplied, camera frame). ValueError naming what was
    received otherwise."""
    try:
        Ba, Bb = (np.asarray(b, dtype=np.float64) for b in systematic)
    except (TypeError, ValueError):
        raise ValueError(f"the systematic pose-error basis must be a pair (Ba, Bb) of "
                         f"(n_pose, 6, P) arrays; received {type(systematic).__name__}") from None
    for name, B in (("Ba", Ba), ("Bb", Bb)):
        if B.ndim != 3 or B.shape[1] != 6 or B.shape[0] < n_pose or not np.isfinite(B).all():
            raise ValueError(f"systematic pose-error basis {name} must be finite with shape "
                             f"(n_pose >= {n_pose}, 6, P); received shape {B.shape}")
    if Ba.shape != Bb.shape:
        raise ValueError(f"systematic pose-error bases Ba and Bb must have the same shape; "
                         f"received {Ba.shape} and {Bb.shape}")
    return Ba, Bb


def _dq_from_xi(xi):
    """Unit dual quaternions (…, 4) each of ``[exp(omega) | t]`` for ``xi = (omega, t)``."""
    w = xi[..., :3]
    ang = np.linalg.norm(w, axis=-1)
    half = 0.5 * ang
    k = np.where(ang > 1e-12, np.sin(half) / np.maximum(ang, 1e-300), 0.5)
    q = np.concatenate([w * k[..., None], np.cos(half)[..., None]], axis=-1)
    t = np.concatenate([xi[..., 3:], np.zeros(xi.shape[:-1] + (1,))], axis=-1)
    return q, 0.5 * quat_multiply(t, q)


def _draw_noise(shape, sigma_r, sigma_t, rng, basis):
    """Pose noise of both cameras (dual quaternions, ``shape + (4,)`` each, for camera a
    and b): white eq. 38 noise, composed with the systematic part ``B @ eta`` when
    ``basis = (Ba, Bb)`` ((n_pose, 6, P) each) is given — one ``eta ~ N(0, I)`` per draw,
    the same for both cameras (their parameters are shared: the marker map)."""
    na = _pose_noise(shape, sigma_r, sigma_t, rng)
    nb = _pose_noise(shape, sigma_r, sigma_t, rng)
    if basis is None:
        return na, nb
    Ba, Bb = basis
    eta = rng.standard_normal((shape[0], Ba.shape[2]))
    out = []
    for (q, qd), B in ((na, Ba), (nb, Bb)):
        s, sd = _dq_from_xi(_systematic_draw(B[:shape[1]], eta))
        out.append(_dq_mul(q, qd, s, sd))
    return tuple(out)


def _systematic_draw(B, eta):
    """``(n_draw, n_pose, 6)`` pose errors ``B @ eta`` for bases ``B`` (n_pose, 6, P) and
    draws ``eta`` (n_draw, P) (one matrix product)."""
    n, _, P = B.shape
    return (eta @ B.reshape(n * 6, P).T).reshape(eta.shape[0], n, 6)


def systematic_residual_power(C, X, alpha: float, pose_pairs, systematic, weights=None,
                              rng: np.random.Generator | None = None, n_draws: int = 32):
    """``(rot2, tr2)``: the mean weighted squared residuals (rotation, rad^2; translation,
    m^2; as the noise fit of :func:`simcalib.solvers.diagnostics.uncertainty.covariance`
    takes them from the data) that the systematic pose errors alone would leave at the
    estimate: motions ``C`` and ``H* = X^-1 C X`` re-simulated with ``n_draws`` draws of the
    basis, each solved for the alpha-cost minimiser (the part of the errors that is a change
    of X, e.g. a run-constant error, leaves no residual)."""
    from simcalib.geometry import invert_transform, transform_from_rotation_translation
    C = np.asarray(C, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    P = check_pose_pairs(pose_pairs, C.shape[0])
    Ba, Bb = check_systematic(systematic, int(P.max()) + 1)
    rng = np.random.default_rng(0) if rng is None else rng
    w = np.ones(C.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    wn = w / w.sum()

    def exp6(xi):
        return transform_from_rotation_translation(matrix_from_rotvec(xi[..., :3]), xi[..., 3:])

    eta = rng.standard_normal((n_draws, Ba.shape[2]))
    Ea = exp6(_systematic_draw(Ba, eta))
    Eb = exp6(_systematic_draw(Bb, eta))
    Cs = invert_transform(Ea[:, P[:, 0]]) @ C @ Ea[:, P[:, 1]]
    Hs = invert_transform(Eb[:, P[:, 0]]) @ (invert_transform(X) @ C @ X) @ Eb[:, P[:, 1]]
    Xs = _minimise(_signed_gram(Cs, Hs, X, alpha, w), X)
    # residuals of each draw at its minimiser: C_i against X H_i X^-1 (linear_model's e)
    e = pose_error(Cs, Xs[:, None] @ Hs @ invert_transform(Xs)[:, None])
    return (float(np.mean(np.sum(wn * np.sum(e[..., :3] ** 2, -1), -1))),
            float(np.mean(np.sum(wn * np.sum(e[..., 3:] ** 2, -1), -1))))


def simulate_error(C, X, alpha: float, pose_pairs, sigma_r_rad: float, sigma_t_m: float,
                   weights=None, rng: np.random.Generator | None = None,
                   n_sim: int = N_SIM, n_truths: int = N_TRUTHS, systematic=None):
    """Bias ``(6,)`` and covariance ``(6, 6)`` (delta coordinates, estimate minus truth) of
    the alpha-cost minimiser near ``X`` for motions ``C`` (N, 4, 4) of camera a whose
    datapoints' poses have white eq. 38 noise ``sigma_r_rad`` / ``sigma_t_m`` (per pose,
    both cameras), shared through ``pose_pairs``; SIMEX-extrapolated to noise-free truths
    (module doc). ``systematic``: optional ``(Ba, Bb)`` (:func:`check_systematic`), pose
    errors shared by the poses through common parameters (marker map, lens calibration),
    drawn afresh with each white draw. The two noise levels use the same ``n_sim`` pose-noise
    draws (common random numbers: their difference, which the extrapolation needs, is then
    far less noisy than either); the second level's truths (``n_truths``, one more draw each) take turns
    over the draws. ``None`` when the simulation is unusable (non-finite results or a
    singular covariance)."""
    C = np.asarray(C, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    P = check_pose_pairs(pose_pairs, C.shape[0])
    rng = np.random.default_rng(0) if rng is None else rng
    w = np.ones(C.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    n_pose = int(P.max()) + 1
    basis = None if systematic is None else check_systematic(systematic, n_pose)
    noise_a, noise_b = _draw_noise((n_sim, n_pose), sigma_r_rad, sigma_t_m, rng, basis)
    qC, qCd = dual_quat_from_transform(C)
    D1 = _simulated((qC, qCd), _consistent_h(qC, qCd, X), X, alpha, P, noise_a, noise_b, w)
    tC = _perturb(qC, qCd, P, _draw_noise((n_truths, n_pose), sigma_r_rad, sigma_t_m, rng,
                                          basis)[0])
    tH = _consistent_h(*tC, X)                     # once per truth, then taken in turns
    pick = np.arange(n_sim) % n_truths
    D2 = _simulated((tC[0][pick], tC[1][pick]), (tH[0][pick], tH[1][pick]), X, alpha, P,
                    noise_a, noise_b, w)
    if not (np.all(np.isfinite(D1)) and np.all(np.isfinite(D2))):
        return None
    b1, S1 = D1.mean(0), np.cov(D1.T)
    b2, S2 = D2.mean(0), np.cov(D2.T)
    lam1, V1 = np.linalg.eigh(0.5 * (S1 + S1.T))
    if not (np.all(np.isfinite(lam1)) and lam1[0] > 0):
        return None
    R, Ri = V1 * np.sqrt(lam1), V1 / np.sqrt(lam1)
    A2 = Ri.T @ S2 @ Ri
    l2, U2 = np.linalg.eigh(0.5 * (A2 + A2.T))
    S = R @ (U2 * np.clip(2.0 - l2, 0.2, 1.0)) @ U2.T @ R.T
    return 2.0 * b1 - b2, 0.5 * (S + S.T)


def minimiser_offset(C, H, X, alpha: float, weights=None) -> np.ndarray:
    """``(6,)`` offset (delta coordinates) from ``X`` to the minimiser of the exact alpha
    cost (8) on the motions ``C``, ``H`` nearby (Gauss-Newton on the unit dual quaternions;
    each motion's dual-quaternion pair signed to fit ``X``): ~1e-13 for an optimal
    estimator, the estimator's own bias otherwise."""
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    w = np.ones(C.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    return pose_error(_minimise(_signed_gram(C, H, X, alpha, w), X, steps=5), X)
