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

Interpreted kernels (the first run on an installation). Compiling every kernel costs ~25 s
of CPU once per installation (numba then loads them from its cache in ~1 s). A run that
finds the cache cold (:func:`kernels_cached`) executes its stages inside
:func:`interpreted`: each kernel call runs its own Python function (the same source,
``prange`` = ``range``, numba not imported), ~100x slower per solve (a run's few hundred
solves take ~1-2 s), while a low-priority child process fills the cache for the runs that
follow (:func:`start_cache_fill`, which then writes the stamp :func:`kernels_cached`
reads). The results agree with the compiled kernels to rounding (~1e-14: the compiled
ones reassociate a few sums). A kernel whose loop runs over the motions may name a
vectorised numpy twin (:func:`twin_of`), which the interpreted calls run instead of its
per-motion Python loop (the twins are checked against the kernels in
``tests/test_solvers_kernels.py``); the 4x4 method code always runs as written.
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
import threading
from contextlib import contextmanager
from pathlib import Path

prange = range   # replaced by numba.prange in the kernel modules when numba is loaded

_KERNELS: list["Kernel"] = []
_LOADED = False
_INTERPRETED = False   # inside interpreted(): kernel calls run their Python functions
_LOAD_LOCK = threading.Lock()   # a run loads the kernels on a thread (pipeline)


class Kernel:
    """A function compiled by numba on first use (see the module docstring)."""

    def __init__(self, py_func, options: dict):
        self.py_func = py_func
        self.options = options
        self.dispatcher = None
        self.twin = None   # the numpy function interpreted calls run instead (twin_of)
        self.twin_when = None   # ... for the arguments it accepts (None: always)
        self.__name__ = py_func.__name__
        self.__qualname__ = py_func.__qualname__
        self.__module__ = py_func.__module__
        self.__doc__ = py_func.__doc__
        self.__wrapped__ = py_func

    def __call__(self, *args, **kwargs):
        if self.dispatcher is None:
            if _INTERPRETED:
                if self.twin is not None and (self.twin_when is None
                                              or self.twin_when(*args, **kwargs)):
                    return self.twin(*args, **kwargs)
                return self.py_func(*args, **kwargs)
            load_numba()
        return self.dispatcher(*args, **kwargs)

    def __getattr__(self, name):   # dispatcher attributes (signatures, stats, ...)
        if name in ("dispatcher", "py_func", "options", "twin", "twin_when"):
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


def twin_of(kernel: Kernel, when=None):
    """Decorator: the decorated numpy function (same arguments, same outputs written, same
    return value, to rounding) runs instead of ``kernel``'s Python function when kernels
    are interpreted: a vectorised twin of a loop over the motions. ``when(*args)``: the
    calls it takes (numpy's fixed cost loses to a loop over a few motions); None: all."""
    def decorate(fn):
        kernel.twin = fn
        kernel.twin_when = when
        return fn
    return decorate


def load_numba() -> None:
    """Import numba and make every kernel a numba dispatcher (idempotent, thread-safe)."""
    global _LOADED, prange
    if _LOADED:
        return
    with _LOAD_LOCK:
        if _LOADED:
            return
        import numba
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


def loaded() -> bool:
    """Has this process turned the kernels into numba dispatchers?"""
    return _LOADED


def interpreting() -> bool:
    """Do kernel calls run their Python functions now (inside :func:`interpreted`, numba
    not loaded)?"""
    return _INTERPRETED and not _LOADED


@contextmanager
def interpreted():
    """Inside the block, kernel calls run their Python functions (numba is not imported);
    yields ``True``. When this process has loaded numba already the block changes nothing
    and yields ``False`` (compiled kernels call each other directly)."""
    global _INTERPRETED
    if _LOADED:
        yield False
        return
    before = _INTERPRETED
    _INTERPRETED = True
    try:
        yield True
    finally:
        _INTERPRETED = before


# ------------------------------------------------------------------- the cache's stamp
@functools.lru_cache(maxsize=1)
def _cache_key() -> str:
    """What numba's cache of these kernels depends on: their sources, numba, Python, the
    machine (computed once per process)."""
    from importlib.metadata import PackageNotFoundError, version
    import platform
    h = hashlib.sha256()
    here = Path(__file__).resolve().parent
    for path in sorted(here.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    try:
        numba_version = version("numba")
    except PackageNotFoundError:
        numba_version = "none"
    h.update(f"{numba_version}|{sys.version}|{platform.machine()}".encode())
    return h.hexdigest()[:20]


def _stamp_dir() -> Path:
    """Where numba caches the kernels: ``NUMBA_CACHE_DIR``, else the kernels'
    ``__pycache__`` when writable; otherwise the stamp goes to the user's cache folder."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    in_tree = Path(__file__).resolve().parent / "__pycache__"
    try:
        in_tree.mkdir(exist_ok=True)
        if os.access(in_tree, os.W_OK):
            return in_tree
    except OSError:
        pass
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "simcalib"


def stamp_path(suffix: str = "ok") -> Path:
    return _stamp_dir() / f"simcalib-kernels-{_cache_key()}.{suffix}"


def kernels_cached() -> bool:
    """Has a process on this installation compiled the kernels into numba's cache (the
    stamp :func:`mark_cached` writes)? A hint only: a stale stamp means numba compiles at
    the first call as usual, a missing one that a run solves interpreted."""
    try:
        return stamp_path().exists()
    except OSError:
        return False


def mark_cached() -> None:
    """Write the stamp (after every kernel a run uses was compiled with ``cache=True``)."""
    path = stamp_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("numba cache of simcalib's solver kernels is filled\n")


def _fill_running() -> bool:
    """Is a :func:`start_cache_fill` child alive (its pid in the lock file)?"""
    lock = stamp_path("filling")
    try:
        pid = int(lock.read_text().strip())
        os.kill(pid, 0)
        return True
    except (OSError, ValueError):
        return False


_FILL_CODE = (
    "import os, sys\n"
    "from simcalib.solvers.kernels import jit\n"
    "lock = jit.stamp_path('filling')\n"
    "try:\n"
    "    from simcalib.solvers.kernels.batch import load_every_kernel\n"
    "    load_every_kernel()\n"
    "    jit.mark_cached()\n"
    "finally:\n"
    "    try:\n"
    "        if lock.read_text().strip() == str(os.getpid()):\n"
    "            lock.unlink()\n"
    "    except OSError:\n"
    "        pass\n"
)


def _background_priority() -> None:   # runs in the child before exec (POSIX)
    os.setpgrp()   # its own process group: a Ctrl-C of the run does not stop it
    try:           # CPU only when nothing else wants it (same session: same autogroup)
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):
        os.nice(19)


def start_cache_fill():
    """Start a child process, at idle CPU priority and in its own process group (it
    outlives the run that started it: ~25 s of CPU once per installation), that compiles
    every kernel a run uses into numba's cache and then writes the stamp. ``None`` when the
    cache is filled, a child is filling it already, or no process can be started."""
    if kernels_cached() or _fill_running():
        return None
    import subprocess
    lock = stamp_path("filling")
    kwargs = {"preexec_fn": _background_priority} if hasattr(os, "setpgrp") else {}
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
        proc = subprocess.Popen([sys.executable, "-c", _FILL_CODE], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, **kwargs)
        lock.write_text(str(proc.pid))
    except OSError:
        return None
    return proc
