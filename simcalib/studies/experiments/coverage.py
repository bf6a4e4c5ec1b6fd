"""Monte-Carlo check of the predicted uncertainty and of the degeneracy verdict;
writes ``docs/uncertainty.md``.

    python -m simcalib.studies.experiments.coverage --trials 500 --flag-trials 200 \
        --out docs/uncertainty.md

Every trial is an independent appendix-D.2 data set of ``n`` motions (paper noise: 0.57 deg,
0.01 m, on C and H) with its own seed derived from ``--seed``; the estimate is solved with
:func:`simcalib.solve_batch` and its uncertainty computed by
:func:`simcalib.solvers.diagnostics.uncertainty.covariance` with the noise estimated from the residuals.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from simcalib.solvers.diagnostics import uncertainty as U

from simcalib.studies.experiments.coverage_params import (ALPHA_GRID, CART_SCENARIOS,
                                                          COVERAGE_CASES, FLAG_ALPHAS,
                                                          PRIOR_AB)


def _datasets(motion: str, trials: int, n: int, seed: int):
    from simcalib.world.synthetic import SyntheticConfig, generate_dataset
    cfg = SyntheticConfig(motion=motion, num_motions=n)
    ds = [generate_dataset(cfg, r) for r in np.random.default_rng(seed).spawn(trials)]
    return np.stack([d.C for d in ds]), np.stack([d.H for d in ds]), ds[0].X, ds[0].config


def coverage_case(method: str, alpha: float, with_prior: bool, trials: int, n: int = 100,
                  seed: int = 0, level: float = 0.95) -> dict:
    """Coverage of the ``level`` region and predicted vs empirical RMS per axis."""
    from simcalib.solvers.api import Prior, solve_batch
    C, H, X, cfg = _datasets("random", trials, n, seed)
    priors = [None] * trials
    if with_prior:
        # the prior's own error is drawn from the covariance the prior reading implies
        prng = np.random.default_rng([seed, 1])
        for b in range(trials):
            u0 = U.covariance(C[b], H[b], X, alpha, prior=Prior(X, *PRIOR_AB),
                              noise=(cfg.sigma_r_rad, cfg.sigma_t_m))
            d0 = prng.multivariate_normal(np.zeros(6), u0.prior_covariance)
            priors[b] = Prior(_perturb(X, d0), *PRIOR_AB)
        Xs = np.stack([_solve_one(C[b], H[b], method, alpha, priors[b]) for b in range(trials)])
    else:
        Xs = solve_batch(C, H, method=method, alpha=alpha).X
    records = []
    for b in range(trials):
        if not np.isfinite(Xs[b]).all():
            records.append(None)
            continue
        u = U.covariance(C[b], H[b], Xs[b], alpha, prior=priors[b])
        records.append({"d2": u.mahalanobis2(X), "err": U.pose_error(X, Xs[b]),
                        "pred": np.diag(u.covariance_determined),
                        "degenerate": bool(u.degenerate),
                        "simulated": u.method == "pose_simulation"})
    row = coverage_row(f"random {method}", records, trials, method, level)
    return {**row, "alpha": alpha, "prior": with_prior}


def _perturb(X, d):
    from simcalib.geometry import matrix_from_rotvec
    Y = X.copy()
    Y[:3, :3] = matrix_from_rotvec(d[:3]) @ X[:3, :3]
    Y[:3, 3] = X[:3, 3] + d[3:]
    return Y


def _solve_one(C, H, method, alpha, prior):
    from simcalib.solvers.api import solve
    s = solve(C, H, method=method, alpha=alpha, prior=prior)
    return s.X if s.success else np.full((4, 4), np.nan)


def flag_case(motion: str, alpha: float, trials: int, n: int = 100, seed: int = 0,
              method: str = "dqopt") -> dict:
    from simcalib.solvers.api import solve_batch
    C, H, X, _ = _datasets(motion, trials, n, seed)
    Xs = solve_batch(C, H, method=method, alpha=alpha).X
    flags, undet, beyond = 0, 0, 0
    errs = []
    for b in range(trials):
        u = U.covariance(C[b], H[b], Xs[b], alpha)
        flags += u.degenerate
        undet += bool(u.undetermined)
        d = U.pose_error(X, Xs[b])
        errs.append(math.degrees(np.linalg.norm(d[:3])))
        if not u.degenerate:
            s = np.sqrt(np.diag(u.covariance))
            beyond += bool(np.any(np.abs(d) > 5 * s))
    return {"motion": motion, "alpha": alpha, "trials": trials, "flagged": flags / trials,
            "undetermined": undet / trials, "median_rot_err_deg": float(np.median(errs)),
            "unflagged_beyond_5sigma": beyond / trials}


def _exp_twist(xi):
    """``(..., 6)`` twists ``(w, rho)`` -> ``(..., 4, 4)`` transforms ``exp([xi])``."""
    from simcalib.geometry import matrix_from_rotvec, skew_matrix
    w, rho = xi[..., :3], xi[..., 3:]
    th = np.linalg.norm(w, axis=-1)[..., None, None]
    W = skew_matrix(w)
    small = th < 1e-8
    ths = np.where(small, 1.0, th)
    b = np.where(small, 0.5, (1.0 - np.cos(ths)) / ths**2)
    c = np.where(small, 1.0 / 6.0, (ths - np.sin(ths)) / ths**3)
    V = np.eye(3) + b * W + c * (W @ W)
    T = np.zeros(xi.shape[:-1] + (4, 4))
    T[..., :3, :3] = matrix_from_rotvec(w)
    T[..., :3, 3] = (V @ rho[..., None])[..., 0]
    T[..., 3, 3] = 1.0
    return T


def determined_error(X_true, X_est, determined_basis, tolerance_deg=U.TOLERANCE_DEG,
                     tolerance_m=U.TOLERANCE_M, iterations: int = 8):
    """Error of ``X_est`` (``(..., 4, 4)``) over the determined directions only: the error
    to the nearest (tolerance units) of the poses the data cannot tell from ``X_true``,
    ``exp(xi) X_true`` with ``xi`` any twist of the undetermined subspace (the complement
    of ``determined_basis``, 6 x k in delta coordinates, orthogonal in tolerance units as
    in :func:`~simcalib.solvers.diagnostics.uncertainty.covariance`). A few Gauss-Newton
    steps from the linear projection; exact for the families of degenerate motions (all
    rotations about one screw line: a rotation about it and a translation along it; pure
    translations: any translation and the rotation about the direction), where a linear
    projection leaves second-order terms of a large excursion along the family.
    Returns ``(rotation_deg, translation_m)`` arrays."""
    X_true = np.asarray(X_true, dtype=np.float64)
    X_est = np.asarray(X_est, dtype=np.float64)
    dsc = np.array([math.radians(tolerance_deg)] * 3 + [tolerance_m] * 3)
    Bp = np.asarray(determined_basis, dtype=np.float64).reshape(6, -1)
    Bt = np.linalg.qr(Bp / dsc[:, None])[0] if Bp.shape[1] else np.zeros((6, 0))
    k = 6 - Bt.shape[1]
    Ut = np.linalg.svd(np.eye(6) - Bt @ Bt.T)[0][:, :k]    # undetermined, tolerance units
    Up = Ut * dsc[:, None]
    # delta direction (w, v) <-> twist (w, v - w x t_true): exp(-c xi) X_true has delta c u
    gen = np.concatenate([Up[:3], Up[3:] - np.cross(Up[:3].T, X_true[:3, 3]).T], axis=0)

    def resid(c):
        return U.pose_error(_exp_twist(-(c @ gen.T)) @ X_true, X_est) / dsc

    c = U.pose_error(X_true, X_est) / dsc @ Ut
    for _ in range(iterations if k else 0):
        r = resid(c)
        J = np.stack([(resid(c + 1e-7 * np.eye(k)[j]) - r) / 1e-7 for j in range(k)], -1)
        JT = np.swapaxes(J, -1, -2)
        c = c - np.linalg.solve(JT @ J + 1e-12 * np.eye(k), (JT @ r[..., None]))[..., 0]
    d = resid(c) * dsc
    return np.degrees(np.linalg.norm(d[..., :3], axis=-1)), np.linalg.norm(d[..., 3:], axis=-1)


ALPHA_HOWS = ("noise_ratio", "min_predicted_error")


def exact_determined_basis(C, H, X, tolerance_deg=U.TOLERANCE_DEG,
                           tolerance_m=U.TOLERANCE_M, rel: float = 1e-9) -> np.ndarray:
    """Determined basis (6 x k, delta coordinates) of **noise-free** motions ``C``, ``H``
    at the true ``X``: the range of their information ``sum K^T K`` in tolerance units
    (eigenvalues above ``rel`` times the largest); its complement is the family of poses
    that fit the motions exactly (the true undetermined subspace, no noise threshold)."""
    dsc = np.array([math.radians(tolerance_deg)] * 3 + [tolerance_m] * 3)
    K = U.linear_model(np.asarray(C, dtype=np.float64), np.asarray(H, dtype=np.float64),
                       np.asarray(X, dtype=np.float64))[1] * dsc
    lam, V = np.linalg.eigh(np.einsum("nki,nkj->ij", K, K))
    return V[:, lam > rel * lam[-1]] * dsc[:, None]


def alpha_compare(label: str, data: list, grid, exact_bases=None) -> dict:
    """Median errors (over the data sets ``[(C, H, X_true, lag), ...]``) of dqopt at the
    data-chosen alpha (each of :data:`ALPHA_HOWS` from the dqopt estimate at alpha = 1) and
    at the oracle alpha of ``grid`` (best median rotation error against the truth): raw
    (keys without prefix), over the determined directions of the verdict (``det_``:
    :func:`determined_error` with ``Uncertainty.determined_basis`` of
    :func:`~simcalib.solvers.diagnostics.uncertainty.covariance` at the true X) and, if
    ``exact_bases`` (one per data set, :func:`exact_determined_basis`) is given, over the
    exactly determined directions (``ex_``); each with its own oracle. ``mpe_``: the same
    at ``min_predicted_error``'s alpha."""
    from simcalib.solvers.api import solve, solve_batch
    grid = np.asarray(grid, dtype=np.float64)
    kinds = ("", "det_") + (("ex_",) if exact_bases is not None else ())
    chosen = {h: [] for h in ALPHA_HOWS}
    on_grid, dofs = [], {k: [] for k in kinds}
    for i, (C, H, X, lag, *_) in enumerate(data):
        bases = {"det_": U.covariance(C, H, X, 1.0, correlation_lag=lag).determined_basis}
        if exact_bases is not None:
            bases["ex_"] = exact_bases[i]

        def errs(Xe):
            d = U.pose_error(X, Xe)
            out = [np.degrees(np.linalg.norm(d[..., :3], axis=-1)),
                   np.linalg.norm(d[..., 3:], axis=-1)]
            for k in kinds[1:]:
                out += list(determined_error(X, Xe, bases[k]))
            return np.stack(out, axis=-1)
        for k in kinds[1:]:
            dofs[k].append(bases[k].shape[1])
        s1 = solve(C, H, method="dqopt", alpha=1.0)
        for h in ALPHA_HOWS:
            a = U.choose_alpha(C, H, s1.X, 1.0, how=h).alpha if s1.success else 1.0
            chosen[h].append(np.concatenate([[a], errs(solve(C, H, alpha=a).X)]))
        B = grid.size
        Xg = solve_batch(np.broadcast_to(C, (B,) + C.shape), np.broadcast_to(H, (B,) + H.shape),
                         alpha=grid).X
        e = np.full((B, 2 * len(kinds)), np.nan)
        ok = np.isfinite(Xg).all(axis=(1, 2))
        e[ok] = errs(Xg[ok])
        on_grid.append(e)
    med = np.median(np.array(on_grid), axis=0)              # (grid, 2 * kinds)
    out = {"motion": label, "trials": len(data)}
    for i, k in enumerate(kinds):
        j = int(np.nanargmin(med[:, 2 * i]))
        out.update({f"{k}oracle_alpha": float(grid[j]),
                    f"{k}oracle_rot_deg": float(med[j, 2 * i]),
                    f"{k}oracle_trans_m": float(med[j, 2 * i + 1])})
        if k:
            out[f"{k}dof_median"] = float(np.median(dofs[k]))
    for h, pre in zip(ALPHA_HOWS, ("", "mpe_")):
        m = np.median(np.array(chosen[h]), axis=0)
        out[f"{pre}alpha_median"] = float(m[0])
        for i, k in enumerate(kinds):
            out[f"{pre}{k}rot_deg"] = float(m[1 + 2 * i])
            out[f"{pre}{k}trans_m"] = float(m[2 + 2 * i])
    out["dof_median"] = out["det_dof_median"]
    return out


