"""simcalib.solvers.kernels.jit: interpreted kernels (the first run on an installation),
the cache stamp, the low-priority child that fills numba's cache, and the run's choice."""

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

import simcalib
from simcalib.cli import main
from simcalib.solvers.kernels import jit
from simcalib.solvers.kernels.batch import random_motions_for_warm_up


def _python(code: str, env: dict, timeout: float = 120) -> str:
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=timeout)
    assert out.returncode == 0, out.stderr
    return out.stdout


@pytest.mark.slow
def test_interpreted_solve_matches_compiled_and_imports_no_numba():
    C, H = random_motions_for_warm_up()
    rng = np.random.default_rng(3)
    C = C @ simcalib.geometry.perturb_transforms(np.tile(np.eye(4), (8, 1, 1)), 1e-3, 1e-3, rng)
    compiled = simcalib.solve(C, H, method="dqopt", alpha=0.7)
    code = (
        "import sys, json, numpy as np, simcalib\n"
        "from simcalib.solvers.kernels import jit\n"
        f"C = np.array({C.tolist()}); H = np.array({H.tolist()})\n"
        "with jit.interpreted() as on:\n"
        "    sol = simcalib.solve(C, H, method='dqopt', alpha=0.7)\n"
        "    msg = sol.message\n"
        "print(json.dumps({'on': on, 'numba': 'numba' in sys.modules, 'X': sol.X.tolist(),\n"
        "                  'cost': sol.cost, 'cert': 'certified' in msg}))\n")
    got = json.loads(_python(code, dict(os.environ)))
    assert got["on"] is True and got["numba"] is False   # the Python functions ran
    np.testing.assert_allclose(np.array(got["X"]), compiled.X, atol=1e-12, rtol=0)
    assert got["cost"] == pytest.approx(compiled.cost, rel=1e-9, abs=1e-15)
    assert got["cert"]


def test_interpreted_is_a_no_op_once_numba_is_loaded():
    simcalib.solve(*random_motions_for_warm_up())   # this process has the compiled kernels
    assert jit.loaded()
    with jit.interpreted() as on:
        assert on is False and not jit.interpreting()


