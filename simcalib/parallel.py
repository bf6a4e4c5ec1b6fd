"""One process pool for simcalib: spawned workers that die quietly on Ctrl-C.

``worker_pool(n, initializer, initargs)`` is a context manager around
``concurrent.futures.ProcessPoolExecutor`` (``spawn`` context: never fork a process that
may hold an OpenGL context or numba threads) used by rendering (:mod:`simcalib.world.render_map`)
and the experiments (:mod:`simcalib.studies.experiments.common`).

BLAS threads: every matrix simcalib multiplies is small (6x6 stacks, a few thousand rows
of 36 at most); OpenBLAS's own threads gain nothing there and, on a busy machine, cost up
to 100x (a thread spinning for a core another process holds: one variogram fit of
``calibrate`` took 0.45 s instead of 4 ms at load 5). The parallelism is numba's threads
and the worker processes. So the CLI runs each command inside :func:`one_blas_thread`,
and every pool worker sets it for its life (an ``OPENBLAS_NUM_THREADS`` set in a worker is
read too late: the spawned worker has loaded numpy to unpickle its initializer).

Ctrl-C: a terminal sends SIGINT to the whole foreground process group, so every worker
would print its own ``KeyboardInterrupt`` traceback (or an ``UnpicklingError`` when it is
interrupted while reading its task). Workers therefore ignore SIGINT (:func:`_quiet_init`
runs before the caller's initializer); only the parent sees the interrupt, and on leaving
the ``with`` block because of it the pool's pending tasks are cancelled and the workers
exit after their current task — no traceback from a worker reaches the terminal. Use
:func:`deferred_interrupt` around the loop that submits and waits, so the parent's own
``KeyboardInterrupt`` is raised between tasks, never inside a lock of the pool.
"""

from __future__ import annotations

import contextlib
import os
import signal
from typing import Any, Callable, Iterator, Sequence

__all__ = ["worker_pool", "default_workers", "terminate_pool", "deferred_interrupt",
           "one_blas_thread", "exit_now"]


def one_blas_thread():
    """Context manager: BLAS and LAPACK (numpy's and scipy's OpenBLAS) on one thread inside
    the block, the previous limits restored after (module doc)."""
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=1, user_api="blas")


def default_workers() -> int:
    """Worker processes used by default: the usable cores (at least 1)."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        n = os.cpu_count() or 1
    return max(1, n)


def _quiet_init(initializer: Callable | None, initargs: Sequence[Any]) -> None:
    # The parent decides what an interrupt means; a worker just stops when told to.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    one_blas_thread()                 # for the worker's life: the processes are the parallelism
    if initializer is not None:
        initializer(*initargs)


def terminate_pool(pool) -> None:
    """Cancel pending tasks and wait for the workers to finish their current task and exit
    (tasks are short chunks). Not waiting here let Python 3.11's exit handler wait forever
    for the pool's manager thread in about one run in three after a Ctrl-C; killing a
    worker instead could leave the pool's reader blocked on a half-written message."""
    pool.shutdown(wait=True, cancel_futures=True)


class _Deferred:
    def __init__(self):
        self.hit = False

    def check(self) -> None:
        """Raise ``KeyboardInterrupt`` here if Ctrl-C arrived since the block started."""
        if self.hit:
            self.hit = False
            raise KeyboardInterrupt


@contextlib.contextmanager
def deferred_interrupt() -> Iterator[_Deferred]:
    """Within the block SIGINT only sets a flag; ``flag.check()`` raises
    ``KeyboardInterrupt`` at a point the caller chooses. A ``KeyboardInterrupt`` raised
    asynchronously inside ``concurrent.futures``/``multiprocessing`` code can leave one of
    their locks held and hang the interpreter at exit; checking between tasks cannot. In
    a thread other than the main one (where signals cannot be handled) it does nothing."""
    import threading  # noqa: PLC0415
    flag = _Deferred()
    if threading.current_thread() is not threading.main_thread():
        yield flag
        return

    def _handler(signum, frame):
        flag.hit = True

    old = signal.signal(signal.SIGINT, _handler)
    try:
        yield flag
    finally:
        signal.signal(signal.SIGINT, old)
    if flag.hit:  # arrived after the last check
        raise KeyboardInterrupt


def _spawn_ignoring_sigint(pool, workers: int) -> None:
    """Start the pool's processes now, with SIGINT ignored in this process meanwhile: an
    ignored signal stays ignored across exec, so a Ctrl-C that arrives while a worker is
    still starting up (importing mujoco, before :func:`_quiet_init` runs) cannot kill it
    half-way — which could leave the pool waiting for it forever. (A pool spawns one
    process per submitted task until it has ``workers``; ``int()`` is a no-op task.) In a
    thread other than the main one the processes start on demand as usual."""
    import threading  # noqa: PLC0415
    if threading.current_thread() is not threading.main_thread():
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        for _ in range(workers):
            pool.submit(int)
    finally:
        signal.signal(signal.SIGINT, old)


@contextlib.contextmanager
def worker_pool(workers: int, initializer: Callable | None = None,
                initargs: Sequence[Any] = (), wait: bool = True) -> Iterator:
    """A ``ProcessPoolExecutor`` with ``workers`` spawned processes whose workers ignore
    SIGINT. Leaving the block normally shuts the pool down (``wait``: wait for the
    workers to exit; ``False`` lets workers still starting up exit on their own). Leaving
    it by an exception (Ctrl-C included) cancels pending tasks; workers stop after their
    current task.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a positive integer; received {workers!r}")
    import multiprocessing as mp  # noqa: PLC0415
    from concurrent.futures import ProcessPoolExecutor  # noqa: PLC0415
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                               initializer=_quiet_init, initargs=(initializer, tuple(initargs)))
    try:
        _spawn_ignoring_sigint(pool, workers)
        yield pool
    except BaseException:
        terminate_pool(pool)
        raise
    else:
        pool.shutdown(wait=wait, cancel_futures=not wait)


def exit_now(status: int, *, join_threads: bool = False) -> None:
    """End the process with ``status`` as a normal exit would, without the interpreter's
    teardown (freeing numba's, scipy's, rerun's and numpy's objects: 0.1-0.3 s a user
    waits for): the non-daemon threads joined (``join_threads``), the exit handlers run,
    stdout and stderr flushed, then ``os._exit``. For a process whose files are all closed
    (:func:`simcalib.cli.run`, the recording worker)."""
    import atexit
    import sys
    import threading
    try:
        if join_threads:
            threading._shutdown()     # what the interpreter's exit does first ...
        atexit._run_exitfuncs()       # ... then
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):
                pass
        os._exit(status)
