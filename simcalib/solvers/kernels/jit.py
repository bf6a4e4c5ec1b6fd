"""``njit`` and ``prange`` for the kernels, with numba imported at the first kernel call.

Importing :mod:`simcalib` (and the solver API) must stay fast: ``import numba`` alone costs
about 0.4 s, which every CLI command (``list``, ``--help``) would pay. So the kernel modules
decorate with :func:`njit` from here: it records the Python function and its numba options
and returns a :class:`Kernel`. The first call of any kernel imports numba, turns every
recorded function into a real numba dispatcher (in the order they were defined, so callees
exist before their callers compile), and writes the dispatchers (and ``numba.prange``) into
the globals of every kernel module: the compiled code sees plain numba functions, exactly
as if numba had been imported at the top. Callers outside the kernels keep the
:class:`Kernel` object, whose call forwards to the dispatcher.
"""

from __future__ import annotations

import sys

prange = range   # replaced by numba.prange in the kernel modules when numba is loaded

_KERNELS: list["Kernel"] = []
_LOADED = False


class Kernel:
    """A function compiled by numba on first use (see the module docstring)."""

    def __init__(self, py_func, options: dict):
        self.py_func = py_func
        self.options = options
        self.dispatcher = None
        self.__name__ = py_func.__name__
        self.__qualname__ = py_func.__qualname__
        self.__module__ = py_func.__module__
        self.__doc__ = py_func.__doc__
        self.__wrapped__ = py_func

    def __call__(self, *args, **kwargs):
        if self.dispatcher is None:
            load_numba()
        return self.dispatcher(*args, **kwargs)

    def __getattr__(self, name):   # dispatcher attributes (signatures, stats, ...)
        if name in ("dispatcher", "py_func", "options"):
            raise AttributeError(name)
        if self.dispatcher is None:
            load_numba()
        return getattr(self.dispatcher, name)

    def __repr__(self) -> str:
        state = "compiled on first call" if self.dispatcher is None else "numba dispatcher"
        return f"<kernel {self.__module__}.{self.__qualname__} ({state})>"


def njit(**options):
    """``numba.njit(**options)`` applied when numba is loaded (keyword options only)."""
    def decorate(py_func):
        kernel = Kernel(py_func, options)
        _KERNELS.append(kernel)
        if _LOADED:
            _materialise(kernel, __import__("numba"))
            _patch_globals(__import__("numba"))
        return kernel
    return decorate


def load_numba() -> None:
    """Import numba and make every kernel a numba dispatcher (idempotent)."""
    global _LOADED
    if _LOADED:
        return
    import numba
    global prange
    for kernel in _KERNELS:
        _materialise(kernel, numba)
    prange = numba.prange
    _patch_globals(numba)
    _LOADED = True


def _materialise(kernel: Kernel, numba) -> None:
    if kernel.dispatcher is None:
        kernel.dispatcher = numba.njit(**kernel.options)(kernel.py_func)


def _patch_globals(numba) -> None:
    """Replace Kernel objects and ``prange`` by numba's in the kernel modules' globals."""
    prefix = __name__.rsplit(".", 1)[0] + "."
    for name, module in list(sys.modules.items()):
        if not name.startswith(prefix) or module is None or name == __name__:
            continue
        g = module.__dict__
        for key, value in list(g.items()):
            if isinstance(value, Kernel):
                g[key] = value.dispatcher
            elif value is range and key == "prange":
                g[key] = numba.prange
