"""One process pool and one BLAS thread (simcalib.parallel)."""

from threadpoolctl import threadpool_info

from simcalib.cli import main
from simcalib.parallel import one_blas_thread, worker_pool


def _blas_threads() -> list[int]:
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_one_blas_thread_limits_inside_the_block_and_restores_after():
    before = _blas_threads()
    with one_blas_thread():
        assert _blas_threads() and set(_blas_threads()) == {1}
    assert _blas_threads() == before


def test_pool_workers_run_blas_on_one_thread():
    """Set at run time: an OPENBLAS_NUM_THREADS set in the worker would come after numpy
    loaded (the spawned worker imports it to unpickle its initializer)."""
    with worker_pool(1) as pool:
        assert set(pool.submit(_blas_threads).result()) == {1}


def test_the_cli_runs_a_command_on_one_blas_thread():
    from simcalib.cli import COMMANDS, register_command
    seen = []
    register_command("blas_probe", lambda argv: seen.append(_blas_threads()) or 0, "test")
    try:
        before = _blas_threads()
        assert main(["blas_probe"]) == 0
    finally:
        COMMANDS.unregister("blas_probe")
    assert seen and set(seen[0]) == {1} and _blas_threads() == before
