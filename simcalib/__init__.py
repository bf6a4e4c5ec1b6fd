"""simcalib — how well will a hand-eye / eye-to-eye calibration work before you trust it?

Library entry points::

    import simcalib
    sol = simcalib.solve(C, H, method="dqopt", alpha=1.0)   # C_i X = X H_i, X = T_a_b
    batch = simcalib.solve_batch(C_batch, H_batch, method="dqopt", alpha=alphas)
    result = simcalib.run(config)                            # a whole simulated scenario
    off = simcalib.estimate_time_offset(stream_a, stream_b)  # clock offset t_b - t_a

Conventions: ``docs/conventions.md``.
"""

from __future__ import annotations

from simcalib.solvers.api import BatchSolution, Prior, Solution, solve, solve_batch
from simcalib.estimation.alignment import estimate_time_offset

from simcalib.config.resources import package_version

__version__ = package_version()

__all__ = ["BatchSolution", "Prior", "Solution", "__version__", "estimate_time_offset",
           "load_config", "run", "solve", "solve_batch"]


def load_config(scenario, overrides=()):
    """Resolve a scenario (name, YAML path, mapping or a config) plus overrides (``"k=v"``
    strings or a mapping of dotted key -> value) into a validated ``ScenarioConfig``:
    :func:`simcalib.pipeline.scenario.load_config`. The scenario schema (which imports the
    world's configs) is imported here, at the first call, so ``import simcalib`` stays light."""
    from simcalib.pipeline.scenario import load_config
    return load_config(scenario, overrides)


def run(config, overrides=(), *, echo: bool = True):
    """Run one scenario end to end and write its outputs: :func:`simcalib.pipeline.stages.run`.

    ``config``: a ``ScenarioConfig`` (:func:`load_config`) or a scenario name / YAML path,
    resolved with ``overrides`` (``["seed=3", ...]``); ``echo`` prints the summary table.
    Returns a :class:`simcalib.pipeline.state.RunResult`. The pipeline (world, rendering,
    recording) is imported here, at the first run, so ``import simcalib`` stays light.
    """
    from simcalib.pipeline import stages as pipeline
    return pipeline.run(config, overrides, echo=echo)
