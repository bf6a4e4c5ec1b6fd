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


@njit(cache=True, error_model="numpy")
def _dq_rows(T, Q, r0, r1):
    """(q, q') of every rigid transform T[i] (T (N, 4, 4)) into Q[r0:r0+4, i] and
    Q[r1:r1+4, i]: same algorithm as geometry.quat_from_matrix (largest-diagonal branch,
    normalised, w >= 0) and q' = 1/2 (t, 0) (x) q.

    Written without branches (the branch choice is a select) and over all motions at once,
    so that LLVM vectorises the loop (sqrt and divisions 8 motions at a time); the values
    are bit for bit those of the scalar algorithm."""
    for i in range(T.shape[0]):
        m00 = T[i, 0, 0]
        m11 = T[i, 1, 1]
        m22 = T[i, 2, 2]
        d0 = 1.0 + m00 - m11 - m22
        d1 = 1.0 - m00 + m11 - m22
        d2 = 1.0 - m00 - m11 + m22
        d3 = 1.0 + m00 + m11 + m22
        # largest diagonal term, the first one on ties: branch k is 3 if c3, else 2 if c2,
        # else 1 if c1, else 0
        c1 = d1 > d0
        dk = d1 if c1 else d0
        c2 = d2 > dk
        dk = d2 if c2 else dk
        c3 = d3 > dk
        dk = d3 if c3 else dk
        dk = dk if dk > 1e-300 else 1e-300
        s = 2.0 * np.sqrt(dk)
        inv = 1.0 / s
        d21 = (T[i, 2, 1] - T[i, 1, 2]) * inv
        d02 = (T[i, 0, 2] - T[i, 2, 0]) * inv
        d10 = (T[i, 1, 0] - T[i, 0, 1]) * inv
        s01 = (T[i, 0, 1] + T[i, 1, 0]) * inv
        s02 = (T[i, 0, 2] + T[i, 2, 0]) * inv
        s12 = (T[i, 1, 2] + T[i, 2, 1]) * inv
        q4 = 0.25 * s
        x = d21 if c3 else (s02 if c2 else (s01 if c1 else q4))
        y = d02 if c3 else (s12 if c2 else (q4 if c1 else s01))
        z = d10 if c3 else (q4 if c2 else (s12 if c1 else s02))
        w = q4 if c3 else (d10 if c2 else (d02 if c1 else d21))
        nrm = 1.0 / np.sqrt(x * x + y * y + z * z + w * w)
        nrm = -nrm if w < 0.0 else nrm
        x *= nrm
        y *= nrm
        z *= nrm
        w *= nrm
        tx = 0.5 * T[i, 0, 3]
        ty = 0.5 * T[i, 1, 3]
        tz = 0.5 * T[i, 2, 3]
        Q[r0, i] = x
        Q[r0 + 1, i] = y
        Q[r0 + 2, i] = z
        Q[r0 + 3, i] = w
        # (t,0) (x) q with L(p) rows [w,-z,y,x],[z,w,-x,y],[-y,x,w,z],[-x,-y,-z,w], p_w = 0
        Q[r1, i] = -tz * y + ty * z + tx * w
        Q[r1 + 1, i] = tz * x - tx * z + ty * w
        Q[r1 + 2, i] = -ty * x + tx * y + tz * w
        Q[r1 + 3, i] = -tx * x - ty * y - tz * z


@njit(cache=True, error_model="numpy")
def _quat_dq(T, q, qd):
    """(q, q') of one 4x4 transform into q, qd."""
    Q = np.empty((8, 1))
    _dq_rows(T.reshape((1, 4, 4)), Q, 0, 4)
    for k in range(4):
        q[k] = Q[k, 0]
        qd[k] = Q[4 + k, 0]


@njit(cache=True, error_model="numpy", inline="always")
def _rigid_ok_at(T, i, tol):
    """T[i] is a rigid transform within tol (every comparison fails on NaN; an infinite
    entry makes a Gram term or the translation sum non-finite). Branch-free, so that a
    loop over motions vectorises."""
    ok = abs(T[i, 0, 3] + T[i, 1, 3] + T[i, 2, 3]) < np.inf
    ok &= abs(T[i, 3, 0]) <= tol
    ok &= abs(T[i, 3, 1]) <= tol
    ok &= abs(T[i, 3, 2]) <= tol
    ok &= abs(T[i, 3, 3] - 1.0) <= tol
    g00 = T[i, 0, 0] * T[i, 0, 0] + T[i, 1, 0] * T[i, 1, 0] + T[i, 2, 0] * T[i, 2, 0] - 1.0
    g11 = T[i, 0, 1] * T[i, 0, 1] + T[i, 1, 1] * T[i, 1, 1] + T[i, 2, 1] * T[i, 2, 1] - 1.0
    g22 = T[i, 0, 2] * T[i, 0, 2] + T[i, 1, 2] * T[i, 1, 2] + T[i, 2, 2] * T[i, 2, 2] - 1.0
    g01 = T[i, 0, 0] * T[i, 0, 1] + T[i, 1, 0] * T[i, 1, 1] + T[i, 2, 0] * T[i, 2, 1]
    g02 = T[i, 0, 0] * T[i, 0, 2] + T[i, 1, 0] * T[i, 1, 2] + T[i, 2, 0] * T[i, 2, 2]
    g12 = T[i, 0, 1] * T[i, 0, 2] + T[i, 1, 1] * T[i, 1, 2] + T[i, 2, 1] * T[i, 2, 2]
    ok &= abs(g00) <= tol
    ok &= abs(g01) <= tol
    ok &= abs(g02) <= tol
    ok &= abs(g11) <= tol
    ok &= abs(g12) <= tol
    ok &= abs(g22) <= tol
    det = (T[i, 0, 0] * (T[i, 1, 1] * T[i, 2, 2] - T[i, 1, 2] * T[i, 2, 1])
           - T[i, 0, 1] * (T[i, 1, 0] * T[i, 2, 2] - T[i, 1, 2] * T[i, 2, 0])
           + T[i, 0, 2] * (T[i, 1, 0] * T[i, 2, 1] - T[i, 1, 1] * T[i, 2, 0]))
    ok &= abs(det - 1.0) <= tol
    return ok


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
