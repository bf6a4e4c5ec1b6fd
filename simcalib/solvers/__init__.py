"""Hand-eye solvers: the dual-quaternion methods of Dekel et al. (CVPR 2020) and classics.

``available()`` lists the registered method names; ``get(name)`` returns their metadata.

The folder is layered, each layer importing only those below it (no import circle:
``tests/test_packaging.py``), top to bottom:

* ``api`` - ``simcalib.solve`` (``single`` plus ``robust=``) and the public names;
* ``robust`` - RANSAC and IRLS, which solve subsets and weighted problems through
  ``single.solve_single`` and ``batch_solve.solve_batch``;
* ``single`` - the plain single-problem solve: checks, the timed solver call, the
  ``Solution``;
* ``solution`` (``Solution``, its diagnostics evaluated on first read) over
  ``batch_solve`` (``solve_batch``, ``BatchSolution``);
* ``diagnostics/`` (uncertainty, certificate, observability), ``validation`` (``Prior``,
  input checks, ``dq_cost``), ``registry`` (the method families ``dq``, ``dqpoly``,
  ``classic``, ``nonlinear``, ``opencv`` register into it and are found by discovery);
* ``problem`` - ``MotionProblem``, ``prepare_problem``, the cost;
* ``kernels/`` - the compiled kernels (numba, imported at their first call) and how a
  command runs them (``kernels.mode``); they know nothing of the layers above.
"""

from simcalib.solvers.registry import available, get, infos, register

__all__ = ["available", "get", "infos", "register"]