def alpha_case(motion: str, trials: int, n: int = 100, seed: int = 0) -> dict:
    """:func:`alpha_compare` on appendix-D.2 data sets; oracle over the paper's grid (100
    log-spaced values in [1e-2, 10^1.7])."""
    C, H, X, _ = _datasets(motion, trials, n, seed)
    return alpha_compare(motion, [(C[b], H[b], X, 0) for b in range(trials)],
                         np.logspace(-2, 1.7, 100))


# ------------------------------------------------------------------ simulated scenarios


def scenario_data(scenario: str, overrides=(), seeds=range(3), one_world=False) -> list:
    """``[(C, H, X_true, lag, X_obs, pose_bias, pose_pairs), ...]`` of a run config's motion pairs for
    each seed (the world, streams and pairs stages of :func:`simcalib.run`; no solvers, no
    recording); ``pose_bias``: the calibration term a run passes to the solver
    (:func:`simcalib.pipeline.uncertainty_inputs.calibration_bias`; None without one).
    ``one_world``: the world (path, physics) of the first seed is kept and only the
    measurement (streams, pairs) is redrawn per seed - a Monte-Carlo over the noise."""
    from simcalib.pipeline import uncertainty_inputs as P
    from simcalib.pipeline.scenario import load_config
    from simcalib.pipeline.stages import state_through_pairs
    out = []
    truth = None
    for seed in seeds:
        cfg = load_config(scenario, ["recording.enabled=false", "progress=false",
                                     "workers=1", f"seed={seed}", *overrides])
        st = state_through_pairs(cfg, truth if one_world else None)
        truth = st.truth
        out.append((np.asarray(st.pairs.C), np.asarray(st.pairs.H), np.asarray(st.X_true),
                    P.correlation_lag(st), _x_without_constant_pose_error(st),
                    P.calibration_bias(st)[0], P.pose_pairs(st)))
    return out


