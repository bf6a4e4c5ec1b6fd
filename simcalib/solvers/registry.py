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
    name: str
    fn: Callable
    family: str                 # "dq" (paper), "dq-nonlinear", "classic", "opencv"
    description: str
    uses_alpha: bool = True
    supports_prior: bool = False
    certified: bool = False     # returns a certificate of global optimality
    stochastic: bool = False    # uses the rng (random starts)
    batch_fn: Callable | None = None
    extra: dict = field(default_factory=dict)


_REGISTRY: dict[str, SolverInfo] = {}
_LOADED = False


def register(name: str, *, family: str, description: str, uses_alpha: bool = True,
             supports_prior: bool = False, certified: bool = False, stochastic: bool = False,
             batch: Callable | None = None, **extra):
    """Decorator adding a solver function to the registry under ``name``."""
    def deco(fn):
        if name in _REGISTRY:
            raise ValueError(f"solver {name!r} registered twice")
        _REGISTRY[name] = SolverInfo(name, fn, family, description, uses_alpha,
                                     supports_prior, certified, stochastic, batch, dict(extra))
        return fn
    return deco


def _load_all() -> None:
    """Import the modules that register solvers (once, lazily)."""
    global _LOADED
    if _LOADED:
        return
    _LOADED = True
    import importlib
    for mod in _SOLVER_MODULES:
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as exc:
            if exc.name != mod:  # a real import error inside the module
                raise


# Modules that register solvers; each is imported lazily on first lookup.
_SOLVER_MODULES = (
    "simcalib.solvers.dq",          # dqopt, dq2steps, dqconvrlx, dq2ndord, dq2ndord_lambda, dqitr
    "simcalib.solvers.dqpoly",      # dqoptpoly
    "simcalib.solvers.classic",     # daniilidis
    "simcalib.solvers.nonlinear",   # chvecopt, quatvecopt, dqnlopt, dqnloptrnd
    "simcalib.solvers.opencv",      # opencv_tsai, opencv_park, ...
)


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
