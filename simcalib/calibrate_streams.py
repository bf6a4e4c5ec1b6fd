"""Calibrate two recorded pose streams end to end (the library core of
``python -m simcalib calibrate``, :mod:`simcalib.commands.calibrate`):

    read (simcalib.importers) -> conventions (simcalib.conventions) -> clock offset
    (simcalib.timesync) -> synchronise + motions -> robust solve (RANSAC + dqopt) and, for
    comparison, a plain solve without rejection.

The validation in simulation and on the ETH data sets is the experiment
``python -m simcalib experiment streams`` (:mod:`simcalib.experiments.streams`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["StreamCalibration", "calibrate_streams", "align_worlds"]


@dataclass(frozen=True, eq=False)
class StreamCalibration:
    """Everything one calibration of two streams produced.

    ``X``: ``T_a_b`` (robust); ``X_plain``: the synchronous solve without rejection (offset 0,
    all motions); ``time_offset``: :class:`simcalib.timesync.TimeOffset`; ``conventions``:
    :class:`simcalib.conventions.ConventionReport`; ``robust`` / ``plain``:
    :class:`simcalib.solvers.robust.RobustSolution`; ``C``, ``H`` the motions used,
    ``motion_time_s`` their start instants (clock a); ``summary``: numbers for reports;
    ``synced``: the synchronised poses (:class:`simcalib.timesync.SyncedPoses`) the motions
    were formed from; ``motion_index``: ``(i, j)``, motion k runs from ``synced`` instant
    ``i[k]`` to ``j[k]``; ``X_aligned``: dqopt on the same motions without rejection.
    """
    X: np.ndarray
    X_plain: np.ndarray
    time_offset: object
    conventions: object
    robust: object
    plain: object
    stream_a: object
    stream_b: object
    C: np.ndarray = field(repr=False)
    H: np.ndarray = field(repr=False)
    motion_time_s: np.ndarray = field(repr=False)
    summary: dict = field(default_factory=dict)
    synced: object = field(default=None, repr=False)
    motion_index: tuple = field(default=(), repr=False)
    X_aligned: np.ndarray | None = field(default=None, repr=False)


def _errors_summary(C, H, X, mask=None):
    from simcalib.solvers.robust import constraint_errors
    r, t = constraint_errors(C, H, X)
    if mask is not None:
        r, t = r[mask], t[mask]
    return {"rot_median_deg": float(np.degrees(np.median(r))),
            "rot_rms_deg": float(np.degrees(np.sqrt(np.mean(r**2)))),
            "trans_median_mm": float(1e3 * np.median(t)),
            "trans_rms_mm": float(1e3 * np.sqrt(np.mean(t**2)))}


def _pose_summary(X):
    from simcalib.geometry import quat_from_matrix, rotvec_from_matrix
    return {"t_m": X[:3, 3].tolist(), "q_xyzw": quat_from_matrix(X[:3, :3]).tolist(),
            "rotvec_deg": np.degrees(rotvec_from_matrix(X[:3, :3])).tolist()}


def calibrate_streams(a, b, *, format_a: str | None = None, format_b: str | None = None,
                      time_offset="estimate", robust: str = "ransac", alpha: float = 1.0,
                      step_s: float = 1.0, min_rotation_deg: float = 2.0,
                      max_rotation_deg: float | None = None, invert_a: bool | None = None,
                      invert_b: bool | None = None, scalar_first_a: bool | None = None,
                      scalar_first_b: bool | None = None, drift: bool = False,
                      robust_options: dict | None = None, method: str = "dqopt",
                      prior=None, seed: int = 0) -> StreamCalibration:
    """Calibrate ``X = T_a_b`` from two pose streams (paths or PoseStreamData).

    ``time_offset``: ``"estimate"`` or seconds ``t_b - t_a``. ``robust``: ``none``,
    ``ransac`` or ``irls``. Motions: over ``step_s`` seconds from every synchronised instant,
    kept when they rotate at least ``min_rotation_deg`` (at most ``max_rotation_deg``).
    Conventions are detected unless forced (``invert_*``, ``scalar_first_*``). ``method``:
    the solver of the final estimate (RANSAC's minimal sets stay dqopt); ``prior``: a
    :class:`simcalib.Prior`, used in a final solve on the inliers (IRLS: with their weights).
    Bad files raise :class:`simcalib.errors.DataError`.
    """
    from simcalib.conventions import apply_conventions, detect_conventions
    from simcalib.importers import PoseStreamData, read_pose_stream
    from simcalib.solvers.robust import robust_solve
    from simcalib.timesync import (_as_offset, estimate_time_offset, make_motions,
                                   synchronise)
    sa = a if isinstance(a, PoseStreamData) else read_pose_stream(a, format_a)
    sb = b if isinstance(b, PoseStreamData) else read_pose_stream(b, format_b)
    fixed = None if time_offset == "estimate" else _as_offset(time_offset)
    conv = detect_conventions(sa, sb, offset=fixed, invert_a=invert_a, invert_b=invert_b,
                              scalar_first_a=scalar_first_a, scalar_first_b=scalar_first_b,
                              alpha=alpha, seed=seed)
    sa, sb = apply_conventions(sa, sb, conv)
    sample_indexed = sa.synthetic_time or sb.synthetic_time
    if fixed is not None:
        off = fixed
    elif sample_indexed:
        off = _as_offset(0.0)
    else:
        off = estimate_time_offset(sa, sb, drift=drift, alpha=alpha)
    sp = synchronise(sa, sb, off)
    C, H, i, j = make_motions(sp, step_s=step_s, min_rotation_deg=min_rotation_deg,
                              max_rotation_deg=max_rotation_deg)
    opts = dict(robust_options or {})
    if robust in ("ransac", "irls"):
        opts.setdefault("rng", np.random.default_rng(seed))
    opts.setdefault("final_method" if robust == "ransac" else "method", method)
    rob = robust_solve(C, H, robust, alpha=alpha, **opts)
    if prior is not None:
        rob = _with_prior(C, H, rob, method, alpha, prior)
    # plain: synchronous (offset 0), no rejection, same motion rule
    sp0 = synchronise(sa, sb, 0.0)
    C0, H0, _, _ = make_motions(sp0, step_s=step_s, min_rotation_deg=min_rotation_deg,
                                max_rotation_deg=max_rotation_deg)
    plain = robust_solve(C0, H0, "none", alpha=alpha)
    aligned = robust_solve(C, H, "none", alpha=alpha)     # offset applied, no rejection
    summary = {
        "a": sa.describe(), "b": sb.describe(), "conventions": conv.message,
        "offset_ms": 1e3 * off.offset_s, "offset_sigma_ms": 1e3 * off.uncertainty_s,
        "offset_message": off.message, "n_motions": int(C.shape[0]),
        "n_inliers": rob.n_inliers, "robust_message": rob.message,
        "X": _pose_summary(rob.X), "X_plain": _pose_summary(plain.X),
        "residuals_inliers": _errors_summary(C, H, rob.X, rob.inlier_mask),
        "residuals_all": _errors_summary(C, H, rob.X),
        "residuals_plain": _errors_summary(C0, H0, plain.X),
        "n_motions_plain": int(C0.shape[0]),
        "X_aligned": _pose_summary(aligned.X),
        "residuals_aligned": _errors_summary(C, H, aligned.X),
        "rot_diff_deg": float(np.degrees(_rot_angle(rob.X, plain.X))),
        "trans_diff_mm": float(1e3 * np.linalg.norm(rob.X[:3, 3] - plain.X[:3, 3])),
        "degenerate": bool(rob.solution.degenerate) if rob.solution is not None else None,
    }
    return StreamCalibration(rob.X, plain.X, off, conv, rob, plain, sa, sb, C, H, sp.time_s[i],
                             summary, synced=sp, motion_index=(i, j),
                             X_aligned=aligned.X)


def _with_prior(C, H, rob, method, alpha, prior):
    """The robust result re-solved with ``prior`` on its inliers (IRLS: all motions with
    their weights); residuals re-evaluated at the new ``X``."""
    import dataclasses

    import simcalib
    from simcalib.solvers.robust import screw_residuals
    if rob.method == "irls":
        sol = simcalib.solve(C, H, method=method, alpha=alpha, prior=prior,
                             weights=rob.weights)
    else:
        m = rob.inlier_mask
        sol = simcalib.solve(C[m], H[m], method=method, alpha=alpha, prior=prior)
    return dataclasses.replace(rob, X=sol.X, solution=sol,
                               residuals=screw_residuals(C, H, sol.X, alpha),
                               message=rob.message + f"; final {method} with the prior")


def align_worlds(T_a: np.ndarray, T_b: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``T_wa_wb``: the fixed transform between the two streams' world frames implied by
    ``X`` (``T_wa_a X = T_wa_wb T_wb_b`` at every synchronised instant), as the chordal
    mean rotation (SVD projection of the mean) and the median translation of the per-instant
    estimates ``T_wa_a X T_wb_b^-1``. Used to draw both trajectories in one frame."""
    from simcalib.geometry import chordal_mean_rotation, invert_transform
    Y = T_a @ X @ invert_transform(T_b)
    out = np.eye(4)
    out[:3, :3] = chordal_mean_rotation(Y[:, :3, :3])
    out[:3, 3] = np.median(Y[:, :3, 3], axis=0)
    return out


def _rot_angle(X1, X2):
    from simcalib.geometry import rotation_error_rad
    return float(rotation_error_rad(X1, X2))
