"""The validated input every solver function receives, and its cost.

:func:`prepare_problem` turns ``(C, H)`` into a :class:`MotionProblem`: validation,
conversion to dual quaternions and the sign alignment of each motion pair (one rule for
every method, see :mod:`simcalib.solvers.kernels.batch`), through the compiled kernel.
:func:`problem_cost` is the paper cost (8) of an estimate on a problem (numpy).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import as_real_array, check_transforms, dual_quat_from_transform, \
    quat_left_matrix, quat_right_matrix

__all__ = ["MotionProblem", "SolverOutput", "build_problem", "prepare_problem",
           "prepare_batch", "problem_cost", "batch_cost", "check_weights", "rotation_shortfall",
           "ALPHA_MIN", "ALPHA_MAX", "TURN_DEG"]

#: accepted range of alpha (1/m): outside it alpha^2 under/overflows the scale of the
#: rotation terms and exact data are no longer recovered (tests/test_solvers_api.py)
ALPHA_MIN = 1e-6
ALPHA_MAX = 1e6


#: a motion turns (beyond the pose noise) when both its rotations, C's and H's, are at least
#: this large and agree (they are equal for a rigid pair; noise gives unrelated angles)
TURN_DEG = 1.0


def rotation_shortfall(C, H) -> str | None:
    """Why the motions' rotations alone cannot give X's rotation, or None when they can:
    fewer than 2 motions (and fewer than 10 %) turn by :data:`TURN_DEG` in both C and H
    with angles within a quarter of each other. Pure translation (a cart or a linear
    stage) is such a motion: its rotations are pose noise, so a method that takes X's
    rotation from the rotation axes alone (two-step methods) would fit the noise; X's
    rotation then follows from the translations only (``t_C = R_X t_H``: dqopt and the
    other DQ methods)."""
    from simcalib.geometry import rotation_angle_rad
    a = np.degrees(rotation_angle_rad(np.asarray(C)[:, :3, :3]))
    b = np.degrees(rotation_angle_rad(np.asarray(H)[:, :3, :3]))
    turns = (np.minimum(a, b) >= TURN_DEG) & (np.abs(a - b) <= 0.25 * np.maximum(a, b))
    n = int(turns.sum())
    if n >= 2 and n >= 0.1 * a.size:
        return None
    return (f"too few motions rotate beyond the pose noise ({n} of {a.size} turn by >= "
            f"{TURN_DEG:g} deg in both streams alike; largest {max(a.max(), b.max()):.3g} "
            "deg): (nearly) pure translation, so the rotation of X is undetermined by this "
            "method's rotation step; X's rotation follows from the translations (t_C = R_X "
            "t_H) with dqopt")


@dataclass(frozen=True)
class MotionProblem:
    """Relative motions with ``C_i X = X H_i`` (``X = T_a_b``), validated and in DQ form.

    ``q_C, q_C_dual, q_H, q_H_dual`` have shape ``(N, 4)`` (x, y, z, w); ``q_C`` has
    ``w >= 0`` and ``(q_H, q_H')`` carry the sign chosen by the alignment rule.
    ``weights``: per-motion weights of the cost ``(N,)``, or None (all 1).
    """
    C: np.ndarray
    H: np.ndarray
    q_C: np.ndarray
    q_C_dual: np.ndarray
    q_H: np.ndarray
    q_H_dual: np.ndarray
    weights: np.ndarray | None = None
    sign_flips: int = 0

    @property
    def n(self) -> int:
        return self.C.shape[0]

    def kept_dqopt(self, alpha: float):
        """``(X, info)`` of dqopt without prior at ``alpha`` when :func:`prepare_problem`
        computed it (the sign alignment solves dqopt on the final alignment: the same
        kernel code on the same motions as a solve of :meth:`soa`), else None."""
        kept = self.__dict__.get("_dqopt")
        if kept is None or kept[0] != alpha:
            return None
        return kept[1].copy(), kept[2]

    def soa(self) -> np.ndarray:
        """The motions as the kernels' ``Q (16, N)`` (rows c, h, c', h'; a new array)."""
        Q = self.__dict__.get("_soa")   # the kernel's own Q, kept by prepare_problem
        if Q is not None:
            return Q.copy()
        return np.ascontiguousarray(np.concatenate(
            [self.q_C.T, self.q_H.T, self.q_C_dual.T, self.q_H_dual.T]))


@dataclass(frozen=True)
class SolverOutput:
    """What a solver function may return instead of a bare 4x4 ``X``."""
    X: np.ndarray
    diagnostics: dict = field(default_factory=dict)
    success: bool = True
    message: str = ""


def align_signs(q_C, q_H, q_H_dual):
    """Flip (q_H, q_H') where its scalar part has the opposite sign to q_C's (the start of
    the alignment; exact away from 180 degrees)."""
    sign = np.where(np.sign(q_C[..., 3]) * np.sign(q_H[..., 3]) < 0, -1.0, 1.0)[..., None]
    return q_H * sign, q_H_dual * sign


def check_weights(weights, shape: tuple, name: str = "weights") -> np.ndarray | None:
    """Per-motion weights: None, or finite, >= 0, not all zero (per problem), of ``shape``."""
    if weights is None:
        return None
    w = as_real_array(weights, name, f"an array of shape {shape} of per-motion weights")
    if w.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)} (one weight per motion); "
                         f"received shape {w.shape}")
    if not np.isfinite(w).all():
        raise ValueError(f"{name} must be finite; received a non-finite weight")
    if (w < 0).any():
        raise ValueError(f"{name} must be >= 0; received {float(w[w < 0].ravel()[0])}")
    if (w.sum(axis=-1) <= 0).any():
        raise ValueError(f"{name} are all zero (for a problem); at least one must be > 0")
    return np.ascontiguousarray(w)


