"""The one registry type: things looked up by name (solvers, pose sources, platforms,
paths, importers, executors, commands, experiments).

    from simcalib.registry import Registry
    EXECUTORS = Registry("executor", key="executor", package="simcalib.executors")

    @EXECUTORS.register("threads", description="a thread pool")     # decorator form
    class ThreadExecutor: ...

    EXECUTORS.register("local", LocalExecutor, description="...")  # call form
    EXECUTORS.get("thread")    # ConfigError: unknown executor 'thread' (did you mean
                               # 'threads'?); available: local, threads
    EXECUTORS.available()      # {"local": <info>, "threads": <info>}

``register(name, obj, **metadata)`` stores ``obj`` and its *info*: ``info(name, obj,
**metadata)`` when the registry was given an ``info`` factory (usually a frozen dataclass
such as ``SolverInfo``), else ``obj.info`` when the object carries one, else the metadata
as a read-only mapping. A name registered twice is refused (the same object again is a
no-op: a module imported twice under one name re-registers nothing new);
``unregister(name)`` removes an entry (a test's temporary one).

**Discovery.** With ``package="simcalib.executors"`` the first lookup imports every module
of that package folder once (``pkgutil``, names starting with ``_`` skipped), so a new file
in the folder that registers itself is found with no import list to edit. Modules are
imported in file-name order; a module that fails to import raises (a broken plug-in is an
error, not a silently missing entry).
"""

from __future__ import annotations

import importlib
import pkgutil
from types import MappingProxyType
from typing import Any, Callable, Generic, Iterator, TypeVar

from simcalib.errors import ConfigError, unknown_choice

__all__ = ["Registry", "discover"]

T = TypeVar("T")
_MISSING = object()


def discover(package: str) -> list[str]:
    """Import every module of ``package`` (one level, ``_``-prefixed names skipped);
    returns the imported module names in file-name order."""
    pkg = importlib.import_module(package)
    paths = getattr(pkg, "__path__", None)
    if paths is None:
        raise TypeError(f"{package!r} is a module, not a package folder")
    names = sorted(m.name for m in pkgutil.iter_modules(paths) if not m.name.startswith("_"))
    for name in names:
        importlib.import_module(f"{package}.{name}")
    return [f"{package}.{n}" for n in names]


class Registry(Generic[T]):
    """Name -> object + info, with did-you-mean errors and package discovery.

    ``kind`` names the things in messages ("pose source"); ``key`` is the configuration
    key the name comes from ("world.platform"), prefixed to errors; ``error`` the error
    class of an unknown name (:class:`~simcalib.errors.ConfigError` by default);
    ``package`` the package whose modules register into it (imported on first lookup);
    ``info`` the factory of the metadata object; ``check(name, obj)`` validates an entry
    before it is added (raises)."""

    def __init__(self, kind: str, *, key: str | None = None, package: str | None = None,
                 info: Callable[..., Any] | None = None, error: type[Exception] = ConfigError,
                 check: Callable[[str, Any], None] | None = None):
        self.kind = kind
        self.key = key
        self.package = package
        self.error = error
        self._info_factory = info
        self._check = check
        self._objects: dict[str, T] = {}
        self._infos: dict[str, Any] = {}
        self._discovered = package is None
        self._discovering = False

    # ------------------------------------------------------------------ registration
    def register(self, name: str, obj: Any = _MISSING, /, **metadata):
        """Add ``obj`` under ``name``; without ``obj`` a decorator. Returns ``obj``."""
        if obj is _MISSING:
            def deco(target):
                self.register(name, target, **metadata)
                return target
            return deco
        if not isinstance(name, str) or not name:
            raise TypeError(f"a {self.kind} name must be a non-empty string; received "
                            f"{name!r}")
        if name in self._objects:
            if self._objects[name] is obj and not metadata:
                return obj
            raise ValueError(f"{self.kind} {name!r} is already registered "
                             f"(by {_origin(self._objects[name])})")
        if self._check is not None:
            self._check(name, obj)
        self._infos[name] = self._make_info(name, obj, metadata)
        self._objects[name] = obj
        return obj

    def unregister(self, name: str) -> Any:
        """Remove ``name`` and return its object (a test's temporary entry, a plug-in
        reloaded under the same name); an unknown name raises like :meth:`get`."""
        obj = self.get(name)
        del self._objects[name], self._infos[name]
        return obj

    def _make_info(self, name: str, obj: Any, metadata: dict) -> Any:
        if self._info_factory is not None:
            return self._info_factory(name, obj, **metadata)
        carried = getattr(obj, "info", None)
        if carried is not None and not metadata and not callable(carried):
            return carried
        return MappingProxyType(dict(metadata))

    # ---------------------------------------------------------------------- lookup
    def load(self) -> None:
        """Import the registry's package modules (once; lookups call this)."""
        if self._discovered or self._discovering:
            return
        self._discovering = True
        try:
            discover(self.package)
            self._discovered = True
        finally:
            self._discovering = False

    def get(self, name: str) -> T:
        """The object registered as ``name``; an unknown name raises ``error`` naming the
        closest and listing the valid ones."""
        self.load()
        if not isinstance(name, str):
            raise self._error_type(f"{self.key or self.kind} must be a string; received "
                                   f"{type(name).__name__}")
        try:
            return self._objects[name]
        except KeyError:
            raise unknown_choice(self.kind, name, list(self._objects), key=self.key,
                                 error=self.error) from None

    def info(self, name: str) -> Any:
        """The metadata object of ``name`` (same errors as :meth:`get`)."""
        self.get(name)
        return self._infos[name]

    def available(self) -> dict[str, Any]:
        """name -> info of every entry, in registration order."""
        self.load()
        return dict(self._infos)

    def names(self) -> list[str]:
        self.load()
        return list(self._objects)

    def items(self) -> list[tuple[str, T]]:
        self.load()
        return list(self._objects.items())

    def __contains__(self, name: object) -> bool:
        self.load()
        return name in self._objects

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        self.load()
        return len(self._objects)

    def __repr__(self) -> str:
        where = f", package={self.package!r}" if self.package else ""
        return f"Registry({self.kind!r}{where}: {len(self._objects)} registered)"

    def _error_type(self, msg: str) -> Exception:
        if issubclass(self.error, ConfigError):
            from simcalib.errors import ConfigTypeError
            return ConfigTypeError(msg, key=self.key)
        return TypeError(msg)


def _origin(obj: Any) -> str:
    mod = getattr(obj, "__module__", None) or type(obj).__module__
    return f"{mod}.{getattr(obj, '__qualname__', type(obj).__qualname__)}"
