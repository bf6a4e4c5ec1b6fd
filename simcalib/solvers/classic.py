"""Daniilidis (1999) dual-quaternion SVD method, with the paper's alpha scaling.

K. Daniilidis, "Hand-eye calibration using dual quaternions", IJRR 18 (1999) 286-298.

For each motion (C_i, H_i) with sign-aligned dual quaternions ``a + eps a'`` (of C_i) and
``b + eps b'`` (of H_i) the method stacks the 6x8 block (quaternions (x, y, z, w))::

    [ [a+b]x      a-b      0       0   ]   ( q  )
    [ [a'+b']x    a'-b'    [a+b]x  a-b ] . ( q' ) = 0

(the vector parts of ``a q = q b`` and its dual part; the scalar equations are dropped, as in
the paper, because they hold identically for exact screw motions). The two right singular
vectors ``v1, v2`` of the 6N x 8 matrix with the smallest singular values span the solution
space; ``q + eps q' = l1 v1 + l2 v2`` with ``|q| = 1`` and ``q . q' = 0`` gives a quadratic
in ``l1 / l2``. Dekel et al. (sec. 4.3) scale the translation part by ``alpha`` for a fair
comparison: translations of C and H are multiplied by ``alpha`` before the SVD and the
resulting translation divided by it (alpha = 1 is the original method).

Degenerate input (more than two near-zero singular values, i.e. the motions do not fix X)
is reported through ``SolverOutput.success = False`` and a message naming the undetermined
directions; the returned X is then one arbitrary member of the solution set.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import transform_from_dual_quat
from simcalib.solvers.problem import MotionProblem, SolverOutput
from simcalib.solvers.registry import register

__all__ = ["daniilidis_matrix", "daniilidis", "unit_dual_quat_from_span",
           "describe_motion_degeneracy"]

# A singular value below NULL_TOL * (largest singular value) counts as zero.
NULL_TOL = 1e-10


def _skew(v: np.ndarray) -> np.ndarray:
    """``[v]x`` for ``(..., 3)`` vectors -> ``(..., 3, 3)``."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack([np.stack([o, -z, y], -1),
                     np.stack([z, o, -x], -1),
                     np.stack([-y, x, o], -1)], axis=-2)


def daniilidis_matrix(problem: MotionProblem, alpha: float = 1.0) -> np.ndarray:
    """The stacked ``(6N, 8)`` Daniilidis matrix acting on ``(q, alpha q')``."""
    a, ad = problem.q_C, problem.q_C_dual * alpha
    b, bd = problem.q_H, problem.q_H_dual * alpha
    n = a.shape[0]
    T = np.zeros((n, 6, 8))
    T[:, :3, :3] = _skew(a[:, :3] + b[:, :3])
    T[:, :3, 3] = a[:, :3] - b[:, :3]
    T[:, 3:, :3] = _skew(ad[:, :3] + bd[:, :3])
    T[:, 3:, 3] = ad[:, :3] - bd[:, :3]
    T[:, 3:, 4:7] = T[:, :3, :3]
    T[:, 3:, 7] = T[:, :3, 3]
    return T.reshape(6 * n, 8)


