"""Compiled kernels of the DQ solvers (numba), each with a numpy twin checked in
``tests/test_solvers_kernels.py``: ``linalg`` (Jacobi eigensolver), ``quaternion``,
``gram`` (Gram accumulation, (S, W, M) assembly), ``dqcore`` (the methods on (S, W, M)),
``batch`` (the fused per-problem kernel used by solve and, on threads, solve_batch).

``jit`` holds the ``njit`` they are decorated with: numba itself is imported at the first
kernel call, not when the kernels (or ``simcalib``) are imported.

Compilation: every kernel is ``cache=True``; see docs/solvers.md ("Start-up").
"""