def test_stamp_follows_mark_and_names_sources(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert jit.stamp_path().parent == tmp_path
    assert not jit.kernels_cached()
    jit.mark_cached()
    assert jit.kernels_cached()
    # the key depends on the kernels' sources: another key is another stamp
    monkeypatch.setattr(jit, "_cache_key", lambda: "other")
    assert not jit.kernels_cached()


def test_cache_fill_child_runs_idle_once_and_writes_the_stamp(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    # the child's work replaced by a fast one that records its CPU scheduling policy
    code = ("import os, time\nfrom simcalib.solvers.kernels import jit\n"
            "time.sleep(0.3)\n"
            f"open({str(tmp_path / 'policy')!r}, 'w').write("
            "f'{os.sched_getscheduler(0)} {int(os.getpgrp() == os.getpid())}')\n"
            "jit.mark_cached()\n"
            "lock = jit.stamp_path('filling')\n"
            "lock.unlink()\n")
    monkeypatch.setattr(jit, "_FILL_CODE", code)
    proc = jit.start_cache_fill()
    assert proc is not None
    assert jit.stamp_path("filling").read_text() == str(proc.pid)
    assert jit.start_cache_fill() is None          # one child at a time
    assert proc.wait(timeout=240) == 0      # a full compile at idle priority: slow under load
    assert jit.kernels_cached()
    assert not jit.stamp_path("filling").exists()
    policy, own_group = map(int, (tmp_path / "policy").read_text().split())
    assert own_group == 1                           # a Ctrl-C of the run does not reach it
    if hasattr(os, "SCHED_IDLE"):
        assert policy == os.SCHED_IDLE
    assert jit.start_cache_fill() is None          # filled: nothing to do


def test_load_every_kernel_loads_every_signature_the_api_calls():
    """After kernels.batch.load_every_kernel (what the loader thread and the cache-fill
    child run; it knows nothing of the API), the API's solves, their diagnostics, a batch
    and a robust solve compile nothing more (a fresh process: numba's cache is warm here)."""
    code = (
        "import numpy as np, simcalib\n"
        "from simcalib.solvers.kernels import batch, jit\n"
        "batch.load_every_kernel()\n"
        "def sigs():\n"
        "    return {k.__qualname__: len(k.dispatcher.signatures) for k in jit._KERNELS\n"
        "            if k.dispatcher is not None}\n"
        "before = sigs()\n"
        "C, H = batch.random_motions_for_warm_up()\n"
        "rng = np.random.default_rng(0)\n"
        "H = simcalib.geometry.perturb_transforms(H, 1e-3, 1e-3, rng)\n"
        "for m in ('dqopt', 'dq2steps', 'dq2ndord', 'dqitr'):\n"
        "    simcalib.solve(C, H, method=m, alpha=0.5).message\n"
        "P = simcalib.Prior(np.eye(4), a=1.0, b=2.0)\n"
        "simcalib.solve(C, H, prior=P, weights=np.linspace(1, 2, 8)).message\n"
        "simcalib.solve_batch(np.stack([C] * 3), np.stack([H] * 3), alpha=[1, 2, 3]).covariance\n"
        "simcalib.solve(np.concatenate([C] * 2), np.concatenate([H] * 2), robust='ransac')\n"
        "print(before == sigs(), before, sigs())\n")
    out = _python(code, dict(os.environ, SIMCALIB_KERNELS="compiled"), timeout=300)
    assert out.startswith("True"), out


@pytest.mark.slow
def test_run_interpreted_equals_compiled_run(tmp_path):
    overrides = ["synthetic.num_motions=60", "pairing.n_pairs=30", "solvers=[dqopt,dq2steps]",
                 "recording.enabled=false", "progress=false"]
    compiled = simcalib.run("random", overrides + [f"output={tmp_path / 'c'}"], echo=False)
    assert compiled.solver_kernels == "compiled"
    env = dict(os.environ, SIMCALIB_KERNELS="interpreted")
    out = subprocess.run([sys.executable, "-m", "simcalib", "run", "scenario=random",
                          *overrides, f"output={tmp_path / 'i'}"], env=env,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "solver kernels: interpreted" in out.stdout
    res = json.loads((tmp_path / "i" / "results.json").read_text())
    assert res["solver_kernels"] == "interpreted"
    for s in compiled.solvers:
        got = res["solvers"][s.label]
        np.testing.assert_allclose(np.array(got["X"]), s.X, atol=1e-10, rtol=0)
        assert got["alpha"] == pytest.approx(s.alpha, rel=1e-9)


@pytest.mark.slow
def test_first_run_on_a_cold_cache_is_interpreted_and_starts_the_fill(tmp_path):
    cache = tmp_path / "numba-cache"
    env = dict(os.environ, SIMCALIB_KERNELS="auto", NUMBA_CACHE_DIR=str(cache))
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "simcalib", "run", "scenario=random",
                          "synthetic.num_motions=60", "pairing.n_pairs=30",
                          "solvers=[dqopt]", "recording.enabled=false", "progress=false",
                          f"output={tmp_path / 'o'}"], env=env, capture_output=True,
                         text=True, timeout=300)
    wall = time.perf_counter() - t0
    assert out.returncode == 0, out.stderr
    res = json.loads((tmp_path / "o" / "results.json").read_text())
    assert res["solver_kernels"] == "interpreted"
    locks = list(cache.glob("simcalib-kernels-*.filling"))
    stamps = list(cache.glob("simcalib-kernels-*.ok"))
    assert locks or stamps, "the run started no cache fill"
    for lock in locks:   # do not leave a 25 s compile running after the test
        try:
            os.kill(int(lock.read_text()), 9)
        except (OSError, ValueError):
            pass
    assert wall < 60


def test_bad_kernel_mode_is_a_config_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SIMCALIB_KERNELS", "fast")
    code = main(["run", "scenario=random", "synthetic.num_motions=20", "pairing.n_pairs=10",
                 "recording.enabled=false", "progress=false", f"output={tmp_path}"])
    err = capsys.readouterr().err
    assert code != 0
    assert "SIMCALIB_KERNELS='fast'" in err and "auto" in err and "interpreted" in err