def unit_dual_quat_from_span(v1: np.ndarray, v2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The unit dual quaternion ``l1 v1 + l2 v2`` (8-vectors ``(q, q')``) with ``|q| = 1`` and
    ``q . q' = 0`` (Daniilidis' quadratic). Returns ``(q, q')``.

    Written on the circle ``(l1, l2) = (cos t, sin t)``: the constraint ``q . q' = 0`` is a
    2x2 quadratic form ``Qd`` that must vanish; of its (up to two) null directions the one
    with the larger ``|q|`` is taken and scaled to ``|q| = 1``. With noise ``Qd`` may be
    definite (no exact solution); then the direction where ``|q . q'|`` is smallest relative
    to ``|q|^2`` is used and the remaining ``q . q'`` is projected away.
    """
    u1, w1, u2, w2 = v1[:4], v1[4:], v2[:4], v2[4:]
    Qd = np.array([[u1 @ w1, 0.5 * (u1 @ w2 + u2 @ w1)],
                   [0.5 * (u1 @ w2 + u2 @ w1), u2 @ w2]])
    Qu = np.array([[u1 @ u1, u1 @ u2], [u1 @ u2, u2 @ u2]])
    e, P = np.linalg.eigh(Qd)
    cands = []
    if e[0] <= 0.0 <= e[1]:
        c = np.array([np.sqrt(max(e[1], 0.0)), np.sqrt(max(-e[0], 0.0))])
        if c @ c == 0.0:       # Qd == 0: every direction satisfies the constraint
            cands = [P[:, 0], P[:, 1]]
        else:
            c /= np.linalg.norm(c)
            cands = [P @ c, P @ (c * np.array([1.0, -1.0]))]
    else:
        # no real solution (noise): generalised eigenvector minimising |Qd| / Qu
        ev, V = np.linalg.eig(np.linalg.solve(Qu + 1e-300 * np.eye(2), Qd))
        k = int(np.argmin(np.abs(ev.real)))
        cands = [np.real(V[:, k])]
    best = max(cands, key=lambda l: l @ Qu @ l)
    l = best / np.sqrt(best @ Qu @ best)
    x = l[0] * v1 + l[1] * v2
    q, qd = x[:4], x[4:]
    if q[3] < 0:
        q, qd = -q, -qd
    return q, qd


def describe_motion_degeneracy(problem: MotionProblem, tol_rad: float = 1e-6) -> str:
    """Plain-words description of why motions may not determine X (rotation axes of C)."""
    q = problem.q_C
    s = np.linalg.norm(q[:, :3], axis=1)
    angles = 2.0 * np.arctan2(s, np.abs(q[:, 3]))
    if angles.max() < tol_rad:
        return ("no motion rotates (max angle {:.3g} rad): the rotation of X is "
                "undetermined".format(angles.max()))
    rot = angles >= tol_rad
    axes = q[rot, :3] / s[rot, None]
    _, sv, Vt = np.linalg.svd(axes, full_matrices=False)
    if sv.size < 2 or sv[1] < tol_rad * max(sv[0], 1.0):
        ax = Vt[0] * np.sign(Vt[0][np.argmax(np.abs(Vt[0]))])
        return ("all rotation axes are parallel to ({:.3f}, {:.3f}, {:.3f}) in frame a "
                "(planar or single-axis motion): the translation of X along that axis is "
                "undetermined".format(*ax))
    return "the motions are (numerically) degenerate"


def daniilidis(problem: MotionProblem, alpha: float = 1.0) -> SolverOutput:
    T = daniilidis_matrix(problem, alpha)
    _, sv, Vt = np.linalg.svd(T, full_matrices=False)
    q, qd_scaled = unit_dual_quat_from_span(Vt[-2], Vt[-1])
    X = transform_from_dual_quat(q, qd_scaled / alpha)
    n_null = int(np.sum(sv <= NULL_TOL * sv[0])) if sv[0] > 0 else 8
    diag = {"singular_values": sv, "n_null": n_null}
    if n_null > 2:
        return SolverOutput(X, diag, success=False, message=(
            f"degenerate motions for Daniilidis: the {T.shape[0]}x8 matrix has {n_null} "
            f"near-zero singular values (a unique X needs exactly 2): "
            f"{describe_motion_degeneracy(problem)}; the returned X is one arbitrary "
            f"solution"))
    return SolverOutput(X, diag, success=True,
                        message="ok" if sv[-3] > 0 else "ok (exact null space)")


@register("daniilidis", family="classic", uses_alpha=True, supports_prior=False,
          description="Daniilidis 1999 dual-quaternion SVD (translation scaled by alpha)")
def _daniilidis(problem: MotionProblem, alpha: float, prior, rng) -> SolverOutput:
    if prior is not None:
        raise ValueError("daniilidis does not support a prior; received prior="
                         f"{prior!r}; use a DQ method (e.g. dqopt) for priors")
    return daniilidis(problem, alpha)
