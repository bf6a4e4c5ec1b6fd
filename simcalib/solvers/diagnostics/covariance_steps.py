"""The steps of :func:`simcalib.solvers.diagnostics.uncertainty.covariance`: checked
inputs, noise level, whitened rows and information, sandwich, serial correlation, pose
bias, prior, the undetermined / poorly determined directions and the pose simulation."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from simcalib.geometry import (
    check_transforms,
)
from simcalib.solvers.diagnostics.inputs import (
    NoiseModel,
    ROTATION_FLOOR_RAD,
    TRANSLATION_FLOOR_REL,
    _PURE,
    _check_X,
    _check_noise,
    _real,
    _woodbury_information,
    check_pose_bias,
    pose_bias_covariance,
)
from simcalib.solvers.diagnostics.linear_model import (
    _dq_map,
    _prior_jacobians,
    _span,
    noise_jacobians,
)
from simcalib.solvers.diagnostics.results import (
    Direction,
    _fmt_vec,
)


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
    with np.errstate(over="ignore"):   # a null direction of M0: the ratio is clipped to 20
        ratio = np.clip(np.einsum("ki,kl,li->i", U0, Ah, U0) / np.maximum(l0, 1e-300),
                        0.05, 20.0)
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


