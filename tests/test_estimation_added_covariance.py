"""simcalib.estimation.added_covariance: terms added on the determined directions only."""

from types import SimpleNamespace

import numpy as np

from simcalib.estimation.added_covariance import add_determined, with_common_error


def _rob(basis):
    unc = SimpleNamespace(determined_basis=basis)
    return SimpleNamespace(solution=SimpleNamespace(uncertainty=unc), X=np.eye(4))


def test_add_determined_projects_on_the_determined_directions():
    B = np.eye(6)[:, :5]                        # the last axis undetermined
    cov = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, np.inf])
    cov_det = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 0.0])
    add = np.full((6, 6), 0.5) + np.eye(6)
    out, out_det = add_determined(cov, cov_det, _rob(B), None, add)
    assert np.isinf(out[5, 5]) and np.allclose(out[:5, :5], np.eye(5) + add[:5, :5])
    assert np.allclose(out_det[5], 0.0) and np.allclose(out_det[:, 5], 0.0)
    check = SimpleNamespace(basis=np.eye(6)[:, :1])  # the consistency check's basis wins
    out, _ = add_determined(cov, cov_det, _rob(B), check, add)
    assert out[0, 0] == 1.0 + add[0, 0] and out[1, 1] == 1.0


def test_no_common_error_stated_adds_nothing():
    cov = np.eye(6)
    assert with_common_error(cov, cov, _rob(np.eye(6)), None, None) == (cov, cov, None)
    stated = SimpleNamespace(stated=False)
    assert with_common_error(None, None, _rob(np.eye(6)), None, stated)[2] is None
