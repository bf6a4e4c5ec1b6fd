"""Packaging: the wheel ships models/ and scenarios/; the solver library stays light;
no module picks a rendering or plotting backend when it is imported."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("mujoco", "cv2", "rerun", "matplotlib")
_COPY_IGNORE = shutil.ignore_patterns(".git", ".venv", "build", "dist", "*.egg-info", "runs",
                                      "__pycache__", ".pytest_cache", "*.rrd", "MUJOCO_LOG.TXT")


def _clean_env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "SIMCALIB_SCENARIOS", "MUJOCO_GL", "MPLBACKEND")}
    env.update(extra)
    return env


def _run(args, cwd, env, timeout=300) -> subprocess.CompletedProcess:
    proc = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)
    assert proc.returncode == 0, f"{args} failed:\n{proc.stdout}\n{proc.stderr}"
    return proc


@pytest.mark.slow
def test_wheel_ships_data_and_runs_outside_the_source_tree(tmp_path):
    pytest.importorskip("setuptools")
    src = tmp_path / "src"          # a copy: no stale build/ of the checkout leaks in
    shutil.copytree(REPO, src, ignore=_COPY_IGNORE)
    wheels = tmp_path / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps",
          "-w", str(wheels), str(src)], cwd=tmp_path, env=_clean_env())
    (wheel,) = wheels.glob("simcalib-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for folder in ("models", "scenarios"):
        expected = {f"simcalib/{folder}/{p.name}" for p in (REPO / folder).iterdir()
                    if p.is_file()}
        assert expected and expected <= names, sorted(expected - names)
    expected_py = {p.relative_to(REPO).as_posix() for p in (REPO / "simcalib").rglob("*.py")
                   if "__pycache__" not in p.parts}
    assert expected_py <= names, sorted(expected_py - names)

    # Install it (no dependencies: they come from this interpreter) and run from elsewhere.
    target = tmp_path / "site"
    _run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index",
          "--target", str(target), str(wheel)], cwd=tmp_path, env=_clean_env())
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = _clean_env(PYTHONPATH=str(target))
    out = _run([sys.executable, "-m", "simcalib", "list"], cwd=elsewhere, env=env).stdout
    assert f"scenarios ({target / 'simcalib' / 'scenarios'})" in out, out
    for name in ("planar", "3d", "random"):
        assert f"  {name} " in out, out
    probe = _run([sys.executable, "-c", textwrap.dedent("""
        import simcalib
        from simcalib.config.resources import model_path
        simcalib.load_config("planar")
        print(simcalib.__file__)
        for m in ("room", "cart", "ur5e", "rig"):
            print(model_path(m))
        """)], cwd=elsewhere, env=env).stdout.split("\n")
    assert probe[0].startswith(str(target)), probe
    assert all(line.startswith(str(target / "simcalib" / "models")) for line in probe[1:5])

    # A user's own scenario folder replaces the built-in one.
    own = tmp_path / "mine"
    own.mkdir()
    shutil.copy(REPO / "scenarios" / "random.yaml", own / "myrandom.yaml")
    out = _run([sys.executable, "-m", "simcalib", "list"], cwd=elsewhere,
               env=dict(env, SIMCALIB_SCENARIOS=str(own))).stdout
    listed = out.split("\n\n")[0]                 # the scenarios block of `list`
    assert f"scenarios ({own})" in listed and "  myrandom " in listed, out
    assert "  planar " not in listed, out


def test_resources_find_the_checkout_data(monkeypatch):
    from simcalib.config import resources
    monkeypatch.delenv("SIMCALIB_SCENARIOS", raising=False)
    assert resources.models_dir() == REPO / "models"
    assert resources.scenarios_dir() == REPO / "scenarios"
    assert resources.model_path("rig") == resources.model_path("rig.xml") == REPO / "models" / "rig.xml"
    with pytest.raises(ValueError, match="unknown model 'rigg'.*rig"):
        resources.model_path("rigg")
    with pytest.raises(TypeError, match="non-empty str"):
        resources.model_path(3)
    monkeypatch.setenv("SIMCALIB_SCENARIOS", "/some/where")
    assert resources.scenarios_dir() == Path("/some/where")


def test_solver_library_imports_no_heavy_module():
    code = textwrap.dedent(f"""
        import sys
        import numpy as np
        import simcalib
        from simcalib.geometry import transform_from_rotation_translation
        from scipy.spatial.transform import Rotation
        rng = np.random.default_rng(0)
        def poses(n):
            R = Rotation.random(n, random_state=rng).as_matrix()
            return transform_from_rotation_translation(R, rng.normal(size=(n, 3)))
        X = poses(1)[0]
        H = poses(12)
        C = X @ H @ np.linalg.inv(X)
        for method in ("dqopt", "daniilidis"):
            sol = simcalib.solve(C, H, method=method)
            assert np.abs(sol.X - X).max() < 1e-8, (method, sol.X, X)
        simcalib.solve_batch(C[None], H[None], method="dqopt", alpha=0.5)
        import simcalib.solvers, simcalib.solvers.registry
        heavy = sorted(m for m in sys.modules if m.split(".")[0] in {HEAVY!r})
        print("HEAVY:", heavy)
        """)
    proc = _run([sys.executable, "-c", code], cwd=REPO, env=_clean_env())
    assert "HEAVY: []" in proc.stdout, proc.stdout


@pytest.mark.slow
@pytest.mark.parametrize("module", ["simcalib.world", "simcalib.world.scene",
                                    "simcalib.world.simulate", "simcalib.world.ik",
                                    "simcalib.studies.experiments.plots", "simcalib.pipeline.stages",
                                    "simcalib.cli"])
def test_no_backend_chosen_at_import(module):
    code = textwrap.dedent(f"""
        import os, sys
        import {module}
        assert "MUJOCO_GL" not in os.environ, os.environ["MUJOCO_GL"]
        assert "MPLBACKEND" not in os.environ
        mpl = sys.modules.get("matplotlib")
        assert mpl is None or mpl.rcParams._get_backend_or_none() is None, mpl.get_backend()
        """)
    _run([sys.executable, "-c", code], cwd=REPO, env=_clean_env())


@pytest.mark.slow
def test_experiment_figures_leave_the_matplotlib_backend_alone(tmp_path):
    code = textwrap.dedent(f"""
        import sys
        import matplotlib
        from simcalib.studies.experiments import plots
        fig, axes = plots._subplots(1, 2, figsize=(3, 2), layout="constrained")
        axes[0].plot([1, 2], [1, 4], color=plots._cmap("tab20")(0))
        path = plots._save(fig, {str(tmp_path / "f.png")!r})
        assert path.stat().st_size > 1000
        assert matplotlib.rcParams._get_backend_or_none() is None
        assert "matplotlib.pyplot" not in sys.modules
        """)
    _run([sys.executable, "-c", code], cwd=REPO, env=_clean_env())


# ------------------------------------------------------------------------- the layout
def _import_graph() -> dict[str, set[str]]:
    """module -> the simcalib modules it imports (every import statement, lazy ones too)."""
    import ast
    root = REPO / "simcalib"
    files = {}
    for p in root.rglob("*.py"):
        parts = p.relative_to(REPO).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        files[name] = p
    graph = {}
    for name, p in files.items():
        is_pkg = p.name == "__init__.py"
        out = set()
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                    pkg = pkg[:len(pkg) - (node.level - 1)]
                    base = ".".join(pkg + ([base] if base else []))
                targets = [f"{base}.{a.name}" for a in node.names] + [base]
            else:
                continue
            for t in targets:
                while t and t not in files:
                    t = t.rpartition(".")[0]
                if t and t != name and t != "simcalib":
                    out.add(t)
        graph[name] = out
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one member (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _folder(module: str) -> str:
    """The folder (top-level package) or top-level module a module belongs to."""
    return ".".join(module.split(".")[:2])


def test_no_folder_imports_back_up():
    """The folders are the architecture: the graph of imports between simcalib's top-level
    folders and modules has no circle (so every folder stands above all it imports)."""
    graph = _import_graph()
    folders: dict[str, set[str]] = {}
    for a, targets in graph.items():
        for b in targets:
            if _folder(a) != _folder(b):
                folders.setdefault(_folder(a), set()).add(_folder(b))
    cycles = _cycles(folders)
    detail = [[(a, b) for a in graph for b in graph[a] if _folder(a) in c and _folder(b) in c
               and _folder(a) != _folder(b)] for c in cycles]
    assert not cycles, f"folders importing each other: {cycles}; through {detail}"


def test_no_circle_between_files_of_different_folders():
    """A circle of imports may only join files of one folder (and is best avoided there)."""
    graph = _import_graph()
    folder_of = lambda m: m.rpartition(".")[0] if m in graph and not any(  # noqa: E731
        k.startswith(m + ".") for k in graph) else m
    mixed = [c for c in _cycles(graph) if len({folder_of(m) for m in c}) > 1]
    assert not mixed, f"circles across folders: {mixed}"


def test_solver_kernels_know_nothing_above_them():
    """simcalib.solvers.kernels (the compiled code, its numpy twins, how a command runs it)
    imports nothing of the solver layers above it (api, single, robust, problem, ...)."""
    graph = _import_graph()
    kernels = "simcalib.solvers.kernels"
    up = sorted((a, b) for a, targets in graph.items() for b in targets
                if a.startswith(kernels) and b.startswith("simcalib.solvers")
                and not b.startswith(kernels))
    assert not up, f"kernels import from above: {up}"