def _x_without_constant_pose_error(st):
    """``N_a^-1 X_true N_b`` with ``N_c`` the run-mean error (right-multiplied, camera frame)
    of camera ``c``'s measured poses against the ground truth: the X the relative motions
    actually determine, since a pose error constant over the run is exactly a change of X
    (``C' = N_a^-1 C N_a`` etc.). Uses the ground truth: a diagnostic, never an input."""
    from simcalib.geometry import (invert_transform, matrix_from_rotvec,
                                   rotvec_from_matrix)
    N = {}
    for cam in ("cam_a", "cam_b"):
        if cam not in st.measured or cam not in st.gt:
            return None
        m, g = st.measured[cam], st.gt[cam]
        pos = {int(f): k for k, f in enumerate(np.asarray(g.frame_index))}
        G = np.asarray(g.T_world_cam)[[pos[int(f)] for f in np.asarray(m.frame_index)]]
        E = invert_transform(G) @ np.asarray(m.T_world_cam)
        xi = np.concatenate([rotvec_from_matrix(E[:, :3, :3]), E[:, :3, 3]], axis=1).mean(0)
        T = np.eye(4)
        T[:3, :3] = matrix_from_rotvec(xi[:3])
        T[:3, 3] = xi[3:]
        N[cam] = T
    return invert_transform(N["cam_a"]) @ np.asarray(st.X_true) @ N["cam_b"]


