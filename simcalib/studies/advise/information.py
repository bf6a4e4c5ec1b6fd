"""What motions tell about X: Fisher information, the predicted 1-sigma, the systematic pose
errors' share, and the directions no feasible motion determines (pure numpy).

Information model (the one of :mod:`simcalib.solvers.diagnostics.uncertainty`): each motion
``i`` carries the Fisher information ``F_i = K_i^T Q_i^-1 K_i`` on the error ``delta =
(omega, v)`` of X (rad, m; camera-a frame), with ``K_i`` the Jacobian of the residual of
``C_i X = X H_i`` and ``Q_i`` the eq. 38 noise (``sigma_r``, ``sigma_t``) of ``C_i`` and
``H_i`` propagated to it. Information adds over motions. Systematic pose errors shared by
the poses (``xi = B eta``, ``eta ~ N(0, I)``) add ``F^-1 G G^T F^-1`` to the covariance,
``G`` the summed :func:`systematic_scores`.

**Determined subspace** (as the solver's verdict works, :mod:`simcalib.solvers.diagnostics`):
in tolerance units (``omega / tolerance_deg``, ``v / tolerance_m``) a direction is
undetermined when its 1-sigma exceeds the range (1 rad, or ``range_m``), or when it is one
of the directions no feasible motion of the platform determines (``undetermined``, from
:func:`undeterminable_directions`: e.g. the vertical translation of X for a platform that
rotates about the vertical only). The covariance is the inverse of the information on the
other directions (restricted to their span), and only the axes an undetermined direction
touches (a component above 5 %, the verdict's rule) are reported undetermined (``inf``):
inverting the whole singular information would make every axis look undetermined.
"""

from __future__ import annotations

import math

import numpy as np

from simcalib.geometry import adjoint_from_transform, invert_transform
from simcalib.solvers.diagnostics.inputs import (_PURE, ROTATION_FLOOR_RAD,
                                                 TRANSLATION_FLOOR_REL)

__all__ = ["AXES", "std_dict", "finite_or_none", "largest_std", "tolerance_scale",
           "motion_information", "predicted_motions", "systematic_scores", "predicted_std",
           "systematic_std", "determined_inverse", "with_systematic", "variance_shares",
           "complement", "check_undetermined", "max_std_tolerance_units",
           "undeterminable_directions", "undeterminable", "describe_direction",
           "PRIOR_KEYS_SCENARIO", "PRIOR_KEYS_CALIBRATE", "TILT_HINT_CART"]

#: the six axes of X's error, camera-a frame (rotation deg, translation m)
AXES = ("wx_deg", "wy_deg", "wz_deg", "vx_m", "vy_m", "vz_m")


def std_dict(s) -> dict:
    """1-sigma per axis ``(6,)`` as ``{axis: value}`` (None where undetermined)."""
    return {a: (None if not np.isfinite(v) else float(v)) for a, v in zip(AXES, s)}


def finite_or_none(x):
    """``float(x)``, or None when ``x`` is None or not finite (JSON-safe)."""
    return None if x is None or not np.isfinite(x) else float(x)


def largest_std(std, skip=()) -> tuple:
    """``(deg, cm)``: the largest 1-sigma of ``std`` (..., 6) per block (rotation deg,
    translation cm) over the axes not in ``skip`` (inf where a block has no other axis)."""
    s = np.where(np.isin(AXES, list(skip)), -np.inf, np.asarray(std, dtype=np.float64))
    deg, m = s[..., :3].max(axis=-1), s[..., 3:].max(axis=-1)
    return np.where(deg < 0, np.inf, deg), 100.0 * np.where(m < 0, np.inf, m)


def tolerance_scale(tolerance_deg, tolerance_m) -> np.ndarray:
    """``(6,)``: one tolerance unit per axis (rad, rad, rad, m, m, m)."""
    return np.array([math.radians(tolerance_deg)] * 3 + [tolerance_m] * 3)


def _range_scale(dsc, range_rad: float, range_m: float) -> np.ndarray:
    """``(6,)``: the range beyond which a direction is undetermined, in tolerance units."""
    return np.array([range_rad] * 3 + [range_m] * 3) / dsc


