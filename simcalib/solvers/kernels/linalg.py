"""Symmetric eigen-decomposition of 4x4 matrices by cyclic Jacobi (numba).

Numpy twin: :func:`numpy.linalg.eigh` (ascending eigenvalues, eigenvectors in columns);
``tests/test_solvers_kernels.py`` checks the two agree. Jacobi is used inside the compiled
solvers because it is accurate for the tiny eigenvalues of noise-free data and needs no
LAPACK call from numba. The kernels are written for 4x4 (loops of constant length, which
LLVM unrolls; ~15 % less time than with the size read at run time, the same arithmetic) and
take their scratch matrices from the caller (no allocation per call).
"""

from __future__ import annotations

import numpy as np
from simcalib.solvers.kernels.jit import njit

__all__ = ["eigh", "eigh_numpy"]


@njit(cache=True, error_model="numpy")
def _eigh(A, w, V, a):
    """Symmetric eigen-decomposition of the 4x4 ``A`` by cyclic Jacobi (accurate);
    ascending ``w``, eigenvectors in the columns of ``V``; ``a``: 4x4 scratch (may be A)."""
    for i in range(4):
        for j in range(4):
            a[i, j] = A[i, j]
            V[i, j] = 1.0 if i == j else 0.0
    _jacobi(a, w, V)


@njit(cache=True, error_model="numpy")
def _eigh_warm(A, V0, w, V, a, tmp):
    """As :func:`_eigh`, starting from the approximate eigenvectors V0 (columns); ``a``,
    ``tmp``: 4x4 scratch."""
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for k in range(4):
                acc += A[i, k] * V0[k, j]
            tmp[i, j] = acc
    for i in range(4):
        for j in range(i, 4):
            acc = 0.0
            for k in range(4):
                acc += V0[k, i] * tmp[k, j]
            a[i, j] = acc
            a[j, i] = acc
    for i in range(4):
        for j in range(4):
            V[i, j] = V0[i, j]
    _jacobi(a, w, V)


@njit(cache=True, error_model="numpy")
def _jacobi(a, w, V):
    """Cyclic Jacobi on the symmetric 4x4 matrix a (overwritten); V accumulates rotations."""
    n = 4
    for sweep in range(40):
        off = 0.0
        dg = 0.0
        for p in range(n):
            dg += a[p, p] * a[p, p]
            for q in range(p + 1, n):
                off += a[p, q] * a[p, q]
        if off == 0.0 or off <= 1e-38 * dg:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                if abs(apq) < 1e-20 * (abs(a[p, p]) + abs(a[q, q])):
                    a[p, q] = 0.0
                    a[q, p] = 0.0
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                if abs(theta) > 1e150:
                    t = 0.5 / theta
                else:
                    t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):
                    akp = a[k, p]
                    akq = a[k, q]
                    a[k, p] = c * akp - s * akq
                    a[k, q] = s * akp + c * akq
                for k in range(n):
                    apk = a[p, k]
                    aqk = a[q, k]
                    a[p, k] = c * apk - s * aqk
                    a[q, k] = s * apk + c * aqk
                for k in range(n):
                    vkp = V[k, p]
                    vkq = V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
    for i in range(n):
        w[i] = a[i, i]
    # insertion sort (ascending) with columns
    for i in range(1, n):
        j = i
        while j > 0 and w[j - 1] > w[j]:
            tmp = w[j - 1]
            w[j - 1] = w[j]
            w[j] = tmp
            for k in range(n):
                tmp = V[k, j - 1]
                V[k, j - 1] = V[k, j]
                V[k, j] = tmp
            j -= 1


def eigh(A):
    """(w, V) of the symmetric 4x4 matrix A by the compiled Jacobi kernel (test entry
    point)."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    if A.shape != (4, 4):
        raise ValueError(f"A must be a 4x4 matrix; received shape {A.shape}")
    w = np.empty(4)
    V = np.empty((4, 4))
    _eigh(A, w, V, np.empty((4, 4)))
    return w, V


def eigh_numpy(A):
    """Numpy twin of :func:`eigh`."""
    return np.linalg.eigh(np.asarray(A, dtype=np.float64))
