"""Calibrate two recorded pose streams end to end (the library core of the future
``python -m simcalib calibrate`` command):

    read (simcalib.importers) -> conventions (simcalib.conventions) -> clock offset
    (simcalib.timesync) -> synchronise + motions -> robust solve (RANSAC + dqopt) and, for
    comparison, a plain solve without rejection.

``python -m simcalib.calibrate_streams --simulate`` prints the simulation validation tables;
``python -m simcalib.calibrate_streams --eth DIR`` calibrates the two ETH
hand_eye_calibration data sets (zips in DIR, unpacked to a temporary folder) and prints the
table of ``docs/calibrate.md``; ``python -m simcalib.calibrate_streams A B`` one pair of files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["StreamCalibration", "calibrate_streams", "ETH_SETS"]


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
    ``i[k]`` to ``j[k]``.
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
                             summary, synced=sp, motion_index=(i, j))


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
    from simcalib.geometry import invert_transform
    Y = T_a @ X @ invert_transform(T_b)
    U, _, Vt = np.linalg.svd(Y[:, :3, :3].mean(axis=0))
    R = U @ Vt
    if np.linalg.det(R) < 0:
        U[:, -1] *= -1
        R = U @ Vt
    out = np.eye(4)
    out[:3, :3] = R
    out[:3, 3] = np.median(Y[:, :3, 3], axis=0)
    return out


def _rot_angle(X1, X2):
    from simcalib.geometry import rotation_error_rad
    return float(rotation_error_rad(X1, X2))


ETH_SETS = {
    "robot_arm_w_color_camera_sim": ("robot_arm_sim_hand.csv", "robot_arm_sim_camera.csv"),
    "prime_sense_1": ("2017-04-09-18-13-10_vicon_prime_sense.csv",
                      "2017-04-09-18-13-10_W_camera_rgb_image_raw.csv"),
}


def eth_files(root) -> dict:
    """Unpack the ETH zips in ``root`` into a temporary folder; ``{set: (path_a, path_b)}``
    (a: the hand / Vicon stream, b: the camera stream)."""
    import tempfile
    import zipfile
    from pathlib import Path
    root = Path(root)
    out = Path(tempfile.mkdtemp(prefix="simcalib_eth_"))
    for z in sorted(root.glob("*.zip")):
        with zipfile.ZipFile(z) as f:
            f.extractall(out)
    found = {}
    for name, (fa, fb) in ETH_SETS.items():
        pa = next(out.rglob(fa), None)
        pb = next(out.rglob(fb), None)
        if pa is not None and pb is not None:
            found[name] = (pa, pb)
    return found


def _table(results: dict) -> str:
    rows = ["| data set | solve | offset (ms) | motions | inliers | X translation (mm) | "
            "X rotation vector (deg) | residual rot median / rms (deg) | "
            "residual trans median / rms (mm) |",
            "|---|---|---|---|---|---|---|---|---|"]
    f3 = lambda v: ", ".join(f"{x:.1f}" for x in v)  # noqa: E731
    for name, r in results.items():
        s = r.summary
        ri, rp = s["residuals_inliers"], s["residuals_plain"]
        rows.append(f"| {name} | RANSAC + dqopt, offset estimated | {s['offset_ms']:.2f} +- "
                    f"{s['offset_sigma_ms']:.2f} | {s['n_motions']} | {s['n_inliers']} | "
                    f"{f3(np.array(s['X']['t_m']) * 1e3)} | {f3(s['X']['rotvec_deg'])} | "
                    f"{ri['rot_median_deg']:.3f} / {ri['rot_rms_deg']:.3f} | "
                    f"{ri['trans_median_mm']:.2f} / {ri['trans_rms_mm']:.2f} |")
        ra = s["residuals_aligned"]
        rows.append(f"| {name} | dqopt, offset estimated, no rejection | {s['offset_ms']:.2f} | "
                    f"{s['n_motions']} | all | {f3(np.array(s['X_aligned']['t_m']) * 1e3)} | "
                    f"{f3(s['X_aligned']['rotvec_deg'])} | {ra['rot_median_deg']:.3f} / "
                    f"{ra['rot_rms_deg']:.3f} | {ra['trans_median_mm']:.2f} / "
                    f"{ra['trans_rms_mm']:.2f} |")
        rows.append(f"| {name} | plain dqopt, synchronous, no rejection | 0 | "
                    f"{s['n_motions_plain']} | all | {f3(np.array(s['X_plain']['t_m']) * 1e3)} | "
                    f"{f3(s['X_plain']['rotvec_deg'])} | {rp['rot_median_deg']:.3f} / "
                    f"{rp['rot_rms_deg']:.3f} | {rp['trans_median_mm']:.2f} / "
                    f"{rp['trans_rms_mm']:.2f} |")
    return "\n".join(rows)


def simulation_tables(runs: int = 5, ransac_runs: int = 50) -> str:
    """The simulation numbers of docs/calibrate.md (time alignment and RANSAC)."""
    import simcalib
    from simcalib.geometry import (random_rotation_matrices, rotation_error_rad,
                                   transform_from_rotation_translation, translation_error_m)
    from simcalib.solvers.robust import inlier_scores, ransac
    from simcalib.stream_sim import rig_streams
    from simcalib.synthetic import synthetic_problem
    from simcalib.timesync import estimate_time_offset, make_motions, synchronise

    def x_err(rs, off):
        C, H, _, _ = make_motions(synchronise(rs.a, rs.b, off), step_s=0.5)
        X = simcalib.solve(C, H).X
        return (math.degrees(float(rotation_error_rad(X, rs.X))),
                1e3 * float(translation_error_m(X, rs.X)))
    out = ["| path | offset (ms) | max abs offset error (ms) | mean reported sigma (ms) | "
           "X rot err, estimated / true offset (deg) | X trans err, estimated / true (mm) | "
           "X rot err without alignment (deg) |", "|---|---|---|---|---|---|---|"]
    for path in ("3d", "planar"):
        for off in (0.0, 0.037, 0.250):
            errs, sig, xe, xt, xn = [], [], [], [], []
            for seed in range(runs):
                rs = rig_streams(offset_s=off, path=path, rng=np.random.default_rng(seed))
                est = estimate_time_offset(rs.a, rs.b)
                errs.append(abs(est.offset_s - off))
                sig.append(est.uncertainty_s)
                xe.append(x_err(rs, est))
                xt.append(x_err(rs, off))
                xn.append(x_err(rs, 0.0))
            xe, xt, xn = np.median(xe, 0), np.median(xt, 0), np.median(xn, 0)
            out.append(f"| {path} | {off * 1e3:.0f} | {1e3 * max(errs):.3f} | "
                       f"{1e3 * np.mean(sig):.3f} | {xe[0]:.4f} / {xt[0]:.4f} | "
                       f"{xe[1]:.3f} / {xt[1]:.3f} | {xn[0]:.4f} |")
    out += ["", "| outlier motions | kind | runs | median rot err clean / plain / RANSAC (deg) | "
            "median trans err clean / plain / RANSAC (cm) | RANSAC / clean | plain / clean | "
            "precision | recall | inliers found (prec >= .95, rec >= .9) |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    from simcalib.geometry import perturb_transforms
    for frac, kind in ((0.2, "gross"), (0.4, "gross"), (0.2, "moderate")):
        rows = []
        for seed in range(ransac_runs):
            rng = np.random.default_rng(seed)
            p = synthetic_problem("random", n=100, rng=rng)
            k = int(round(frac * 100))
            idx = rng.choice(100, k, replace=False)
            C = p.C.copy()
            if kind == "gross":      # a random rigid motion instead of the measured one
                C[idx] = transform_from_rotation_translation(
                    random_rotation_matrices(rng, (k,)), rng.uniform(-1, 1, (k, 3)))
            else:                    # the measured motion corrupted by 5 deg / 5 cm (1 sigma)
                C[idx] = perturb_transforms(C[idx], math.radians(5.0), 0.05, rng)
            good = np.ones(100, bool)
            good[idx] = False
            e = lambda X: (math.degrees(float(rotation_error_rad(X, p.X))),  # noqa: E731
                           100 * float(translation_error_m(X, p.X)))
            r = ransac(C, p.H, rng=np.random.default_rng(1000 + seed))
            sc = inlier_scores(r.inlier_mask, good)
            rows.append((*e(simcalib.solve(p.C, p.H).X), *e(simcalib.solve(C, p.H).X),
                         *e(r.X), sc["precision"], sc["recall"]))
        a = np.array(rows)
        m = np.median(a, 0)
        found = np.mean((a[:, 6] >= 0.95) & (a[:, 7] >= 0.9))
        out.append(f"| {frac:.0%} | {kind} | {ransac_runs} | "
                   f"{m[0]:.4f} / {m[2]:.3f} / {m[4]:.4f} | "
                   f"{m[1]:.3f} / {m[3]:.2f} / {m[5]:.3f} | {m[4] / m[0]:.2f} (rot), "
                   f"{m[5] / m[1]:.2f} (trans) | {m[2] / m[0]:.0f} (rot) | "
                   f"{a[:, 6].mean():.3f} | {a[:, 7].mean():.3f} | {found:.0%} |")
    return "\n".join(out)


def main(argv=None) -> int:
    import argparse
    p = argparse.ArgumentParser(prog="python -m simcalib.calibrate_streams",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("files", nargs="*", help="two pose files a b")
    p.add_argument("--eth", help="folder with the ETH zips (calibrate both data sets)")
    p.add_argument("--robust", default="ransac")
    p.add_argument("--simulate", action="store_true",
                   help="print the simulation validation tables of docs/calibrate.md")
    args = p.parse_args(argv)
    if args.simulate:
        print(simulation_tables())
        return 0
    if args.eth:
        pairs = eth_files(args.eth)
        if not pairs:
            print(f"no ETH data sets found in {args.eth}")
            return 2
    elif len(args.files) == 2:
        pairs = {"a-b": tuple(args.files)}
    else:
        p.error("give two files or --eth DIR")
    results = {}
    for name, (fa, fb) in pairs.items():
        r = calibrate_streams(fa, fb, robust=args.robust)
        results[name] = r
        s = r.summary
        print(f"## {name}\n- a: {s['a']}\n- b: {s['b']}\n- conventions: {s['conventions']}\n"
              f"- time offset: {s['offset_message']}\n- {s['robust_message']}\n"
              f"- X (robust): t = {np.round(np.array(s['X']['t_m']) * 1e3, 2).tolist()} mm, "
              f"q_xyzw = {np.round(s['X']['q_xyzw'], 5).tolist()}\n"
              f"- robust vs plain: {s['rot_diff_deg']:.3f} deg, {s['trans_diff_mm']:.2f} mm; "
              f"degenerate: {s['degenerate']}\n")
    print(_table(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
