"""simcalib bench: the hot-path mode (solve vs the reference single solve, batch rate), the
ratio column of the timing table (issue 32), and what the hot path relies on in the API: a
lazily evaluated cost/objective and the fast rigidity check of solver output (issue 29)."""

import copy
import json
import pickle
from dataclasses import replace

import numpy as np
import pytest

import simcalib
from simcalib.studies.bench import solvers as bench
from simcalib import geometry as g
from simcalib.solvers import api


def _problem(seed=0, n=30, sigma=0.005):
    C, H, _ = bench.make_problems(np.random.default_rng(seed), 1, n, sigma, sigma)
    return C[0], H[0]


# ------------------------------------------------------------------ issue 32: ratio column
def _rows(us_by_method):
    return {m: {"runtime_s": np.asarray(us) * 1e-6, "wall_s": np.asarray(us) * 1e-6,
                "cost": np.ones(len(us)), "failures": 0} for m, us in us_by_method.items()}


def _ratio_column(text, method):
    line = next(ln for ln in text.splitlines() if ln.startswith(method + " "))
    return line.split()[-2]   # ..., ratio, rel. cost


def test_ratio_column_keeps_significant_digits_for_fast_methods():
    rows = _rows({"dqopt": [50.0, 60.0, 40.0], "opencv_daniilidis": [40_000.0] * 3,
                  "daniilidis": [400.0, 400.0, 400.0], "slowest": [80_000.0] * 3})
    text = bench._fmt_table(rows, "opencv_daniilidis")
    assert _ratio_column(text, "dqopt") == "0.00125"        # was "0.00"
    assert _ratio_column(text, "daniilidis") == "0.01"
    assert _ratio_column(text, "opencv_daniilidis") == "1"
    assert _ratio_column(text, "slowest") == "2"
    for m in rows:
        assert float(_ratio_column(text, m)) > 0
    assert _ratio_column(bench._fmt_table(rows, None), "dqopt") == "-"


# ----------------------------------------------------------------------- reference solve
def test_reference_solve_is_dqopt_on_unambiguous_motions():
    rng = np.random.default_rng(3)
    R = g.matrix_from_rotvec(rng.normal(size=(40, 3)) * 0.4)   # far from 180 deg
    C = g.transform_from_rotation_translation(R, rng.normal(size=(40, 3)))
    X = g.transform_from_rotation_translation(g.random_rotation_matrices(rng), [0.1, 0.2, 0.3])
    H = g.perturb_transforms(g.invert_transform(X) @ C @ X, 0.003, 0.003, rng)
    ref = bench.reference_solve(C, H, 0.7)
    np.testing.assert_allclose(ref, simcalib.solve(C, H, alpha=0.7).X, atol=1e-12)
    assert np.abs(ref - X).max() < 0.02


def test_hot_path_reports_both_rows():
    h = bench.hot_path(n=20, problems=6, repeats=2, alpha=1.0, sigma_r=0.01, sigma_t=0.01,
                       seed=1, batch_size=8)
    assert len(h["solve_wall_s"]) == len(h["reference_wall_s"]) == len(h["ratio"]) == 2
    np.testing.assert_allclose(h["ratio"], np.divide(h["solve_wall_s"], h["reference_wall_s"]))
    assert all(r > 0 for r in h["ratio"]) and h["runtime_s_median"] > 0
    assert 0 <= h["x_agree"] <= 6 and len(h["batch_problems_per_s"]) == 2
    text = "\n".join(bench.hot_path_lines(h))
    assert "x the reference" in text and "problems/s" in text
    md = bench.markdown_tables({"hot_path": {**h, "load": "load x"}})
    assert "| ratio solve / reference |" in md and "| `solve_batch` B = 8 (problems/s) |" in md