def _noise_covariance(X, sigma_r_rad, sigma_t_m, Qr, Qt) -> np.ndarray:
    """The eq. 38 noise of each residual, with the uncertainty model's numerical floor."""
    L = max(float(np.linalg.norm(np.asarray(X)[:3, 3])), 1e-3)
    return ((sigma_r_rad ** 2 + ROTATION_FLOOR_RAD ** 2) * Qr
            + (sigma_t_m ** 2 + (TRANSLATION_FLOOR_REL * L) ** 2) * Qt)


def motion_information(C, H, X, sigma_r_rad: float, sigma_t_m: float) -> np.ndarray:
    """``(N, 6, 6)`` Fisher information of each motion on ``delta`` (rad, m) at ``X``."""
    from simcalib.solvers.diagnostics.uncertainty import linear_model
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    if C.ndim != 3 or C.shape[1:] != (4, 4) or H.shape != C.shape:
        raise ValueError(f"C and H must be (N, 4, 4) of the same shape; received {C.shape}, "
                         f"{H.shape}")
    if C.shape[0] == 0:
        return np.zeros((0, 6, 6))
    _, K, Qr, Qt = linear_model(C, H, np.asarray(X, dtype=np.float64))
    Qinv = np.linalg.inv(_noise_covariance(X, sigma_r_rad, sigma_t_m, Qr, Qt))
    F = np.einsum("nki,nkl,nlj->nij", K, Qinv, K)
    return 0.5 * (F + np.swapaxes(F, -1, -2))


def predicted_motions(motion_a, X) -> tuple[np.ndarray, np.ndarray]:
    """``(C, H)`` of motions of camera a ``motion_a`` with camera b following through X."""
    C = np.asarray(motion_a, dtype=np.float64)
    return C, invert_transform(X) @ C @ X


