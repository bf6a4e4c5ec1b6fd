"""Diagnostics of a hand-eye estimate (issues 8, 9).

* :mod:`.uncertainty` - covariance of the estimate, the degeneracy verdict that follows from
  it (``Solution.degenerate`` / ``undetermined`` / ``verdict``), the data-driven alpha.
* :mod:`.certificate` - certificates of global optimality of DQ solutions.
* :mod:`.observability` - geometry of the motions (singular values of the linearised
  equations, a plain description of the motion); descriptive only, not the verdict.

Submodules are imported lazily by :class:`simcalib.solvers.api.Solution`.
"""
