"""``executor=ray``: one Ray task per cell (``pip install -e .[cluster]`` brings Ray).

``address=None`` starts a local Ray instance (``ray.init()``) with ``workers`` CPUs (the
machine's cores by default) and runs its workers with this process's ``PYTHONPATH`` and
``MUJOCO_GL``, so they import the same simcalib. ``address=auto`` joins the cluster this
machine belongs to, ``ray://host:port`` a remote one through Ray Client; the cluster's
nodes must have simcalib installed (same version). One task per CPU (``num_cpus=1``);
rendering in each worker follows the same backend rules as ``run``. A lost worker (node
death, OOM kill) is retried by Ray ``max_retries`` times; a cell whose run fails is not
retried (its failure is a result).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from simcalib.errors import BackendError, ConfigError
from simcalib.executors import register

__all__ = ["RayExecutor"]


def _import_ray():
    try:
        import ray
    except ModuleNotFoundError:
        raise ConfigError("executor=ray needs Ray: pip install -e '.[cluster]' (or pip "
                          "install ray); executor=local needs nothing extra") from None
    return ray


@register("ray", description="Ray tasks: a local Ray instance, or a cluster (address=auto | "
                "ray://host:port)", extra="cluster")
class RayExecutor:
    name = "ray"

    def __init__(self, address: str | None = None, max_retries: int = 3):
        self.address = address or None
        self.max_retries = int(max_retries)
        self._started = False

    def _init(self, ray, workers: int | None) -> None:
        if ray.is_initialized():
            return
        if self.address is None:
            root = str(Path(__file__).resolve().parents[2])     # the folder holding simcalib/
            path = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)
            env = {"PYTHONPATH": path, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
                   "RAY_AUTH_MODE": "disabled"}
            os.environ.setdefault("RAY_AUTH_MODE", "disabled")
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False,
                     configure_logging=False, runtime_env={"env_vars": env})
        else:
            try:
                ray.init(address=self.address, log_to_driver=False, configure_logging=False)
            except Exception as exc:  # noqa: BLE001 - say what was tried
                raise BackendError(f"could not connect to the Ray cluster at "
                                   f"{self.address!r}: {type(exc).__name__}: {exc}") from None
        self._started = True

    def map(self, fn: Callable, tasks: Sequence[tuple], workers: int | None
            ) -> Iterator[tuple[int, Any]]:
        ray = _import_ray()
        self._init(ray, workers)
        try:
            remote = ray.remote(num_cpus=1, max_retries=self.max_retries)(fn)
            refs = {remote.remote(*task): i for i, task in enumerate(tasks)}
            while refs:
                done, _ = ray.wait(list(refs), num_returns=1, timeout=1.0)
                for ref in done:
                    i = refs.pop(ref)
                    try:
                        yield i, ray.get(ref)
                    except Exception as exc:  # noqa: BLE001 - lost worker after retries
                        yield i, exc
        except KeyboardInterrupt:
            for ref in list(locals().get("refs", {})):
                ray.cancel(ref, force=True)
            raise
        finally:
            if self._started:
                ray.shutdown()
                self._started = False
