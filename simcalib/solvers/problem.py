"""The validated input every solver function receives."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import check_transforms, dual_quat_from_transform

__all__ = ["MotionProblem", "SolverOutput", "build_problem"]


@dataclass(frozen=True)
class MotionProblem:
    """Relative motions with ``C_i X = X H_i`` (``X = T_a_b``), validated and in DQ form.

    ``q_C, q_C_dual, q_H, q_H_dual`` have shape ``(N, 4)`` (x, y, z, w). ``q_H``/``q_H_dual``
    are sign-aligned so that the scalar parts of ``q_C`` and ``q_H`` have the same sign
    (NOTES.md, "double cover"); ``q_C`` has ``w >= 0``.
    """
    C: np.ndarray
    H: np.ndarray
    q_C: np.ndarray
    q_C_dual: np.ndarray
    q_H: np.ndarray
    q_H_dual: np.ndarray

    @property
    def n(self) -> int:
        return self.C.shape[0]


@dataclass(frozen=True)
class SolverOutput:
    """What a solver function may return instead of a bare 4x4 ``X``."""
    X: np.ndarray
    diagnostics: dict = field(default_factory=dict)
    success: bool = True
    message: str = ""


def align_signs(q_C, q_H, q_H_dual):
    """Flip (q_H, q_H') where its scalar part has the opposite sign to q_C's."""
    sign = np.where(np.sign(q_C[..., 3]) * np.sign(q_H[..., 3]) < 0, -1.0, 1.0)[..., None]
    return q_H * sign, q_H_dual * sign


def build_problem(C, H) -> MotionProblem:
    """Validate ``C`` and ``H`` (each ``(N, 4, 4)``, N >= 2, same N, rigid, finite)."""
    C = check_transforms(C, "C", min_count=2)
    H = check_transforms(H, "H", min_count=2)
    if C.shape[0] != H.shape[0]:
        raise ValueError(f"C and H must hold the same number of motions; received "
                         f"{C.shape[0]} and {H.shape[0]}")
    q_C, q_C_dual = dual_quat_from_transform(C)
    q_H, q_H_dual = dual_quat_from_transform(H)
    q_H, q_H_dual = align_signs(q_C, q_H, q_H_dual)
    return MotionProblem(C, H, q_C, q_C_dual, q_H, q_H_dual)
