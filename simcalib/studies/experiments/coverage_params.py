"""The parameters of the coverage experiment (:mod:`simcalib.studies.experiments.coverage`),
which its page (:mod:`simcalib.studies.experiments.coverage_doc`) also states."""

from __future__ import annotations

import numpy as np

__all__ = ["COVERAGE_CASES", "FLAG_ALPHAS", "PRIOR_AB", "CART_SCENARIOS", "ALPHA_GRID"]

#: (method, alpha, with a prior) of each coverage row
COVERAGE_CASES = (("dqopt", 0.3, False), ("dqopt", 1.0, False), ("dqopt", 3.0, False),
                  ("dq2steps", 1.0, False), ("daniilidis", 1.0, False), ("dqopt", 1.0, True))
#: the alphas at which the line / circle flags are checked
FLAG_ALPHAS = (0.1, 1.0, 10.0, 30.0)
#: the prior's weights a, b
PRIOR_AB = (100.0, 100.0)
#: the cart scenarios of the alpha comparison
CART_SCENARIOS = ("planar", "linear", "circular", "rotation", "3d")
#: the oracle's alpha grid
ALPHA_GRID = np.logspace(-2, 1.7, 40)
