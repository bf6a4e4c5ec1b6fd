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

import difflib
from dataclasses import dataclass, field
from typing import Callable

__all__ = ["SolverInfo", "register", "get", "available", "infos"]


@dataclass(frozen=True)
class SolverInfo:
    """A registered solver and what callers need to know about it.

    ``uses_alpha``: the method takes alpha; ``alpha_independent``: it takes alpha but its
    estimate does not depend on it (dq2steps: alpha^2 cancels); ``supports_prior``,
    ``supports_weights`` (per-motion weights of the cost); ``certified``: returns a
    certificate of global optimality; ``stochastic``: uses the rng; ``slow``: a nonlinear
    optimiser (experiments time fewer runs of it); ``expected_cost_us``: rough time of one
    solve at N = 100 (schedules experiment chunks, slowest first).
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


_REGISTRY: dict[str, SolverInfo] = {}
_LOADED = False


def register(name: str, *, family: str, description: str, uses_alpha: bool = True,
             supports_prior: bool = False, certified: bool = False, stochastic: bool = False,
             batch: Callable | None = None, supports_weights: bool = False,
             alpha_independent: bool = False, slow: bool = False,
             expected_cost_us: float = 100.0, **extra):
    """Decorator adding a solver function to the registry under ``name``."""
    def deco(fn):
        if name in _REGISTRY:
            raise ValueError(f"solver {name!r} registered twice")
        _REGISTRY[name] = SolverInfo(name, fn, family, description, uses_alpha,
                                     supports_prior, certified, stochastic, batch,
                                     supports_weights, alpha_independent, slow,
                                     float(expected_cost_us), dict(extra))
        return fn
    return deco


def _load_all() -> None:
    """Import the modules that register solvers (once, on first lookup)."""
    global _LOADED
    if _LOADED:
        return
    _LOADED = True
    # each module registers its methods at import (cv2, scipy are imported lazily inside)
    from simcalib.solvers import dq  # noqa: F401  dqopt, dq2steps, dqconvrlx, dq2ndord, ...
    from simcalib.solvers import dqpoly  # noqa: F401  dqoptpoly
    from simcalib.solvers import classic  # noqa: F401  daniilidis
    from simcalib.solvers import nonlinear  # noqa: F401  chvecopt, quatvecopt, dqnlopt, ...
    from simcalib.solvers import opencv  # noqa: F401  opencv_tsai, opencv_park, ...


def available() -> list[str]:
    """Names of all registered solvers, in registration order."""
    _load_all()
    return list(_REGISTRY)


def infos() -> list[SolverInfo]:
    _load_all()
    return list(_REGISTRY.values())


def get(name: str) -> SolverInfo:
    """Look up a solver by name; an unknown name lists the valid ones."""
    _load_all()
    if not isinstance(name, str):
        raise TypeError(f"method must be a string; received {type(name).__name__}")
    try:
        return _REGISTRY[name]
    except KeyError:
        close = difflib.get_close_matches(name, list(_REGISTRY), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(f"unknown method {name!r}{hint}; available: "
                         f"{', '.join(_REGISTRY)}") from None