def _chosen(C, H, method="dqopt", lag=0, pose_bias=None, pose_pairs=None,
            pose_error_basis=None):
    """dqopt at alpha = 1, alpha from its residuals, re-solved: (solution, alpha) - what
    a run does (``alpha: auto``; ``pose_pairs`` and ``pose_error_basis`` as a run passes
    them for its headline)."""
    from simcalib.solvers.api import solve
    s1 = solve(C, H, method="dqopt", alpha=1.0)
    a = U.choose_alpha(C, H, s1.X, 1.0).alpha if s1.success else 1.0
    return solve(C, H, method=method, alpha=a, correlation_lag=lag, pose_bias=pose_bias,
                 pose_pairs=pose_pairs, pose_error_basis=pose_error_basis), a


def _coverage_record(sol, X) -> dict | None:
    """One data set's contribution to a coverage row: squared Mahalanobis distance of the
    error (inf unless all six directions are determined), the error, the predicted
    variances, the verdict and the covariance method; None when unavailable."""
    u = sol.uncertainty
    if u is None or X is None:
        return None
    return {"d2": u.mahalanobis2(X) if u.dof == 6 else math.inf,
            "err": U.pose_error(X, sol.X), "pred": np.diag(u.covariance_determined),
            "degenerate": bool(u.degenerate), "simulated": u.method == "pose_simulation"}


