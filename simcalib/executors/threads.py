"""``executor=threads``: a thread pool in this process (no extra dependency, no spawn).

For cells whose work releases the GIL (numpy / LAPACK solves of synthetic scenarios) and
for small sweeps, where starting processes costs more than the cells: nothing is pickled
and nothing is imported again. The results are the ones of ``local`` (each task carries
its own seed; the order of completion does not matter). Cells that render are better run
by ``local``: one OpenGL context per process is the rendering rule of the pipeline.
Ctrl-C cancels the tasks not yet started; running ones finish.
"""

from __future__ import annotations

from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from typing import Any, Callable, Iterator, Sequence

from simcalib.executors import register
from simcalib.parallel import default_workers

__all__ = ["ThreadExecutor"]


@register("threads", description="a thread pool in this process (no spawn, nothing pickled; "
                                  "for cells that do not render)")
class ThreadExecutor:
    name = "threads"

    def map(self, fn: Callable, tasks: Sequence[tuple], workers: int | None
            ) -> Iterator[tuple[int, Any]]:
        workers = default_workers() if workers is None else int(workers)
        if not tasks:
            return
        pool = ThreadPoolExecutor(max_workers=max(1, min(workers, len(tasks))),
                                  thread_name_prefix="simcalib-cell")
        try:
            futures = {pool.submit(fn, *task): i for i, task in enumerate(tasks)}
            while futures:
                done, _ = wait(list(futures), timeout=0.2, return_when=FIRST_COMPLETED)
                for fut in done:
                    i = futures.pop(fut)
                    try:
                        yield i, fut.result()
                    except Exception as exc:  # noqa: BLE001 - reported per task
                        yield i, exc
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
