"""Shared test setup. MUJOCO_GL must be set before mujoco is imported anywhere."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
# Runs in the suite use the compiled kernels whatever the cache holds, so runs compare bit
# for bit; the first-run interpreted path has its own tests (test_solvers_kernels_jit.py).
os.environ.setdefault("SIMCALIB_KERNELS", "compiled")

import numpy as np  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="module")
def gl():
    """The MuJoCo rendering backend; a test that renders skips, naming why, where none exists."""
    from simcalib.world.render_backend import RenderBackendError, available_backend
    try:
        return available_backend()
    except RenderBackendError as exc:
        pytest.skip(f"no MuJoCo rendering backend: {exc}")
