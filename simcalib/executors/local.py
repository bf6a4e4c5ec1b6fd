"""``executor=local``: a pool of spawned processes on this machine (no extra dependency).

Each worker process renders with its own MuJoCo context (the pipeline's rendering rules);
Ctrl-C cancels pending cells and lets running ones stop quietly (simcalib.parallel). A
worker that dies (killed, out of memory) breaks the pool: the pool is rebuilt and the
unfinished tasks are resubmitted up to ``retries`` times, then reported as lost.
"""

from __future__ import annotations

from concurrent.futures import FIRST_COMPLETED, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Iterator, Sequence

from simcalib.executors import register
from simcalib.parallel import default_workers, deferred_interrupt, worker_pool

__all__ = ["LocalExecutor"]


@register("local", description="a process pool on this machine (one renderer per process)")
class LocalExecutor:
    name = "local"

    def __init__(self, retries: int = 1):
        self.retries = int(retries)

    def map(self, fn: Callable, tasks: Sequence[tuple], workers: int | None
            ) -> Iterator[tuple[int, Any]]:
        workers = default_workers() if workers is None else workers
        pending = list(range(len(tasks)))
        attempts = {i: 0 for i in pending}
        while pending:
            lost: list[int] = []
            with deferred_interrupt() as interrupt, \
                    worker_pool(min(workers, len(pending))) as pool:
                futures = {pool.submit(fn, *tasks[i]): i for i in pending}
                while futures:
                    done, _ = wait(list(futures), timeout=0.2, return_when=FIRST_COMPLETED)
                    interrupt.check()
                    for fut in done:
                        i = futures.pop(fut)
                        try:
                            yield i, fut.result()
                        except BrokenProcessPool:
                            lost.append(i)
                        except Exception as exc:  # noqa: BLE001 - reported per task
                            yield i, exc
            pending = []
            for i in lost:
                attempts[i] += 1
                if attempts[i] > self.retries:
                    yield i, RuntimeError(f"worker process lost {attempts[i]} times")
                else:
                    pending.append(i)
