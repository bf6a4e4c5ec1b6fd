"""Quaternion kernels (numba), convention (x, y, z, w).

Numpy twins live in :mod:`simcalib.geometry` (``dual_quat_from_transform``,
``quat_multiply``, ``transform_from_dual_quat``, ``check_transforms``);
``tests/test_solvers_kernels.py`` checks each kernel against its twin.
"""

from __future__ import annotations

import numpy as np
from simcalib.solvers.kernels.jit import njit

__all__ = ["dual_quat_one", "is_rigid"]

#: tolerance of the rigidity test (same as simcalib.geometry.ORTHONORMAL_TOL)
RIGID_TOL = 1e-6


@njit(cache=True, error_model="numpy", inline="always")
def _quat_dq_at(T, i):
    """(q, q') of the rigid transform T[i] as 8 scalars: same algorithm as
    geometry.quat_from_matrix (largest-diagonal branch, normalised, w >= 0) and
    q' = 1/2 (t, 0) (x) q."""
    m00 = T[i, 0, 0]
    m11 = T[i, 1, 1]
    m22 = T[i, 2, 2]
    d0 = 1.0 + m00 - m11 - m22
    d1 = 1.0 - m00 + m11 - m22
    d2 = 1.0 - m00 - m11 + m22
    d3 = 1.0 + m00 + m11 + m22
    k = 0
    dk = d0
    if d1 > dk:
        k = 1
        dk = d1
    if d2 > dk:
        k = 2
        dk = d2
    if d3 > dk:
        k = 3
        dk = d3
    s = 2.0 * np.sqrt(max(dk, 1e-300))
    inv = 1.0 / s
    d21 = (T[i, 2, 1] - T[i, 1, 2]) * inv
    d02 = (T[i, 0, 2] - T[i, 2, 0]) * inv
    d10 = (T[i, 1, 0] - T[i, 0, 1]) * inv
    s01 = (T[i, 0, 1] + T[i, 1, 0]) * inv
    s02 = (T[i, 0, 2] + T[i, 2, 0]) * inv
    s12 = (T[i, 1, 2] + T[i, 2, 1]) * inv
    if k == 0:
        x, y, z, w = 0.25 * s, s01, s02, d21
    elif k == 1:
        x, y, z, w = s01, 0.25 * s, s12, d02
    elif k == 2:
        x, y, z, w = s02, s12, 0.25 * s, d10
    else:
        x, y, z, w = d21, d02, d10, 0.25 * s
    nrm = 1.0 / np.sqrt(x * x + y * y + z * z + w * w)
    if w < 0.0:
        nrm = -nrm
    x *= nrm
    y *= nrm
    z *= nrm
    w *= nrm
    tx = 0.5 * T[i, 0, 3]
    ty = 0.5 * T[i, 1, 3]
    tz = 0.5 * T[i, 2, 3]
    # (t,0) (x) q with L(p) rows [w,-z,y,x],[z,w,-x,y],[-y,x,w,z],[-x,-y,-z,w], p_w = 0
    return (x, y, z, w, -tz * y + ty * z + tx * w, tz * x - tx * z + ty * w,
            -ty * x + tx * y + tz * w, -tx * x - ty * y - tz * z)


@njit(cache=True, error_model="numpy")
def _quat_dq(T, q, qd):
    """(q, q') of one 4x4 transform into q, qd."""
    T3 = T.reshape((1, 4, 4))
    r = _quat_dq_at(T3, 0)
    for k in range(4):
        q[k] = r[k]
        qd[k] = r[4 + k]


@njit(cache=True, error_model="numpy", inline="always")
def _rigid_ok_at(T, i, tol):
    tot = 0.0
    for r in range(4):
        for c in range(4):
            tot += T[i, r, c]
    if not np.isfinite(tot):
        return False
    if (abs(T[i, 3, 0]) > tol or abs(T[i, 3, 1]) > tol or abs(T[i, 3, 2]) > tol
            or abs(T[i, 3, 3] - 1.0) > tol):
        return False
    for a in range(3):
        for b in range(a, 3):
            g = T[i, 0, a] * T[i, 0, b] + T[i, 1, a] * T[i, 1, b] + T[i, 2, a] * T[i, 2, b]
            if a == b:
                g -= 1.0
            if abs(g) > tol:
                return False
    det = (T[i, 0, 0] * (T[i, 1, 1] * T[i, 2, 2] - T[i, 1, 2] * T[i, 2, 1])
           - T[i, 0, 1] * (T[i, 1, 0] * T[i, 2, 2] - T[i, 1, 2] * T[i, 2, 0])
           + T[i, 0, 2] * (T[i, 1, 0] * T[i, 2, 1] - T[i, 1, 1] * T[i, 2, 0]))
    return abs(det - 1.0) <= tol


@njit(cache=True, error_model="numpy")
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product (x, y, z, w) of a and b."""
    return (a3 * b0 + b3 * a0 + a1 * b2 - a2 * b1,
            a3 * b1 + b3 * a1 + a2 * b0 - a0 * b2,
            a3 * b2 + b3 * a2 + a0 * b1 - a1 * b0,
            a3 * b3 - a0 * b0 - a1 * b1 - a2 * b2)


@njit(cache=True, error_model="numpy")
def _transform_from_dq(q, qd, X):
    x, y, z, w = q[0], q[1], q[2], q[3]
    X[0, 0] = 1 - 2 * (y * y + z * z)
    X[0, 1] = 2 * (x * y - z * w)
    X[0, 2] = 2 * (x * z + y * w)
    X[1, 0] = 2 * (x * y + z * w)
    X[1, 1] = 1 - 2 * (x * x + z * z)
    X[1, 2] = 2 * (y * z - x * w)
    X[2, 0] = 2 * (x * z - y * w)
    X[2, 1] = 2 * (y * z + x * w)
    X[2, 2] = 1 - 2 * (x * x + y * y)
    # t = 2 q' (x) conj(q), vector part
    a, b, c, d = qd[0], qd[1], qd[2], qd[3]
    X[0, 3] = 2.0 * (-d * x + a * w - b * z + c * y)
    X[1, 3] = 2.0 * (-d * y + b * w - c * x + a * z)
    X[2, 3] = 2.0 * (-d * z + c * w - a * y + b * x)
    X[3, 0] = 0.0
    X[3, 1] = 0.0
    X[3, 2] = 0.0
    X[3, 3] = 1.0


@njit(cache=True, error_model="numpy")
def _rigid_one(T, tol):
    return _rigid_ok_at(T.reshape((1, 4, 4)), 0, tol)


def dual_quat_one(X):
    """(q, q') of one 4x4 transform (compiled twin of geometry.dual_quat_from_transform)."""
    q = np.empty(4)
    qd = np.empty(4)
    _quat_dq(np.ascontiguousarray(X, dtype=np.float64), q, qd)
    return q, qd


def is_rigid(X, tol: float = RIGID_TOL) -> bool:
    """One 4x4 float64 array is a rigid transform (twin of geometry.check_transforms)."""
    return bool(_rigid_one(np.ascontiguousarray(X, dtype=np.float64), tol))
