"""What the motions determine, and certificates of global optimality for DQ solutions.

Observability (any method): the motion equations ``C_i X = X H_i`` are linearised in a
left perturbation ``X -> exp(delta) X`` with ``delta = (omega, v)`` expressed in the frame of
camera a (``omega``: rotation vector in rad, ``v``: translation in m). Motion ``i`` gives
the rows ``[[I - R_i, 0], [-alpha [t_i]x, I - R_i]]`` acting on ``(omega, alpha v)`` (the
rotation equation, and the translation equation weighted by alpha as in the cost). The
singular values / vectors of the stacked 6N x 6 matrix say which combinations of
rotation and translation of X the motions fix. A direction is

* **undetermined** when its singular value is (numerically) zero relative to the largest
  (``< 1e-6``): planar motion leaves the translation along the common rotation axis free,
  pure translation leaves the whole translation free (and the rotation about the
  translation direction if all translations are parallel), rotations about a single axis
  leave the translation along that axis free;
* **poorly determined** when its predicted 1-sigma uncertainty ``sigma / s_k`` (``sigma``
  = RMS residual of the motion equations at the solution) exceeds ``weak_std``
  (default 0.02: ~1.1 deg, or 0.02/alpha m) while ``s_k / s_max < 0.1``: near-planar
  noisy motion, where the value along that direction is fitted noise.

``degenerate`` is True if either kind exists. With a prior the direction takes its value
from the prior (rotation directions if ``a > 0``, translation directions if ``b > 0``).

Certificates (DQ methods): see :class:`Certificate`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcalib.geometry import rotvec_from_matrix

__all__ = ["Direction", "Observability", "analyse",
           "UNDETERMINED_REL", "WEAK_STD", "WEAK_REL"]

UNDETERMINED_REL = 1e-6
WEAK_STD = 0.02
WEAK_REL = 0.1
_PURE = 0.05  # a direction is "pure" rotation/translation if the other part is < 5 %


def _fmt_vec(v) -> str:
    return "[" + ", ".join(f"{x:+.3f}" for x in v) + "]"


@dataclass(frozen=True)
class Direction:
    """One combination of X's rotation/translation the motions do not (well) determine.

    ``kind``: "translation", "rotation" or "coupled"; ``rotation_axis_a`` and
    ``translation_dir_a``: unit 3-vectors in camera-a coordinates (zeros if absent);
    ``dims``: dimension of the subspace described (e.g. 3 for "translation in every
    direction"); ``singular_value`` (per-motion RMS, dimensionless); ``std``: predicted
    1-sigma uncertainty (rad, or m times alpha); ``reason``: "undetermined" or "weak";
    ``determined_by_prior``; ``description``: plain words.
    """
    kind: str
    rotation_axis_a: np.ndarray
    translation_dir_a: np.ndarray
    dims: int
    singular_value: float
    std: float
    reason: str
    determined_by_prior: bool
    description: str


@dataclass(frozen=True)
class Observability:
    """Observability diagnostics of a solution (see module doc).

    ``singular_values``: ascending, of the stacked linearised problem divided by sqrt(N)
    (dimensionless; rotation rows in rad, translation rows times alpha).
    ``singular_vectors``: columns (omega, alpha v) in camera-a coordinates.
    ``relative``: singular values / largest. ``residual_rms``: RMS residual of the motion
    equations at the solution (same units). ``motion``: a plain description of camera a's
    motions (rotation axes, pure translation ...).
    """
    singular_values: np.ndarray
    singular_vectors: np.ndarray
    relative: np.ndarray
    residual_rms: float
    degenerate: bool
    undetermined: tuple
    motion: str
    prior_used: bool

    def summary(self) -> str:
        if not self.degenerate:
            return (f"observability: all 6 degrees of freedom determined (smallest relative "
                    f"singular value {self.relative[0]:.3g})")
        parts = []
        for d in self.undetermined:
            what = "NOT determined by the motions" if d.reason == "undetermined" else \
                f"poorly determined (predicted 1-sigma {d.std:.3g})"
            src = ("its value comes from the prior" if d.determined_by_prior else
                   "the returned value along it is arbitrary/noise, not a measurement")
            parts.append(f"{d.description} is {what}; {src}")
        return "DEGENERATE motion (" + self.motion + "): " + "; ".join(parts)


def _linearised(C: np.ndarray, alpha: float) -> np.ndarray:
    """Stacked Jacobian blocks (N, 6, 6) acting on (omega, alpha v)."""
    N = C.shape[0]
    R = C[:, :3, :3]
    t = C[:, :3, 3] * alpha
    ImR = np.eye(3) - R
    tx = np.zeros((N, 3, 3))
    tx[:, 0, 1], tx[:, 0, 2] = -t[:, 2], t[:, 1]
    tx[:, 1, 0], tx[:, 1, 2] = t[:, 2], -t[:, 0]
    tx[:, 2, 0], tx[:, 2, 1] = -t[:, 1], t[:, 0]
    J = np.zeros((N, 6, 6))
    J[:, :3, :3] = ImR
    J[:, 3:, :3] = -tx
    J[:, 3:, 3:] = ImR
    return J


def _residuals(C, H, X, alpha) -> np.ndarray:
    """Per-motion residual 6-vectors of C_i = X H_i X^-1 (rotation vector, alpha * dt)."""
    from simcalib.geometry import invert_transform
    Ct = X @ H @ invert_transform(X)
    dR = C[:, :3, :3] @ np.swapaxes(Ct[:, :3, :3], -1, -2)
    r = np.concatenate([rotvec_from_matrix(dR), alpha * (C[:, :3, 3] - Ct[:, :3, 3])], axis=1)
    return r


def _motion_text(C: np.ndarray) -> str:
    rv = rotvec_from_matrix(C[:, :3, :3])
    ang = np.linalg.norm(rv, axis=1)
    moving = ang > 1e-6
    if not moving.any():
        return "camera a only translates (no rotation in any motion)"
    axes = rv[moving] / ang[moving, None]
    # principal axis: eigenvector of the axis scatter matrix
    w, V = np.linalg.eigh(axes.T @ axes)
    k = V[:, -1]
    spread = np.degrees(np.arccos(np.clip(np.abs(axes @ k), 0.0, 1.0))).max()
    txt = (f"{int(moving.sum())} of {len(C)} motions rotate; rotation axes within "
           f"{spread:.2g} deg of {_fmt_vec(k)} (camera-a frame)")
    if spread < 1.0:
        trans = C[:, :3, 3]
        along = np.abs(trans @ k).max() if len(trans) else 0.0
        txt += ("; planar motion (translations perpendicular to that axis)"
                if along < 1e-3 * max(np.linalg.norm(trans, axis=1).max(), 1e-12)
                else "; single rotation axis")
    return txt


def _subspace_words(U: np.ndarray, s_k: np.ndarray, std_k: np.ndarray, reason: str,
                    prior) -> list:
    """Describe span(U) (6 x k, columns (omega, alpha v)) in words, split into pure
    translation, pure rotation and coupled parts."""
    out = []
    k = U.shape[1]
    if k == 0:
        return out
    a_prior = prior is not None and prior.a > 0
    b_prior = prior is not None and prior.b > 0
    sv = float(s_k.min())
    sd = float(std_k.max())
    # pure-translation subspace: vectors in span(U) with small omega part
    Wr, Vr = np.linalg.eigh(U[:3].T @ U[:3])          # ascending omega-energy
    trans_idx = Wr < _PURE**2
    T = U @ Vr[:, trans_idx]
    Wt, Vt = np.linalg.eigh(U[3:].T @ U[3:])
    rot_idx = Wt < _PURE**2
    Rs = U @ Vt[:, rot_idx]
    used = int(trans_idx.sum()) + int(rot_idx.sum())
    if T.shape[1]:
        d = T.shape[1]
        dirs = T[3:]
        if d == 1:
            v = dirs[:, 0] / np.linalg.norm(dirs[:, 0])
            desc = f"translation of X along {_fmt_vec(v)} (camera-a frame)"
        elif d == 2:
            n = np.cross(dirs[:, 0], dirs[:, 1])
            v = n / np.linalg.norm(n)
            desc = f"translation of X within the plane perpendicular to {_fmt_vec(v)} (camera-a frame)"
        else:
            v = np.zeros(3)
            desc = "translation of X in every direction"
        out.append(Direction("translation", np.zeros(3), v, d, sv, sd, reason, b_prior, desc))
    if Rs.shape[1]:
        d = Rs.shape[1]
        if d == 1:
            v = Rs[:3, 0] / np.linalg.norm(Rs[:3, 0])
            desc = f"rotation of X about the axis {_fmt_vec(v)} (camera-a frame)"
        else:
            v = np.zeros(3)
            desc = f"rotation of X about {d} independent axes"
        out.append(Direction("rotation", v, np.zeros(3), d, sv, sd, reason, a_prior, desc))
    if used < k:
        # coupled remainder: directions orthogonal to the pure parts
        P = np.concatenate([T, Rs], axis=1) if used else np.zeros((6, 0))
        Q = U - P @ (P.T @ U) if used else U
        uq, sq, _ = np.linalg.svd(Q, full_matrices=False)
        for j in range(k - used):
            u = uq[:, j]
            w, t = u[:3], u[3:]
            ax = w / max(np.linalg.norm(w), 1e-300)
            td = t / max(np.linalg.norm(t), 1e-300)
            desc = (f"rotation of X about {_fmt_vec(ax)} coupled with a translation along "
                    f"{_fmt_vec(td)} (camera-a frame)")
            out.append(Direction("coupled", ax, td, 1, sv, sd, reason, a_prior and b_prior,
                                 desc))
    return out


def analyse(problem, X, alpha: float, prior=None, cost=None, *, weak_std: float = WEAK_STD
            ) -> Observability:
    """Observability diagnostics for solution ``X`` of ``problem`` (see module doc)."""
    C = problem.C
    N = C.shape[0]
    J = _linearised(C, alpha)
    G = np.einsum("nki,nkj->ij", J, J)
    w, V = np.linalg.eigh(0.5 * (G + G.T))
    s = np.sqrt(np.clip(w, 0.0, None))
    smax = max(s[-1], 1e-300)
    rel = s / smax
    Xf = np.asarray(X, dtype=np.float64)
    if np.isfinite(Xf).all():
        r = _residuals(C, problem.H, Xf, alpha)
        rms = float(np.sqrt(np.sum(r * r) / max(6 * N - 6, 1)))
    else:
        rms = float("nan")
    std = np.where(s > 0, (rms if np.isfinite(rms) else 0.0) / np.maximum(s, 1e-300), np.inf)
    undet = rel < UNDETERMINED_REL
    weak = ~undet & (rel < WEAK_REL) & (std > weak_std)
    directions = []
    directions += _subspace_words(V[:, undet], s[undet] / np.sqrt(N), std[undet],
                                  "undetermined", prior)
    directions += _subspace_words(V[:, weak], s[weak] / np.sqrt(N), std[weak], "weak", prior)
    degenerate = bool(undet.any() or weak.any())
    return Observability(singular_values=s / np.sqrt(N), singular_vectors=V, relative=rel,
                         residual_rms=rms, degenerate=degenerate,
                         undetermined=tuple(directions),
                         motion=_motion_text(C) if degenerate else "general motion",
                         prior_used=prior is not None)
