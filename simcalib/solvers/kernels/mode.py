"""How a command's solves execute: compiled numba kernels, or — the first time on an
installation, while numba's cache is cold — the kernels' own Python functions
(:mod:`simcalib.solvers.kernels.jit`, docs/solvers.md "Start-up").

``SIMCALIB_KERNELS`` chooses (:data:`KERNEL_MODES`): ``auto`` (default) interprets when the
cache stamp is missing and starts the idle-priority child that fills the cache; otherwise
the compiled kernels are loaded on a thread (:attr:`KernelPlan.loader`) while the command
does its other work. ``simcalib run`` and ``simcalib calibrate`` use it; library calls
(``simcalib.solve``, experiments, sweeps) always compile.
"""

from __future__ import annotations

import contextlib
import os
import threading
from dataclasses import dataclass
from typing import Callable

#: environment variable choosing how a command's solves execute (values: KERNEL_MODES)
KERNELS_ENV = "SIMCALIB_KERNELS"
KERNEL_MODES = {
    "auto": "interpreted when numba's cache of the kernels is cold, else compiled",
    "compiled": "always numba (the first run on an installation compiles, ~25 s)",
    "interpreted": "always the kernels' Python functions (unless this process loaded numba)",
}


@dataclass(frozen=True)
class KernelPlan:
    """``mode``: ``"compiled"`` or ``"interpreted"``; ``context``: a context-manager
    factory the command's solving runs in; ``loader``: the thread loading the compiled
    kernels (None when none was started): :meth:`wait` for it before timing a solve."""
    mode: str
    context: Callable
    loader: threading.Thread | None = None

    def wait(self) -> None:
        if self.loader is not None:
            self.loader.join()


def prepare_kernels() -> KernelPlan:
    """The plan for ``$SIMCALIB_KERNELS`` (ConfigError naming the allowed values)."""
    from simcalib.solvers.kernels import jit
    mode = os.environ.get(KERNELS_ENV, "auto")
    if mode not in KERNEL_MODES:
        from simcalib.errors import ConfigError
        raise ConfigError(f"{KERNELS_ENV}={mode!r} is not a kernel mode; allowed: "
                          f"{', '.join(KERNEL_MODES)} ({KERNEL_MODES['auto']})")
    if mode == "interpreted" and not jit.loaded():
        return KernelPlan("interpreted", jit.interpreted)
    if jit.loaded() or mode == "compiled" or jit.kernels_cached():
        loader = None
        if not jit.loaded():
            loader = threading.Thread(target=_load_kernels, daemon=True,
                                      name="simcalib-kernel-load")
            loader.start()
        return KernelPlan("compiled", contextlib.nullcontext, loader)
    jit.start_cache_fill()
    return KernelPlan("interpreted", jit.interpreted)


def _load_kernels() -> None:
    """Load every kernel a run uses (one small solve and its diagnostics)."""
    from simcalib.solvers.kernels.batch import load_every_kernel
    try:
        load_every_kernel()
    except Exception:  # noqa: BLE001 - the command's own first solve reports any problem
        pass


INTERPRETED_NOTE = ("solver kernels: interpreted (first run on this installation; a "
                    "low-priority process compiles them for the next runs): the times are "
                    "~100x the compiled ones, the numbers the same to rounding")
