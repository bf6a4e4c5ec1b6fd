"""Executors: where the cells of a sweep run. One file per executor, one registry.

An executor is a class with ``name``, ``description`` and ``map(fn, tasks, workers)``: it
calls ``fn(*task)`` for every task and yields ``(index, result)`` as each finishes (in any
order) or ``(index, exc)`` when the task could not be run at all (a lost worker after its
retries). ``fn`` must be a module-level function (it is pickled); it handles its own errors.
The results must not depend on the executor or on ``workers`` — each task carries its own
seed. ``get(name)`` looks one up; an unknown name lists the valid ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterator, Protocol, Sequence

from simcalib.errors import ConfigError, unknown_choice

__all__ = ["Executor", "ExecutorInfo", "available", "get", "register"]


class Executor(Protocol):
    name: str

    def map(self, fn: Callable, tasks: Sequence[tuple], workers: int | None
            ) -> Iterator[tuple[int, Any]]: ...


@dataclass(frozen=True)
class ExecutorInfo:
    name: str
    description: str
    target: str          # "module:Class", imported when used (Ray only when asked for)
    extra: str = ""      # the pip extra that brings its dependency

    def load(self, **options) -> Executor:
        import importlib
        module, _, cls = self.target.partition(":")
        return getattr(importlib.import_module(module), cls)(**options)


_REGISTRY: dict[str, ExecutorInfo] = {}


def register(info: ExecutorInfo) -> None:
    if info.name in _REGISTRY:
        raise ValueError(f"executor {info.name!r} registered twice")
    _REGISTRY[info.name] = info


register(ExecutorInfo("local", "a process pool on this machine (one renderer per process)",
                      "simcalib.executors.local:LocalExecutor"))
register(ExecutorInfo("ray", "Ray tasks: a local Ray instance, or a cluster (address=auto | "
                      "ray://host:port)", "simcalib.executors.ray:RayExecutor",
                      extra="cluster"))


def available() -> list[str]:
    return list(_REGISTRY)


def get(name: str, **options) -> Executor:
    """The executor ``name`` built with ``options`` (e.g. ``address`` for Ray)."""
    try:
        info = _REGISTRY[name]
    except (KeyError, TypeError):
        raise unknown_choice("executor", name, _REGISTRY, key="executor",
                             error=ConfigError) from None
    return info.load(**options)
