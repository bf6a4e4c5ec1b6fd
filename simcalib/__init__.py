"""simcalib — how well will a hand-eye / eye-to-eye calibration work before you trust it?

Library entry points (heavy dependencies are imported lazily)::

    import simcalib
    sol = simcalib.solve(C, H, method="dqopt", alpha=1.0)   # C_i X = X H_i, X = T_a_b
    batch = simcalib.solve_batch(C_batch, H_batch, method="dqopt", alpha=alphas)
    result = simcalib.run(config)                            # a whole simulated scenario
    off = simcalib.estimate_time_offset(stream_a, stream_b)  # clock offset t_b - t_a

Conventions: ``docs/conventions.md``.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_LAZY = {
    "solve": "simcalib.solvers.api",
    "solve_batch": "simcalib.solvers.api",
    "Solution": "simcalib.solvers.api",
    "BatchSolution": "simcalib.solvers.api",
    "Prior": "simcalib.solvers.api",
    "run": "simcalib.pipeline",
    "load_config": "simcalib.config",
    "estimate_time_offset": "simcalib.timesync",
}

__all__ = sorted(_LAZY) + ["__version__"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'simcalib' has no attribute {name!r}")
