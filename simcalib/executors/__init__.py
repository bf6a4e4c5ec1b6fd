"""Executors: where the cells of a sweep run. One file per executor, one registry.

An executor is a class with ``name`` and ``map(fn, tasks, workers)``: it calls
``fn(*task)`` for every task and yields ``(index, result)`` as each finishes (in any order)
or ``(index, exc)`` when the task could not be run at all (a lost worker after its
retries). ``fn`` must be a module-level function (a process executor pickles it); it
handles its own errors. The results must not depend on the executor or on ``workers`` —
each task carries its own seed.

A file of this folder registers its class (discovered on the first lookup, no list to
edit)::

    @register("local", description="a process pool on this machine")
    class LocalExecutor: ...

``get(name, **options)`` builds one; an unknown name lists the valid ones; ``available()``
maps each name to its :class:`ExecutorInfo`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterator, Protocol, Sequence

from simcalib.registry import Registry

__all__ = ["EXECUTORS", "Executor", "ExecutorInfo", "available", "get", "register"]


class Executor(Protocol):
    name: str

    def map(self, fn: Callable, tasks: Sequence[tuple], workers: int | None
            ) -> Iterator[tuple[int, Any]]: ...


@dataclass(frozen=True)
class ExecutorInfo:
    """A registered executor: ``cls`` is built with the caller's options; ``extra`` is
    the pip extra that brings its dependency ("" = none)."""
    name: str
    cls: type
    description: str
    extra: str = ""


def _info(name: str, cls: type, *, description: str, extra: str = "") -> ExecutorInfo:
    if not callable(getattr(cls, "map", None)):
        raise TypeError(f"executor {name!r} needs a map(fn, tasks, workers) method; "
                        f"received {cls!r}")
    return ExecutorInfo(name, cls, description, extra)


EXECUTORS: Registry[type] = Registry("executor", key="executor",
                                     package="simcalib.executors", info=_info)


def register(name: str, *, description: str, extra: str = ""):
    """Class decorator adding an executor under ``name``."""
    return EXECUTORS.register(name, description=description, extra=extra)


def available() -> dict[str, ExecutorInfo]:
    """name -> :class:`ExecutorInfo` of every executor."""
    return EXECUTORS.available()


def get(name: str, **options) -> Executor:
    """The executor ``name`` built with ``options`` (e.g. ``address`` for Ray)."""
    return EXECUTORS.get(name)(**options)