def coverage_row(label: str, records: list, trials: int, method: str = "dqopt",
                 level=0.95) -> dict:
    """Coverage of the ``level`` region and pred/RMS per axis over the records of
    :func:`_coverage_record` (None: not solved)."""
    from scipy.stats import chi2
    rec = [r for r in records if r is not None]
    err = np.array([r["err"] for r in rec])
    pred = np.array([r["pred"] for r in rec])
    rms = np.sqrt(np.mean(err**2, axis=0))
    prd = np.sqrt(np.mean(pred, axis=0))
    d2 = np.array([r["d2"] for r in rec])
    return {"label": label, "method": method, "trials": trials, "solved": len(rec),
            "coverage": float(np.mean(d2 <= chi2.ppf(level, 6))), "rms": rms,
            "pred": prd, "ratio": prd / rms,
            "flagged": sum(r["degenerate"] for r in rec) / max(len(rec), 1),
            "simulated": sum(r["simulated"] for r in rec)}


def scenario_coverage(label: str, data: list, method: str = "dqopt", level=0.95,
                      target: str = "truth", calibration: bool = False) -> dict:
    """Coverage of the 95 % region and pred/RMS per axis over the data sets (data-chosen
    alpha, noise from the residuals). ``target="observable"``: the error is measured
    against X without the run-constant pose error of the cameras
    (:func:`_x_without_constant_pose_error`) instead of the true X. ``calibration``: the
    covariance includes the cameras' calibration term (``pose_bias``)."""
    records = []
    for C, H, X_true, lag, X_obs, *rest in data:
        X = X_obs if target == "observable" else X_true
        if X is None:
            continue
        sol, _ = _chosen(C, H, method, lag, rest[0] if calibration and rest else None,
                         rest[1] if len(rest) > 1 else None)
        records.append(_coverage_record(sol, X))
    return coverage_row(label, records, len(data), method, level)


def aruco_trial(seed: int, keep_data: bool = False, overrides=()) -> dict:
    """One seed of ``3d`` with ArUco poses, as a run solves it for its headline (dqopt at the
    data-chosen alpha, ``pose_pairs`` and the systematic pose errors of the marker map and
    the calibrations, :func:`simcalib.pipeline.uncertainty_inputs.pose_error_basis`): coverage
    records against the true X (``run``) and against X without the run-constant pose error
    (``observable``), and of the first-order model with the calibration term instead
    (``first_order``, the model before the systematic simulation). ``keep_data``: also the
    data tuple of :func:`scenario_data` (for the flag and alpha rows). ``overrides``: extra
    ``key=value`` of the run config. Runs in a worker process (module-level, picklable)."""
    from simcalib.pipeline import uncertainty_inputs as P
    from simcalib.pipeline.scenario import load_config
    from simcalib.pipeline.stages import state_through_pairs
    from simcalib.solvers.api import solve
    cfg = load_config("3d", ["recording.enabled=false", "progress=false", "workers=1",
                             f"seed={seed}", *overrides])
    st = state_through_pairs(cfg)
    C, H, X_true = np.asarray(st.pairs.C), np.asarray(st.pairs.H), np.asarray(st.X_true)
    lag, pairs, X_obs = P.correlation_lag(st), P.pose_pairs(st), _x_without_constant_pose_error(st)
    bias = P.calibration_bias(st)[0]
    run, a = _chosen(C, H, "dqopt", lag, bias, pairs, P.pose_error_basis(st))
    first = solve(C, H, alpha=a, correlation_lag=lag, pose_bias=bias, pose_pairs=pairs)
    out = {"run": _coverage_record(run, X_true),
           "observable": _coverage_record(run, X_obs),
           "first_order": _coverage_record(first, X_true)}
    if keep_data:
        out["data"] = (C, H, X_true, lag, X_obs, bias, pairs)
    return out