def test_hot_path_command(tmp_path, capsys):
    out = tmp_path / "h.json"
    assert bench.main(["--hot-path", "--n-motions", "12", "--problems", "4", "--repeats", "2",
                       "--throughput-batch", "4", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "ratio" in text and "x the reference" in text and "load average" in text
    h = json.loads(out.read_text())["hot_path"]
    assert h["n_motions"] == 12 and h["problems"] == 4 and len(h["ratio"]) == 2
    with pytest.raises(SystemExit):
        bench.main(["--hot-path", "--repeats", "0"])


# ------------------------------------------------------------- the hot path in the API
def test_cost_and_objective_are_evaluated_on_first_read_with_the_eager_numbers():
    C, H = _problem(4)
    off = g.transform_from_rotation_translation(g.matrix_from_rotvec(np.array([0.05, 0, 0])),
                                                [0.02, 0.0, 0.0])
    prior = simcalib.Prior(X=simcalib.solve(C, H).X @ off, a=2.0, b=3.0)
    for kw in ({}, {"prior": prior}, {"method": "dq2steps", "alpha": 0.3},
               {"weights": np.linspace(0.5, 1.5, 30)}, {"method": "daniilidis"}):
        sol = simcalib.solve(C, H, **kw)
        assert sol.__dict__["cost"] is api.PENDING and sol.__dict__["objective"] is api.PENDING
        eager = api._cost_and_objective(sol.problem, sol.X, sol.alpha, sol.prior)
        assert sol.objective == eager[1] and sol.cost == eager[0]   # objective read first
        assert sol.__dict__["cost"] == eager[0]                       # stored once
        assert type(sol.cost) is float
        assert sol.cost == api.dq_cost(sol.X, sol.problem, sol.alpha)
        if "prior" in kw:
            assert sol.objective > sol.cost
        else:
            assert sol.objective == sol.cost
    # every copy holds numbers, never the marker
    sol = simcalib.solve(C, H)
    cost = api._cost_and_objective(sol.problem, sol.X, sol.alpha, None)[0]
    back = pickle.loads(pickle.dumps(sol))
    assert back.__dict__["cost"] == cost and back.cost == cost
    assert copy.deepcopy(simcalib.solve(C, H)).cost == cost
    assert replace(simcalib.solve(C, H), tolerance_deg=2.0).cost == cost
    assert f"cost={cost!r}" in repr(simcalib.solve(C, H))
    # a failed solve has its inf eagerly; a Solution built by hand keeps what it was given
    I = np.tile(np.eye(4), (4, 1, 1))
    failed = simcalib.solve(I, I, method="dqoptpoly")   # raises inside: no X
    assert not failed.success and failed.__dict__["cost"] == np.inf == failed.objective
    made = api.Solution(X=np.eye(4), cost=1.5, objective=2.5, method="m", alpha=1.0,
                        runtime_s=0.0, success=True, solver_message="", n_motions=2)
    assert (made.cost, made.objective) == (1.5, 2.5)
    with pytest.raises(TypeError):
        api.Solution(X=np.eye(4))   # cost and objective stay required


def test_fast_rigidity_check_never_accepts_what_check_transforms_refuses():
    rng = np.random.default_rng(8)
    X = simcalib.solve(*_problem(5)).X
    accepted = refused_fast = 0
    for k in range(3000):
        Y = X.copy()
        scale = 10.0 ** rng.uniform(-12, -3)
        part = k % 4
        if part == 0:
            Y[:3, :3] += rng.normal(size=(3, 3)) * scale
        elif part == 1:
            Y[3, k % 4] += scale * (1 if k % 8 < 4 else -1)
        elif part == 2:
            Y[:3, :3] *= 1 + scale
        else:
            Y[:3, :3] = Y[:3, :3] @ np.diag([1.0, 1.0, -1.0 if k % 8 == 3 else 1.0]) * (1 + scale)
        try:
            g.check_transforms(Y, "X")
            exact = True
        except ValueError:
            exact = False
        fast = api._clearly_rigid(Y)
        assert not (fast and not exact), (k, scale)
        accepted += fast
        refused_fast += exact and not fast
        # and _finish_output's decision and message are check_transforms' own
        _, ok, msg, _ = api._finish_output(Y, "m")
        assert ok == exact and (exact or "returned a non-rigid X" in msg)
    assert accepted > 1000 and refused_fast > 0   # both branches ran


def test_throughput_reports_cpu_per_problem_and_the_overhead_per_call(capsys):
    assert bench.main(["--throughput", "--throughput-batch", "8", "--repeats", "3",
                       "--n-motions", "10", "--markdown", "-"]) == 0
    text = capsys.readouterr().out
    assert "CPU per problem (process," in text and "wall beyond CPU / threads" in text
    t = {"batch_size": 1000, "problems_per_s": [100_000.0, 50_000.0], "cpu_s": [0.018, 0.02],
         "threads": 2}
    o = bench.throughput_overhead(t)
    np.testing.assert_allclose(o["cpu_us_per_problem"], [18.0, 20.0])
    np.testing.assert_allclose(o["overhead_ms"], [10.0 - 9.0, 20.0 - 10.0])
