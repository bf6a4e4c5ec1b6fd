"""Covariance terms the path adds to X's on the directions the data determine: the 1-sigma
of b's estimated scale (:mod:`simcalib.estimation.scale`) and a stated error common to
every pose (:mod:`simcalib.estimation.common_error`), neither of which the residuals
show."""

from __future__ import annotations

import numpy as np

__all__ = ["with_scale", "with_common_error", "add_determined"]


def with_scale(cov, cov_det, rob, check, ms, scale, alpha):
    """The covariances with the estimated scale's 1-sigma carried into X (on the
    determined directions), where the scale used was estimated."""
    if cov is None or not scale.sigma_used > 0.0:
        return cov, cov_det
    from simcalib.estimation.scale import scale_covariance
    add = scale_covariance(ms.C, ms.H, rob.inlier_mask.astype(np.float64),
                           scale.sigma_used / scale.used, alpha)
    return add_determined(cov, cov_det, rob, check, add)


def with_common_error(cov, cov_det, rob, check, common):
    """``(cov, cov_det, common)``: the covariances with the stated ``common`` error's
    (:class:`~simcalib.estimation.common_error.CommonError`) added on the determined
    directions, and ``common`` where it was added (else None)."""
    if cov is None or common is None or not common.stated:
        return cov, cov_det, None
    return (*add_determined(cov, cov_det, rob, check, common.covariance(rob.X)), common)


def add_determined(cov, cov_det, rob, check, add):
    """``(cov, cov_det)`` with the 6x6 ``add`` projected on the determined directions (the
    basis the consistency check reports, else the model's; undetermined axes stay
    ``inf``)."""
    basis = getattr(check, "basis", None)
    B = np.asarray(rob.solution.uncertainty.determined_basis if basis is None else basis)
    P = B @ B.T
    add = P @ add @ P
    out = cov.copy()
    fin = np.isfinite(out)
    out[fin] = out[fin] + add[fin]
    return out, cov_det + add