def aruco_trials(n: int, keep: int, workers: int) -> list:
    """:func:`aruco_trial` for seeds ``0..n-1`` on ``workers`` processes
    (:func:`simcalib.studies.experiments.common.run_tasks`: spawned, one thread per library, each
    renders with one worker), the first ``keep`` with their data."""
    from simcalib.studies.experiments.common import run_tasks
    return run_tasks(aruco_trial, [(s, s < keep) for s in range(n)], workers)


def scenario_flags(label: str, data: list, method: str = "dqopt") -> dict:
    verdicts, errs, beyond = [], [], 0
    for C, H, X, lag, *rest in data:
        sol, _ = _chosen(C, H, method, lag, None, rest[2] if len(rest) > 2 else None)
        verdicts.append(sol.verdict)
        d = U.pose_error(X, sol.X) if sol.success else np.full(6, np.nan)
        errs.append(math.degrees(np.linalg.norm(d[:3])))
        if sol.uncertainty is not None and not sol.degenerate:
            beyond += bool(np.any(np.abs(d) > 5 * np.sqrt(np.diag(sol.covariance))))
    counts = {v: verdicts.count(v) for v in sorted(set(verdicts))}
    return {"label": label, "trials": len(data),
            "flagged": float(np.mean([v != "determined" for v in verdicts])),
            "verdicts": counts, "median_rot_err_deg": float(np.nanmedian(errs)),
            "unflagged_beyond_5sigma": beyond}


def scenario_alpha(label: str, data: list, noise_free=None) -> dict:
    """:func:`alpha_compare` on a scenario's data sets, oracle over ``ALPHA_GRID``;
    ``noise_free``: the same seeds' noise-free motion pairs (``source=ground_truth``), for
    the exactly determined directions."""
    exact = None if noise_free is None else [exact_determined_basis(C, H, X)
                                             for C, H, X, *_ in noise_free]
    return alpha_compare(label, data, ALPHA_GRID, exact)


NOISE_FREE_ALPHAS = (0.01, 1.0, 50.0)


def noise_free_check(label: str, noise_free: tuple) -> dict:
    """dqopt on noise-free motion pairs ``(C, H, X, lag)`` of a scenario
    (``source=ground_truth``) at :data:`NOISE_FREE_ALPHAS`: rotation errors, the largest
    residual of those estimates and the largest error over the exactly determined
    directions (:func:`exact_determined_basis`)."""
    from simcalib.solvers.api import solve_batch
    C, H, X = noise_free[:3]
    basis = exact_determined_basis(C, H, X)
    a = np.array(NOISE_FREE_ALPHAS)
    Xs = solve_batch(np.broadcast_to(C, (a.size,) + C.shape),
                     np.broadcast_to(H, (a.size,) + H.shape), alpha=a).X
    res = max(float(np.abs(U.linear_model(C, H, Xa)[0]).max()) for Xa in Xs)
    d = U.pose_error(X, Xs)
    return {"label": label, "dof": int(basis.shape[1]),
            "rot_deg": np.degrees(np.linalg.norm(d[:, :3], axis=1)), "max_residual": res,
            "det_rot_deg": float(np.max(determined_error(X, Xs, basis)[0]))}


def car_case(label: str, data: list) -> list:
    """Per data set: dqopt's verdict, the flagged translation direction closest to the
    vertical of camera a's motion plane, its predicted 1-sigma and the actual error
    along it."""
    rows = []
    for i, (C, H, X, lag, *rest) in enumerate(data):
        sol, a = _chosen(C, H, lag=lag, pose_pairs=rest[2] if len(rest) > 2 else None)
        u = sol.uncertainty
        d = U.pose_error(X, sol.X)
        # normal of camera a's motion plane: the common rotation axis of C
        from simcalib.geometry import rotvec_from_matrix
        rv = rotvec_from_matrix(C[:, :3, :3])
        _, _, Vt = np.linalg.svd(rv.T @ rv)
        nrm = Vt[0]
        cov_v = u.covariance[3:, 3:]
        sig = math.sqrt(nrm @ cov_v @ nrm) if np.isfinite(cov_v).all() else math.inf
        rows.append({"label": label, "seed": i, "verdict": u.verdict, "alpha": a,
                     "sigma_vertical_m": sig, "error_vertical_m": abs(float(d[3:] @ nrm)),
                     "translation_error_m": float(np.linalg.norm(d[3:])),
                     "information_ratio": float(u.information_ratio[0]),
                     "ratio_threshold": float(u.ratio_threshold[0]),
                     "directions": [dd.summary() for dd in u.directions]})
    return rows