def systematic_scores(C, H, X, sigma_r_rad: float, sigma_t_m: float, B_start_a, B_end_a,
                      B_start_b, B_end_b) -> np.ndarray:
    """``(N, 6, P)``: how systematic pose errors move each motion's information-weighted
    score ``K_i^T Q_i^-1 e_i`` (the estimate's error is ``F^-1 sum_i`` of it): the poses
    at each motion's start and end carry the errors ``xi = B @ eta`` (``B_*`` ``(N, 6, P)``
    per camera, or ``(6, P)`` when every motion starts or ends at the same pose;
    ``eta ~ N(0, I)`` shared), the motion the error ``xi_end - Ad(M^-1) xi_start``
    (right-multiplied), the residual its first-order response (the eq. 38 noise Jacobians
    of :func:`simcalib.solvers.diagnostics.uncertainty.linear_model`)."""
    from simcalib.solvers.diagnostics.uncertainty import (linear_model_jacobians,
                                                          noise_covariance_parts)
    C = np.asarray(C, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    _, K, Jc, Jh = linear_model_jacobians(C, H, X)
    Qr, Qt = noise_covariance_parts(Jc, Jh)
    KQ = np.swapaxes(K, -1, -2) @ np.linalg.inv(_noise_covariance(X, sigma_r_rad, sigma_t_m,
                                                                  Qr, Qt))
    Mc, Mh = KQ @ Jc, KQ @ Jh          # (N, 6, 6): the products with the bases come last
    return (_times_basis(Mc, B_end_a) - _times_basis(Mc @ _adinv(C), B_start_a)
            + _times_basis(Mh, B_end_b) - _times_basis(Mh @ _adinv(H), B_start_b))


def _adinv(T):
    """``Ad(T^-1)`` (…, 6, 6): ``exp(-xi) T = T exp(-Ad(T^-1) xi)``."""
    return adjoint_from_transform(invert_transform(T))


def _times_basis(M, B) -> np.ndarray:
    """``M @ B`` for ``M`` ``(N, 6, 6)`` and an error basis ``B``: ``(N, 6, P)`` (one per
    motion) or ``(6, P)`` (one pose shared by every motion: a single 2-D product)."""
    B = np.asarray(B, dtype=np.float64)
    if B.ndim == 2:
        return (M.reshape(-1, 6) @ B).reshape(M.shape[0], 6, B.shape[-1])
    return M @ B


# ------------------------------------------------------------------ determined subspace
def complement(U) -> np.ndarray:
    """Orthonormal basis ``(6, 6 - r)`` of the orthogonal complement of the orthonormal
    columns ``U`` ``(6, r)``."""
    U = np.asarray(U, dtype=np.float64).reshape(6, -1)
    if U.shape[1] == 0:
        return np.eye(6)
    Q, _ = np.linalg.qr(np.concatenate([U, np.eye(6)], axis=1))
    return Q[:, U.shape[1]:6]


def check_undetermined(undetermined) -> np.ndarray | None:
    """``undetermined`` as ``(6, r)`` orthonormal directions (tolerance units), or None when
    there are none; ValueError for anything else."""
    if undetermined is None:
        return None
    U = np.asarray(undetermined, dtype=np.float64)
    if U.ndim != 2 or U.shape[0] != 6 or not np.isfinite(U).all() or not np.allclose(
            U.T @ U, np.eye(U.shape[1]), atol=1e-8):
        raise ValueError(f"undetermined must be (6, r) orthonormal directions; received "
                         f"shape {U.shape}")
    return U if U.shape[1] else None


def _determined_modes(F, dsc, range_rad, range_m, undetermined):
    """``(B, lam, Ut)`` in tolerance units: the determined eigen-directions ``B`` of the
    information ``F`` (restricted to the complement of ``undetermined``) with their
    eigenvalues, and a basis ``Ut`` of the undetermined ones (those and the directions
    whose 1-sigma exceeds the range)."""
    Ft = np.asarray(F) * np.outer(dsc, dsc)
    Ft = 0.5 * (Ft + Ft.T)
    U0 = check_undetermined(undetermined)
    Bc = np.eye(6) if U0 is None else complement(U0)
    lam, V = np.linalg.eigh(Bc.T @ Ft @ Bc) if U0 is not None else np.linalg.eigh(Ft)
    U = Bc @ V if U0 is not None else V
    sig = np.where(lam > 0, 1.0 / np.sqrt(np.maximum(lam, 1e-300)), np.inf)
    rng_sc = _range_scale(dsc, range_rad, range_m)
    undet = sig * np.sqrt(np.sum((U / rng_sc[:, None]) ** 2, axis=0)) > 1.0
    Ut = U[:, undet] if U0 is None else np.concatenate([U0, U[:, undet]], axis=1)
    return U[:, ~undet], lam[~undet], Ut


def determined_inverse(F, dsc, range_rad: float = 1.0, range_m: float = 1.0,
                       undetermined=None) -> tuple[np.ndarray, np.ndarray]:
    """``(Fi, touched)``: the inverse of the scaled information ``F * dsc dsc^T`` over its
    determined directions (zero along the others; tolerance units) and ``(6,)`` bool, the
    axes an undetermined direction touches (component above 5 %)."""
    B, lam, Ut = _determined_modes(F, dsc, range_rad, range_m, undetermined)
    Fi = (B / lam) @ B.T if B.shape[1] else np.zeros((6, 6))
    touched = (np.linalg.norm(Ut, axis=1) > _PURE) if Ut.shape[1] else np.zeros(6, bool)
    return Fi, touched


def _std_from_covariance(S, dsc, touched) -> np.ndarray:
    """1-sigma per axis (deg, m) of the covariance ``S`` (tolerance units); inf where
    ``touched``."""
    s = np.sqrt(np.clip(np.diag(S), 0, None)) * dsc
    s = np.concatenate([np.degrees(s[:3]), s[3:]])
    return np.where(touched, np.inf, s)


def predicted_std(F, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                  range_rad: float = 1.0, range_m: float = 1.0,
                  undetermined=None) -> np.ndarray:
    """1-sigma per axis ``(wx, wy, wz)`` deg, ``(vx, vy, vz)`` m from information ``F``
    over its determined subspace (module text); ``inf`` on the axes an undetermined
    direction touches. ``undetermined``: ``(6, r)`` directions (tolerance units) no
    feasible motion determines (:func:`undeterminable_directions`)."""
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
    Fi, touched = determined_inverse(F, dsc, range_rad, range_m, undetermined)
    return _std_from_covariance(Fi, dsc, touched)


def with_systematic(Fi, Gt) -> np.ndarray:
    """The covariance ``Fi + Fi G G^T Fi`` (batched): white-noise covariance ``Fi`` plus
    what the shared pose errors with score ``G`` add."""
    FG = Fi @ Gt
    return Fi + FG @ np.swapaxes(FG, -1, -2)


def systematic_std(F, G, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                   range_rad: float = 1.0, range_m: float = 1.0,
                   undetermined=None) -> np.ndarray:
    """:func:`predicted_std` with the systematic pose errors: over the determined
    directions the covariance ``F^-1 + F^-1 G G^T F^-1`` (``G`` ``(6, P)``, the summed
    :func:`systematic_scores`); ``inf`` on the axes an undetermined direction touches."""
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
    Fi, touched = determined_inverse(F, dsc, range_rad, range_m, undetermined)
    return _std_from_covariance(with_systematic(Fi, np.asarray(G) * dsc[:, None]), dsc,
                                touched)


def variance_shares(F, G, groups, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
                    range_rad: float = 1.0, range_m: float = 1.0,
                    undetermined=None) -> tuple[np.ndarray, list]:
    """Where the predicted variance of each axis of X comes from: ``(shares (6, 1 + n),
    names)`` with ``names = ["white noise", *the n distinct groups]`` and ``shares[a, j]``
    the fraction of axis ``a``'s variance (the diagonal of
    ``F^-1 + F^-1 G G^T F^-1`` over the determined directions, :func:`systematic_std`) that
    the white noise (``F^-1``) or the columns of ``G`` (6, P) labelled with group ``j``
    (``groups``: P labels, e.g. "marker map") add — exactly, since ``G G^T`` is the sum
    of its column groups' ``G_g G_g^T``. Rows of undetermined axes (zero variance over
    the determined directions) are NaN."""
    G = np.asarray(G, dtype=np.float64)
    labels = list(groups)
    if G.ndim != 2 or G.shape[0] != 6 or len(labels) != G.shape[1]:
        raise ValueError(f"G must be (6, P) with P group labels; received G of shape "
                         f"{G.shape} and {len(labels)} labels")
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
    Fi, _ = determined_inverse(F, dsc, range_rad, range_m, undetermined)
    names = ["white noise"] + list(dict.fromkeys(labels))
    parts = [np.diag(Fi)]
    Gt = G * dsc[:, None]
    for name in names[1:]:
        FG = Fi @ Gt[:, [i for i, g in enumerate(labels) if g == name]]
        parts.append(np.sum(FG * FG, axis=1))
    V = np.stack(parts, axis=1)
    total = V.sum(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        shares = np.where(total > 0, V / np.where(total > 0, total, 1.0), np.nan)
    return shares, names


def max_std_tolerance_units(F, *, tolerance_deg: float = 1.0,
                            tolerance_m: float = 0.01) -> float:
    """Largest 1-sigma of information ``F`` (rad, m) in tolerance units
    (``1/sqrt(lambda_min)``; inf when a direction is undetermined)."""
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
    Ft = np.asarray(F, dtype=np.float64) * np.outer(dsc, dsc)
    lam = np.linalg.eigvalsh(0.5 * (Ft + Ft.T))[0]
    return float(1.0 / math.sqrt(lam)) if lam > 0 else math.inf


# ------------------------------------------------------------------ what no motion helps
#: how a prior on X is given, named in the fix of :func:`undeterminable`: a scenario's keys
PRIOR_KEYS_SCENARIO = {"translation": "prior.translation_m with a weight prior.b",
                       "rotation": "prior.rotvec_deg with a weight prior.a"}
#: ... and ``calibrate``'s (pose files)
PRIOR_KEYS_CALIBRATE = {
    "translation": "prior=[tx,ty,tz,qx,qy,qz,qw] with a weight prior_weight_translation",
    "rotation": "prior=[tx,ty,tz,qx,qy,qz,qw] with a weight prior_weight_rotation"}


def undeterminable_directions(F_base, F_cand, *, feasible=None, tolerance_deg: float = 1.0,
                              tolerance_m: float = 0.01, range_rad: float = 1.0,
                              range_m: float = 1.0) -> np.ndarray:
    """``(6, r)`` orthonormal directions of X (tolerance units) that no feasible candidate
    motion can determine: undetermined (1-sigma beyond the range) by the feasible
    candidates alone, each added 100 times, and not determined within the tolerance by
    the recorded motions (``F_base``). The candidates are judged alone because the
    recorded motions' information along such a direction may be made by their errors (a
    systematic tilt of the measured poses looks like the rotation that would determine
    it) and adding candidates cannot change that."""
    dsc = tolerance_scale(tolerance_deg, tolerance_m)
    Fb = np.asarray(F_base, dtype=np.float64) * np.outer(dsc, dsc)
    Fc = np.asarray(F_cand, dtype=np.float64)
    if feasible is not None:
        Fc = Fc[np.asarray(feasible, bool)]
    Ft = 100.0 * Fc.sum(axis=0) * np.outer(dsc, dsc)
    lam, U = np.linalg.eigh(0.5 * (Ft + Ft.T))
    sig = np.where(lam > 0, 1.0 / np.sqrt(np.maximum(lam, 1e-300)), np.inf)
    rng_sc = _range_scale(dsc, range_rad, range_m)
    keep = [k for k in range(6)
            if sig[k] * math.sqrt(float(np.sum((U[:, k] / rng_sc) ** 2))) > 1.0
            and float(U[:, k] @ Fb @ U[:, k]) < 1.0]    # the recorded motions: 1-sigma > tol
    return U[:, keep]


def undeterminable(F_base, F_cand, *, feasible=None, tolerance_deg: float = 1.0,
                   tolerance_m: float = 0.01, range_rad: float = 1.0,
                   range_m: float = 1.0, prior_keys: dict | None = None,
                   tilt_hint: str | None = None) -> list[dict]:
    """The directions of :func:`undeterminable_directions`, each a dict of
    :func:`describe_direction` (``prior_keys``: how the prior is given,
    :data:`PRIOR_KEYS_SCENARIO` by default; ``tilt_hint``: the platform's own way to rotate
    about another axis, :data:`TILT_HINT_CART` by default)."""
    U = undeterminable_directions(F_base, F_cand, feasible=feasible,
                                  tolerance_deg=tolerance_deg, tolerance_m=tolerance_m,
                                  range_rad=range_rad, range_m=range_m)
    return [describe_direction(u, prior_keys, tilt_hint) for u in U.T]


def _vec(v) -> str:
    return "[" + ", ".join(f"{x:+.3f}" for x in v) + "]"


#: how a cart could rotate about another axis than the vertical (the fix's example)
TILT_HINT_CART = "e.g. tilt the rig: drive over a ramp, or mount it on an arm"


def describe_direction(u, prior_keys: dict | None = None, tilt_hint: str | None = None
                       ) -> dict:
    """A direction ``u`` (6,) of X no feasible motion determines, for the user: ``kind``
    (rotation / translation / coupled), ``rotation_axis_a``, ``translation_dir_a`` (unit,
    camera-a frame, zeros when that part is < 5 %), ``description``, ``statement``,
    ``fix`` (the prior or extra measurement that would determine it; ``tilt_hint``: how
    the platform could rotate about another axis, :data:`TILT_HINT_CART` by default)."""
    keys = PRIOR_KEYS_SCENARIO if prior_keys is None else prior_keys
    w, t = np.asarray(u[:3]), np.asarray(u[3:])
    nw, nt = np.linalg.norm(w), np.linalg.norm(t)
    tot = math.hypot(nw, nt)
    ax = w / nw if nw > _PURE * tot else np.zeros(3)
    td = t / nt if nt > _PURE * tot else np.zeros(3)
    if ax.any() and td.any():
        kind = "coupled"
        desc = (f"rotation of X about {_vec(ax)} coupled with translation along {_vec(td)} "
                "(camera-a frame)")
    elif ax.any():
        kind, desc = "rotation", f"rotation of X about {_vec(ax)} (camera-a frame)"
    else:
        kind, desc = "translation", f"translation of X along {_vec(td)} (camera-a frame)"
    return {"kind": kind, "rotation_axis_a": ax.tolist(), "translation_dir_a": td.tolist(),
            "description": desc,
            "statement": (f"{desc}: no motion this platform can make determines it "
                          "(undetermined even with every feasible candidate)"),
            "fix": "; ".join(_fixes(ax, td, keys, tilt_hint or TILT_HINT_CART))}


def _fixes(ax, td, keys, tilt_hint: str) -> list:
    """What would determine a direction with rotation axis ``ax`` / translation ``td``."""
    fix = []
    if td.any():
        fix.append(f"a prior on X's translation along {_vec(td)} ({keys['translation']}, "
                   "e.g. the camera offset measured with a ruler or taken from the CAD "
                   "model, to within the tolerance)")
        fix.append("or motions rotating about an axis not parallel to it — which this "
                   f"platform cannot make ({tilt_hint})")
    if ax.any():
        fix.append(f"a prior on X's rotation about {_vec(ax)} ({keys['rotation']}), or "
                   "motions with rotations about two non-parallel axes")
    return fix
