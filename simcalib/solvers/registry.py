"""The one registry of solvers: name -> function + metadata.

A solver module registers its methods with :func:`register`::

    @register("daniilidis", family="classic", description="...", uses_alpha=True)
    def _daniilidis(problem: MotionProblem, alpha: float, prior, rng) -> SolverOutput | np.ndarray:
        ...

The function receives a validated, sign-aligned :class:`simcalib.solvers.problem.MotionProblem`
and returns either the 4x4 estimate ``X`` or a ``SolverOutput`` (X plus method-specific
diagnostics). ``simcalib.solve`` does validation, timing, cost, observability and the
``Solution`` object; solver functions do none of that.
A method may also register a vectorised ``batch`` function (``(B, ...)`` problems at once)
used by ``simcalib.solve_batch``; without one, ``solve_batch`` loops.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from simcalib.registry import Registry

__all__ = ["SOLVERS", "SolverInfo", "register", "get", "available", "infos"]


@dataclass(frozen=True)
class SolverInfo:
    """A registered solver and what callers need to know about it.

    ``uses_alpha``: the method takes alpha; ``alpha_independent``: it takes alpha but its
    estimate does not depend on it (dq2steps: alpha^2 cancels); ``supports_prior``,
    ``supports_weights`` (per-motion weights of the cost); ``certified``: returns a
    certificate of global optimality; ``stochastic``: uses the rng; ``slow``: a nonlinear
    optimiser (experiments time fewer runs of it); ``expected_cost_us``: rough time of one
    solve at N = 100 (schedules experiment chunks, slowest first); ``extra``: the other
    metadata, e.g. ``needs_rotation`` (the method takes X's rotation from the motions'
    rotations alone: where no motion rotates beyond the noise,
    :func:`simcalib.solvers.problem.rotation_shortfall`, ``simcalib.solve`` keeps its answer
    but names the motion in the message and marks the solution degenerate).
    """
    name: str
    fn: Callable
    family: str                 # "dq" (paper), "dq-nonlinear", "classic", "opencv"
    description: str
    uses_alpha: bool = True
    supports_prior: bool = False
    certified: bool = False
    stochastic: bool = False
    batch_fn: Callable | None = None
    supports_weights: bool = False
    alpha_independent: bool = False
    slow: bool = False
    expected_cost_us: float = 100.0
    extra: dict = field(default_factory=dict)

    @property
    def depends_on_alpha(self) -> bool:
        """Whether the estimate changes with alpha."""
        return self.uses_alpha and not self.alpha_independent


def _make_info(name: str, fn: Callable, *, family: str, description: str,
               uses_alpha: bool = True, supports_prior: bool = False, certified: bool = False,
               stochastic: bool = False, batch: Callable | None = None,
               supports_weights: bool = False, alpha_independent: bool = False,
               slow: bool = False, expected_cost_us: float = 100.0, **extra) -> SolverInfo:
    return SolverInfo(name, fn, family, description, uses_alpha, supports_prior, certified,
                      stochastic, batch, supports_weights, alpha_independent, slow,
                      float(expected_cost_us), dict(extra))


#: every module of :mod:`simcalib.solvers` is imported on the first lookup (a new solver
#: file registers itself; no import list here, so no import circle with the solver modules)
SOLVERS: Registry[Callable] = Registry("method", key="method", package="simcalib.solvers",
                                       info=_make_info)


def register(name: str, *, family: str, description: str, **metadata):
    """Decorator adding a solver function to the registry under ``name`` (keywords: the
    fields of :class:`SolverInfo`, ``batch=`` the vectorised function, others go to
    ``extra``)."""
    return SOLVERS.register(name, family=family, description=description, **metadata)


#: the order solvers are listed in (tables, ``bench``, ``solvers=all``): the paper's first;
#: a family not named here comes last
FAMILY_ORDER = ("dq", "classic", "dq-nonlinear", "opencv")


def infos() -> list[SolverInfo]:
    """Every registered solver, by :data:`FAMILY_ORDER`, then module file name, then
    registration order within a module."""
    rank = {f: k for k, f in enumerate(FAMILY_ORDER)}
    return sorted(SOLVERS.available().values(),
                  key=lambda i: rank.get(i.family, len(FAMILY_ORDER)))


def available() -> list[str]:
    """Names of all registered solvers, in the order of :func:`infos`."""
    return [i.name for i in infos()]


def get(name: str) -> SolverInfo:
    """Look up a solver by name; an unknown name lists the valid ones."""
    return SOLVERS.info(name)
