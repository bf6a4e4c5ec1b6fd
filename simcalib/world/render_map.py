"""Many frames rendered in parallel: :func:`render_map` renders camera frames
(:class:`FrameJob`) in this process and in worker processes
(:func:`simcalib.parallel.worker_pool`) with :class:`~simcalib.world.render.CameraRenderer`,
and applies a picklable per-frame function there (so only small results travel back).

Results are returned in job order and do not depend on the worker count: a job carries
everything its frame needs (state, seed key), and rendering the same state gives the same
pixels. Ctrl-C stops the workers quietly and returns the frames done in
:class:`RenderInterrupted`; ``progress`` reports frames as they finish (:class:`LineProgress`
prints a line every N frames for logs).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from simcalib.world.render import (CameraRenderer, RenderSettings, model_from_bytes,
                                   model_to_bytes)
from simcalib.world.render_backend import available_backend

__all__ = ["FrameJob", "FrameTiming", "LineProgress", "MIN_JOBS_PER_WORKER", "RenderInterrupted",
           "check_progress", "default_workers", "render_map"]


@dataclass(frozen=True)
class FrameJob:
    """One frame to render: camera name, frame index, raw MuJoCo state, and ``key`` (any
    picklable data the per-frame function needs, e.g. a seed key).

    ``substates``: ``((qpos, mocap_pos, mocap_quat_wxyz), ...)`` — when given, each is
    rendered and the per-frame function receives the ``(S, H, W, 3)`` stack (motion blur,
    rolling shutter); the frame's own state still defines ``FrameTiming.T_world_cam``.
    ``light``: ``(intensity scale, azimuth offset rad)`` for :meth:`CameraRenderer.set_light`
    (``None``: the model's lights). ``check_points``: ``(N, 3)`` world points tested for
    occlusion at the frame's state (``FrameTiming.occluded``)."""
    camera: str
    frame_index: int
    qpos: np.ndarray | None
    mocap_pos: np.ndarray | None
    mocap_quat_wxyz: np.ndarray | None
    key: Any = None
    substates: tuple = ()
    light: tuple | None = None
    check_points: np.ndarray | None = None


@dataclass(frozen=True)
class FrameTiming:
    """Seconds spent on one frame: ``render_s`` (wall, rendering only), ``total_s`` (wall,
    rendering + the per-frame function), ``cpu_s`` (CPU time of the rendering process
    over both, all its threads — independent of other load on the machine), ``pid`` (the
    process that rendered it), ``T_world_cam`` (the OpenCV-frame pose of the camera in the
    rendered state — lets callers check the state against their ground truth)."""
    render_s: float
    total_s: float
    cpu_s: float
    pid: int
    T_world_cam: np.ndarray
    occluded: np.ndarray | None = None


_WORKER: dict[str, Any] = {}


#: Fewest frames per rendering process before another worker process is started.
MIN_JOBS_PER_WORKER = 12


def _worker_init(model_blob: bytes, settings: RenderSettings, backend: str,
                 fn: Callable) -> None:
    os.environ["MUJOCO_GL"] = backend
    if backend == "osmesa":
        os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
    # One thread per worker: the pool already uses every core.
    os.environ.setdefault("LP_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        import cv2  # noqa: PLC0415
        cv2.setNumThreads(1)
    except ImportError:
        pass
    _WORKER["fn"] = fn
    try:
        _WORKER["renderer"] = CameraRenderer(model_from_bytes(model_blob), settings)
    except Exception as exc:  # noqa: BLE001  (re-raised in the parent by the first task)
        _WORKER["error"] = exc


def _run_jobs(renderer: CameraRenderer, fn: Callable, jobs: Sequence[FrameJob]) -> list:
    out = []
    for job in jobs:
        c0 = time.process_time()
        t0 = time.perf_counter()
        renderer.set_light(*(job.light if job.light is not None else (1.0, 0.0)))
        if job.substates:
            img = np.stack([renderer.render(job.camera, *st) for st in job.substates])
            renderer.set_state(job.qpos, job.mocap_pos, job.mocap_quat_wxyz)
        else:
            img = renderer.render(job.camera, job.qpos, job.mocap_pos, job.mocap_quat_wxyz)
        T = renderer.T_world_cam(job.camera)
        occ = None if job.check_points is None else renderer.occluded(job.camera,
                                                                      job.check_points)
        t1 = time.perf_counter()
        res = img if fn is None else fn(img, job)
        out.append((res, FrameTiming(t1 - t0, time.perf_counter() - t0,
                                     time.process_time() - c0, os.getpid(), T, occ)))
    return out


def _worker_chunk(jobs: Sequence[FrameJob]) -> list:
    if "error" in _WORKER:
        raise _WORKER["error"]
    return _run_jobs(_WORKER["renderer"], _WORKER["fn"], jobs)


def default_workers() -> int:
    """Worker processes used by default: the usable cores (at least 1)."""
    from simcalib.parallel import default_workers as _dw  # noqa: PLC0415
    return _dw()


class RenderInterrupted(KeyboardInterrupt):
    """Ctrl-C (or another interrupt) during :func:`render_map`, carrying what was done.

    ``results`` / ``timings``: lists in job order, ``None`` for frames not rendered;
    ``n_done``: frames rendered. A ``KeyboardInterrupt``, so code that does not handle it
    still stops as on Ctrl-C.
    """

    def __init__(self, results: list, timings: list):
        super().__init__("rendering interrupted")
        self.results = results
        self.timings = timings
        self.n_done = sum(r is not None for r in timings)


class LineProgress:
    """Progress callback ``(n_done, n_total)`` that prints a line to ``stream`` (stderr)
    every ``every`` frames and at the end — for logs and non-terminal stderr, where a bar
    would print nothing useful."""

    def __init__(self, label: str = "frames", every: int = 100, stream=None):
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise ValueError(f"every must be a positive integer; received {every!r}")
        self.label, self.every, self.stream = label, every, stream
        self._last = 0
        self._t0 = time.perf_counter()

    def __call__(self, n_done: int, n_total: int) -> None:
        if n_done - self._last < self.every and n_done < n_total:
            return
        if n_done == self._last:
            return
        self._last = n_done
        dt = time.perf_counter() - self._t0
        rate = n_done / dt if dt > 0 else float("inf")
        print(f"{self.label}: {n_done}/{n_total} ({rate:.1f}/s)",
              file=self.stream or sys.stderr, flush=True)


def render_map(model, settings: RenderSettings, jobs: Sequence[FrameJob],
               fn: Callable[[np.ndarray, FrameJob], Any] | None = None,
               workers: int | None = None, chunk_size: int = 8,
               use_this_process: bool = True,
               progress: Callable[[int, int], None] | None = None
               ) -> tuple[list, list[FrameTiming]]:
    """Render every job's frame and return ``([fn(image, job) ...], [FrameTiming ...])``
    in job order.

    ``fn`` must be picklable (a module-level function or an instance of a module-level
    class) and deterministic given ``(image, job)``; ``None`` returns the images.
    ``workers``: ``None`` = all usable cores; ``1`` renders in this process (or in one
    worker process when only a fallback backend works); ``n > 1`` renders in this process
    plus ``n - 1`` spawned worker processes (``n`` spawned ones when this process cannot
    render, or with ``use_this_process=False``). The results do not depend on ``workers``,
    ``chunk_size`` or ``use_this_process``.

    ``progress(n_done, n_total)`` is called in this process as frames complete (per frame
    rendered here, per chunk from workers). An interrupt (Ctrl-C) stops the workers
    quietly and raises :class:`RenderInterrupted` carrying the frames already rendered.
    """
    if workers is None:
        workers = default_workers()
    _check_map_options(workers, chunk_size, progress)
    jobs = list(jobs)
    if not jobs:
        return [], []
    backend, inprocess = available_backend()
    inprocess = inprocess and bool(use_this_process)
    # Starting a worker costs ~1 s (a fresh interpreter importing mujoco and cv2): not
    # worth it below ~MIN_JOBS_PER_WORKER frames per process.
    workers = int(min(workers, -(-len(jobs) // MIN_JOBS_PER_WORKER)))
    if workers == 1 and inprocess:
        pairs = _pairs_rendered_here(model, settings, jobs, fn, progress)
    else:
        pairs = _pairs_rendered_in_pool(model, settings, jobs, fn, workers, chunk_size,
                                        backend, inprocess, progress)
    return [p[0] for p in pairs], [p[1] for p in pairs]


def check_progress(progress) -> None:
    """Raise TypeError unless ``progress`` is a callable ``(n_done, n_total)`` or None."""
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable (n_done, n_total) or None; received "
                        f"{type(progress).__name__}")


def _check_map_options(workers, chunk_size, progress) -> None:
    """Raise the error of the first invalid ``workers``/``chunk_size``/``progress``."""
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a positive integer or None; received {workers!r}")
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) \
            or chunk_size < 1:
        raise ValueError(f"chunk_size must be a positive integer; received {chunk_size!r}")
    check_progress(progress)


def _render_each(renderer: CameraRenderer, fn: Callable, jobs: Sequence[FrameJob], out: list,
                 done_before: int, n_total: int, progress, intr) -> None:
    """Append each job's (result, timing) pair to ``out``; progress and interrupt per frame."""
    for job in jobs:
        out += _run_jobs(renderer, fn, [job])
        if progress is not None:
            progress(done_before + len(out), n_total)
        intr.check()


def _pairs_rendered_here(model, settings: RenderSettings, jobs: list, fn: Callable,
                         progress) -> list:
    """(result, timing) pairs of ``jobs`` rendered one by one in this process."""
    from simcalib.parallel import deferred_interrupt  # noqa: PLC0415
    n_total = len(jobs)
    pairs: list = []
    try:
        with deferred_interrupt() as intr, CameraRenderer(model, settings) as r:
            _render_each(r, fn, jobs, pairs, 0, n_total, progress, intr)
    except KeyboardInterrupt:
        pad = [None] * (n_total - len(pairs))
        raise RenderInterrupted([p[0] for p in pairs] + pad,
                                [p[1] for p in pairs] + pad) from None
    return pairs


def _job_chunks(jobs: list, workers: int, chunk_size: int) -> list:
    """Contiguous chunks of ``jobs``, several per worker for load balance."""
    size = int(max(1, min(chunk_size, -(-len(jobs) // (2 * workers)))))
    return [jobs[i:i + size] for i in range(0, len(jobs), size)]


class _ChunkPairs:
    """Each chunk's (result, timing) pairs as they arrive (``None``: not yet); frames done."""

    def __init__(self, n_chunks: int, n_total: int, progress):
        self.pairs: list = [None] * n_chunks
        self.done = 0
        self.n_total = n_total
        self.progress = progress

    def store(self, i: int, part: list) -> None:
        """Record chunk ``i``'s pairs and count its frames as done."""
        self.pairs[i] = part
        self.done += len(part)

    def collect(self, futures, block: bool) -> None:
        """Store finished worker chunks (``block``: wait up to 0.2 s first); report progress."""
        from concurrent.futures import FIRST_COMPLETED, wait  # noqa: PLC0415
        pending = [f for i, f in enumerate(futures) if self.pairs[i] is None]
        if block and pending:
            wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
        for i, f in enumerate(futures):
            if self.pairs[i] is None and f.done() and not f.cancelled():
                self.store(i, f.result())
        if self.progress is not None:
            self.progress(self.done, self.n_total)

    def interrupted(self, chunks: list) -> RenderInterrupted:
        """The :class:`RenderInterrupted` of the chunks done (``None`` per frame of the others)."""
        res_out: list = []
        tim_out: list = []
        for c, chunk_res in zip(chunks, self.pairs):
            if chunk_res is None:
                res_out += [None] * len(c)
                tim_out += [None] * len(c)
            else:
                res_out += [p[0] for p in chunk_res]
                tim_out += [p[1] for p in chunk_res]
        return RenderInterrupted(res_out, tim_out)


def _submitted_chunks(pool, chunks: list, intr) -> list:
    """Futures of every chunk submitted to ``pool``; interrupt checked after each."""
    futures = []
    for c in chunks:
        futures.append(pool.submit(_worker_chunk, c))
        intr.check()
    return futures


def _render_unstarted_chunks_here(model, settings: RenderSettings, fn: Callable, chunks: list,
                                  futures: list, book: _ChunkPairs, intr) -> None:
    """Render here, last chunk first, every chunk whose future could still be cancelled."""
    with CameraRenderer(model, settings) as r:
        for i in range(len(chunks) - 1, -1, -1):
            if futures[i].cancel():
                part: list = []
                _render_each(r, fn, chunks[i], part, book.done, book.n_total, book.progress,
                             intr)
                book.store(i, part)
                book.collect(futures, block=False)


def _pairs_rendered_in_pool(model, settings: RenderSettings, jobs: list, fn: Callable,
                            workers: int, chunk_size: int, backend: str, inprocess: bool,
                            progress) -> list:
    """(result, timing) pairs of ``jobs`` rendered in chunks by worker processes (and here)."""
    from simcalib.parallel import deferred_interrupt, worker_pool  # noqa: PLC0415
    blob = model_to_bytes(model)
    chunks = _job_chunks(jobs, workers, chunk_size)
    # When this process can render, it is one of the workers: it starts at once (no
    # interpreter start-up) and takes chunks from the end while the spawned processes
    # take them from the front. Chunk results do not depend on who renders them.
    n_proc = workers - 1 if inprocess else workers
    book = _ChunkPairs(len(chunks), len(jobs), progress)
    try:
        # Do not wait for workers that are still starting up once every result is in:
        # they receive the shutdown request and exit on their own.
        with deferred_interrupt() as intr, \
                worker_pool(n_proc, _worker_init, (blob, settings, backend, fn),
                            wait=False) as pool:
            futures = _submitted_chunks(pool, chunks, intr)
            if inprocess:
                _render_unstarted_chunks_here(model, settings, fn, chunks, futures, book, intr)
            while any(r is None for r in book.pairs):
                book.collect(futures, block=True)
                intr.check()
    except KeyboardInterrupt:
        raise book.interrupted(chunks) from None
    return [p for chunk in book.pairs for p in chunk]
