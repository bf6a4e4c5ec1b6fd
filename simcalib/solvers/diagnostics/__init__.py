"""Diagnostics of a hand-eye estimate.

* :mod:`.uncertainty` - covariance of the estimate, the degeneracy verdict that follows from
  it (``Solution.degenerate`` / ``undetermined`` / ``verdict``), the data-driven alpha
  (every public name of the model importable from here), built from :mod:`.inputs` (checks,
  noise model, pose bias, the error convention), :mod:`.linear_model` (residual Jacobians),
  :mod:`.covariance_steps` (the steps of ``covariance``) and :mod:`.results` (``Direction``,
  ``Uncertainty``); :mod:`.pose_noise` - the pose-noise simulation.
* :mod:`.certificate` - certificates of global optimality of DQ solutions.
* :mod:`.observability` - geometry of the motions (singular values of the linearised
  equations, a plain description of the motion); descriptive only, not the verdict.

Submodules are imported lazily by :class:`simcalib.solvers.api.Solution`.
"""