def _check_pair(C, H):
    C = as_real_array(C, "C", "an array of 4x4 rigid transforms")
    H = as_real_array(H, "H", "an array of 4x4 rigid transforms")
    for arr, name in ((C, "C"), (H, "H")):
        if arr.ndim != 3 or arr.shape[-2:] != (4, 4):
            raise ValueError(f"{name} must have shape (N, 4, 4); received shape {arr.shape}")
        if arr.shape[0] < 2:
            raise ValueError(f"{name} needs at least 2 transforms; received {arr.shape[0]}")
    if C.shape[0] != H.shape[0]:
        raise ValueError(f"C and H must hold the same number of motions; received "
                         f"{C.shape[0]} and {H.shape[0]}")
    return np.ascontiguousarray(C), np.ascontiguousarray(H)


def build_problem(C, H, weights=None) -> MotionProblem:
    """Validate ``C`` and ``H`` (each ``(N, 4, 4)``, N >= 2, same N, rigid, finite) and
    convert them with the scalar-part sign rule only (numpy; no re-alignment)."""
    C, H = _check_pair(C, H)
    C = check_transforms(C, "C", min_count=2)
    H = check_transforms(H, "H", min_count=2)
    w = check_weights(weights, (C.shape[0],))
    q_C, q_C_dual = dual_quat_from_transform(C)
    q_H, q_H_dual = dual_quat_from_transform(H)
    q_H, q_H_dual = align_signs(q_C, q_H, q_H_dual)
    return MotionProblem(C, H, q_C, q_C_dual, q_H, q_H_dual, w)


def prepare_problem(C, H, alpha: float = 1.0, weights=None) -> MotionProblem:
    """Validated, converted and sign-aligned problem (compiled; see module doc)."""
    from simcalib.solvers.kernels.batch import run_batch
    from simcalib.solvers.kernels.dqcore import DQOPT
    C, H = _check_pair(C, H)
    w = check_weights(weights, (C.shape[0],))
    out = run_batch(DQOPT, np.array([float(alpha)]), C=C[None], H=H[None],
                    weights=None if w is None else w[None], keep_q=True)
    if out["bad"][0] >= 0:
        check_transforms(C, "C")
        check_transforms(H, "H")
        raise ValueError(f"motion {int(out['bad'][0])}: C or H is not a rigid transform")
    Q = out["Q"][0]
    problem = MotionProblem(C, H, Q[0:4].T.copy(), Q[8:12].T.copy(), Q[4:8].T.copy(),
                            Q[12:16].T.copy(), w, int(out["nflip"][0]))
    # soa() of these motions is Q itself (the same numbers): kept instead of re-stacked;
    # and the alignment's dqopt solution (kept_dqopt)
    object.__setattr__(problem, "_soa", Q)
    object.__setattr__(problem, "_dqopt", (float(alpha), out["X"][0], out["info"][0]))
    return problem


def prepare_batch(C, H, alphas, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """Aligned motions ``Q (B, 16, N)`` of validated ``(B, N, 4, 4)`` C, H (compiled) and
    the number of sign flips per problem ``(B,)``."""
    from simcalib.solvers.kernels.batch import run_batch
    from simcalib.solvers.kernels.dqcore import DQOPT
    out = run_batch(DQOPT, alphas, C=np.ascontiguousarray(C), H=np.ascontiguousarray(H),
                    weights=weights, keep_q=True)
    return out["Q"], out["nflip"]


def problem_cost(problem: MotionProblem, q, qd, alpha: float) -> float:
    """Cost (8) ``sum_i w_i (|A_i q|^2 + alpha^2 |B_i q + A_i q'|^2)`` at (q, q'), motion by
    motion (numpy)."""
    A = quat_left_matrix(problem.q_C) - quat_right_matrix(problem.q_H)
    B = quat_left_matrix(problem.q_C_dual) - quat_right_matrix(problem.q_H_dual)
    r1 = A @ q
    r2 = B @ q + A @ qd
    per = np.sum(r1 * r1, axis=-1) + alpha**2 * np.sum(r2 * r2, axis=-1)
    if problem.weights is not None:
        per = per * problem.weights
    return float(np.sum(per))


def batch_cost(Q, X, alphas, weights=None) -> np.ndarray:
    """Cost (8) of each ``X[b]`` on the aligned motions ``Q[b]`` (B, 16, N); non-finite X ->
    inf (numpy, vectorised)."""
    X = np.asarray(X, dtype=np.float64)
    finite = np.isfinite(X).all(axis=(-2, -1))
    q, qd = dual_quat_from_transform(np.where(finite[:, None, None], X, np.eye(4)))
    qC, qH = np.swapaxes(Q[:, 0:4], 1, 2), np.swapaxes(Q[:, 4:8], 1, 2)
    qCd, qHd = np.swapaxes(Q[:, 8:12], 1, 2), np.swapaxes(Q[:, 12:16], 1, 2)
    A = quat_left_matrix(qC) - quat_right_matrix(qH)
    B = quat_left_matrix(qCd) - quat_right_matrix(qHd)
    r1 = np.einsum("bnij,bj->bni", A, q)
    r2 = np.einsum("bnij,bj->bni", B, q) + np.einsum("bnij,bj->bni", A, qd)
    per = np.sum(r1 * r1, -1) + np.asarray(alphas)[:, None] ** 2 * np.sum(r2 * r2, -1)
    if weights is not None:
        per = per * weights
    return np.where(finite, per.sum(-1), np.inf)


def alpha_range_error(alpha) -> str:
    return (f"alpha must lie in [{ALPHA_MIN:g}, {ALPHA_MAX:g}] (1/m; outside it the "
            f"computation loses accuracy: rescale the translations instead); received "
            f"{alpha}")


