"""solve_batch's result assembly (simcalib.solvers.batch_solve): success and the failure
reasons, with and without failed problems."""

import numpy as np

import simcalib
from simcalib.solvers.batch_solve import _success_and_reasons
from solver_cases import general_case


def test_failure_reasons_name_only_the_failed_problems(monkeypatch):
    from simcalib.solvers import dq
    from simcalib.solvers.kernels import dqcore
    rng = np.random.default_rng(5)
    C, H, _ = general_case(rng, n=8, sigma_r=0.01, sigma_t=0.01)
    CB, HB = np.stack([C, C, C]), np.stack([H, H, H])
    ok = simcalib.solve_batch(CB, HB)
    assert ok.success.all()
    assert ok.diagnostics["failure_reason"].dtype == object
    assert list(ok.diagnostics["failure_reason"]) == ["", "", ""]
    real = dq.kernel_batch.run_batch

    def second_fails(*args, **kwargs):   # the kernel's output for a failed problem 1
        out = real(*args, **kwargs)
        out["X"][1] = np.nan
        out["info"][1, dqcore.I_STATUS] = dqcore.ST_NONFINITE
        return out

    monkeypatch.setattr(dq.kernel_batch, "run_batch", second_fails)
    b = simcalib.solve_batch(CB, HB)
    assert list(b.success) == [True, False, True]
    reason = b.diagnostics["failure_reason"]
    assert reason.dtype == object and reason.shape == (3,)
    assert list(reason) == ["", dqcore.STATUS_TEXT[dqcore.ST_NONFINITE], ""]
    assert np.isnan(b.X[1]).all() and np.isinf(b.cost[1])
    np.testing.assert_array_equal(b.X[[0, 2]], ok.X[[0, 2]])


def test_non_finite_x_without_a_reason_is_named():
    X = np.tile(np.eye(4), (3, 1, 1))
    X[1, 0, 0] = np.nan
    success, reason = _success_and_reasons({"X": X}, X, 3)
    assert list(success) == [True, False, True]
    assert list(reason) == ["", "non-finite X", ""]
    out = {"X": X, "success": np.array([True, True, False]),
           "failure_reason": np.array(["", "", "solver raised"], dtype=object)}
    success, reason = _success_and_reasons(out, X, 3)
    assert list(success) == [True, False, False]
    assert list(reason) == ["", "non-finite X", "solver raised"]
    success, reason = _success_and_reasons({"X": np.eye(4)[None]}, np.eye(4)[None], 1)
    assert success.all() and reason.dtype == object and list(reason) == [""]