def sim_experiments(args) -> tuple[dict, list]:
    """The simulated-scenario part (coverage on 3d, cart flags, car); returns the rendered
    data and the alpha rows of the cart scenarios."""
    sim = {"coverage": [], "flags": [], "car": [], "noise_free": []}
    noisy = scenario_data("3d", ["source=noisy"], range(args.sim_noisy_trials),
                          one_world=True) if args.sim_noisy_trials else []
    if noisy:
        sim["coverage"].append(scenario_coverage("3d / noisy", noisy))
        print(sim["coverage"][-1], flush=True)
    trials = aruco_trials(args.sim_aruco_trials, args.cart_seeds, args.workers) \
        if args.sim_aruco_trials else []
    aruco = [t["data"] for t in trials if "data" in t]
    if trials:
        n = len(trials)
        for label, key in (("3d / aruco", "run"),
                           ("3d / aruco, first-order model with the calibration term",
                            "first_order"),
                           ("3d / aruco vs X without the run-constant pose error",
                            "observable")):
            sim["coverage"].append(coverage_row(label, [t[key] for t in trials], n))
            print(sim["coverage"][-1], flush=True)
    alpha_rows = []
    for name in CART_SCENARIOS:
        data = aruco[:args.cart_seeds] if name == "3d" and len(aruco) >= args.cart_seeds \
            else scenario_data(name, [], range(args.cart_seeds))
        if not data:
            continue
        sim["flags"].append(scenario_flags(name, data))
        print(sim["flags"][-1], flush=True)
        exact = scenario_data(name, ["source=ground_truth"], range(len(data)))
        alpha_rows.append(scenario_alpha(name, data, exact))
        print(alpha_rows[-1], flush=True)
        sim["noise_free"].append(noise_free_check(name, exact[0]))
        print(sim["noise_free"][-1], flush=True)
    for name in ("car", "car-flat"):
        if args.car_seeds:
            sim["car"] += car_case(name, scenario_data(name, [], range(args.car_seeds)))
            print(sim["car"][-2:], flush=True)
    return sim, alpha_rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.coverage",
                                description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=500)
    p.add_argument("--flag-trials", type=int, default=200)
    p.add_argument("--alpha-trials", type=int, default=100)
    p.add_argument("--n", type=int, default=100)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--sim-noisy-trials", type=int, default=500)
    p.add_argument("--sim-aruco-trials", type=int, default=500)
    p.add_argument("--workers", type=int, default=0,
                   help="processes for the ArUco trials (0, default: one per CPU, at most 8)")
    p.add_argument("--cart-seeds", type=int, default=4)
    p.add_argument("--car-seeds", type=int, default=3)
    p.add_argument("--out", default="docs/uncertainty.md")
    args = p.parse_args(argv)
    from simcalib.studies.experiments.common import check_workers
    args.workers = check_workers(args.workers)
    t0 = time.perf_counter()
    cov_rows = []
    for method, alpha, pr in COVERAGE_CASES:
        cov_rows.append(coverage_case(method, alpha, pr, args.trials, args.n, args.seed))
        print(cov_rows[-1], flush=True)
    flag_rows = []
    for motion in ("line", "circle", "random"):
        for a in FLAG_ALPHAS:
            flag_rows.append(flag_case(motion, a, args.flag_trials, args.n, args.seed + 1))
            print(flag_rows[-1], flush=True)
    alpha_rows = [alpha_case(m, args.alpha_trials, args.n, args.seed + 2)
                  for m in ("random", "line", "circle")] if args.alpha_trials > 0 else []
    sim = None
    if args.sim_noisy_trials or args.sim_aruco_trials or args.cart_seeds or args.car_seeds:
        sim, cart_alpha = sim_experiments(args)
        alpha_rows = alpha_rows + cart_alpha
    from simcalib.studies.experiments.coverage_doc import render
    text = render(cov_rows, flag_rows, alpha_rows, args, time.perf_counter() - t0, sim)
    with open(args.out, "w") as fh:
        fh.write(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
