"""The solver stage of a run: every configured method (and each ``<method>+prior``) at the
data-chosen alpha, with its covariance, verdict and convergence curve, as
:class:`~simcalib.pipeline.state.SolverResult` entries.

The headline alpha never comes from the ground truth (:func:`choose_run_alpha`); with an
alpha list in the config every alpha is solved too and the one best against the truth is
reported beside the headline as ``oracle``. A failing method is a FAILED entry with its
reason, never an estimate, and never sinks the run.
"""

from __future__ import annotations

import math
import time

import numpy as np

from simcalib.evaluation import estimate_errors
from simcalib.geometry import (matrix_from_rotvec, rotation_error_rad,
                               transform_from_rotation_translation)
from simcalib.pipeline.state import RunState, SolverResult
from simcalib.pipeline.uncertainty_inputs import (calibration_bias, correlation_lag,
                                                  pose_error_basis, pose_pairs)
from simcalib.progress import progress

__all__ = ["choose_run_alpha", "convergence_curve", "convergence_points", "run_prior",
           "stage_solvers"]


def stage_solvers(st: RunState) -> None:
    """Solve the run's motions with every configured method (and each with the prior)."""
    cfg = st.cfg
    if st.kernel_loader is not None:
        t0 = time.perf_counter()
        st.kernel_loader.join()
        st.kernel_loader = None
        st.timing["waited_for_kernels"] = time.perf_counter() - t0
    jobs = [(m, m, False) for m in cfg.solvers]
    prior = prior_info = None
    if cfg.prior.enabled:
        prior, prior_info = run_prior(st)
        jobs += [(f"{m}+prior", m, True) for m in cfg.prior.methods]
    rng_children = st.rngs["solvers"].spawn(len(jobs))
    C, H = st.pairs.C, st.pairs.H
    st.pose_bias, st.sensing["calibration_bias"] = calibration_bias(st)
    st.pose_error_basis = pose_error_basis(st)
    choice = choose_run_alpha(cfg, C, H)
    for (label, method, with_prior), rng in zip(
            progress(jobs, enabled=cfg.progress, desc="solvers", unit="method",
                             position=1), rng_children):
        st.solvers.append(_solve_one(st, label, method, prior if with_prior else None,
                                     prior_info if with_prior else None, C, H, rng, choice))


def run_prior(st: RunState):
    """``(Prior, info)`` of the run (``prior.*``): the given X, or the true X perturbed by
    ``prior.rotation_error_deg`` / ``translation_error_m`` in directions drawn from the
    run's ``prior`` generator; ``info`` is results.json's ``prior``."""
    from simcalib.solvers.api import Prior
    pc = st.cfg.prior
    if pc.translation_m is not None:
        X = transform_from_rotation_translation(
            matrix_from_rotvec(np.deg2rad(np.asarray(pc.rotvec_deg))), np.asarray(
                pc.translation_m))
        origin = "given"
    else:
        rng = st.rngs["prior"]
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        direction = rng.standard_normal(3)
        direction /= np.linalg.norm(direction)
        dR = matrix_from_rotvec(axis * np.deg2rad(pc.rotation_error_deg))
        X = st.X_true.copy()
        X[:3, :3] = X[:3, :3] @ dR
        X[:3, 3] = X[:3, 3] + direction * pc.translation_error_m
        origin = "true X perturbed"
    info = {"X": X.tolist(), "a": pc.a, "b": pc.b, "origin": origin,
            "rotation_error_deg": float(np.rad2deg(rotation_error_rad(X, st.X_true))),
            "translation_error_m": float(np.linalg.norm(X[:3, 3] - st.X_true[:3, 3]))}
    return Prior(X=X, a=pc.a, b=pc.b), info


def choose_run_alpha(cfg, C, H) -> dict:
    """The alpha of a run's headline estimates, never from the ground truth.

    ``alpha: <number>``: that alpha. ``alpha: auto`` or a list: dqopt at alpha = 1, then
    :func:`simcalib.solvers.diagnostics.uncertainty.choose_alpha` (``noise_ratio``) from its
    residuals. Returns ``{"alpha", "how", "source", ...}`` (results.json ``alpha_choice``)."""
    if cfg.alpha != "auto" and not isinstance(cfg.alpha, tuple):
        return {"alpha": float(cfg.alpha), "source": "config", "how": "given in the config"}
    from simcalib.solvers.api import solve
    from simcalib.solvers.diagnostics.uncertainty import choose_alpha
    try:
        sol = solve(C, H, method="dqopt", alpha=1.0)
        if not sol.success or not np.isfinite(sol.X).all():
            raise ValueError(sol.solver_message or "dqopt failed")
        ch = choose_alpha(C, H, sol.X, 1.0, tolerance_deg=cfg.verdict.tolerance_deg,
                          tolerance_m=cfg.verdict.tolerance_m)
    except Exception as exc:  # noqa: BLE001 - fall back, and say so
        return {"alpha": 1.0, "source": "fallback",
                "how": f"alpha = 1: the data-driven choice failed ({type(exc).__name__}: "
                       f"{exc})"}
    return {"alpha": float(ch.alpha), "source": "data", "how": ch.how,
            "initial": "dqopt at alpha = 1", "sigma_r_deg": float(np.degrees(ch.sigma_r_rad)),
            "sigma_t_m": float(ch.sigma_t_m)}


def _failure_reason(sol) -> str | None:
    """Why ``sol`` is not an estimate (``None`` when it is one)."""
    X = np.asarray(sol.X, dtype=np.float64)
    if not sol.success:
        return sol.solver_message or "the solver reported failure"
    if X.shape != (4, 4) or not np.isfinite(X).all():
        return "non-finite X"
    return None


def _failed(label, method, prior_info, reason, sweep=(), choice=None, oracle=None,
            convergence=()) -> SolverResult:
    return SolverResult(label=label, method=method, alpha=None, prior=prior_info, X=None,
                        rotation_error_deg=None, translation_error_m=None,
                        translation_error_determined_m=None, cost=None, runtime_s=None,
                        success=False, degenerate=None, error=reason.splitlines()[0],
                        message=f"{method}: FAILED ({reason.splitlines()[0]})",
                        sweep=tuple(sweep), alpha_choice=choice, oracle=oracle,
                        convergence=tuple(convergence))


def _verdict(sol) -> dict:
    """The headline verdict fields of a :class:`SolverResult` from ``sol.uncertainty``
    (simcalib.solvers.diagnostics.uncertainty): degenerate, the directions in words, the
    flagged translation axes not fixed by a prior (undetermined or poorly determined:
    projected out of ``translation_error_determined_m``),
    covariance, std, predicted RMS errors."""
    u = sol.uncertainty
    if u is None:
        return {"degenerate": None, "verdict": "unknown", "undetermined": (
            "uncertainty unavailable (the residuals of X are not finite)",)}
    from simcalib.report.directions import direction_record
    words, dirs, axes = [], [], []
    for d in u.directions:
        words.append(d.summary())
        dirs.append(direction_record(d))   # its state and sigma decided once, with it
        if d.kind == "translation" and not d.determined_by_prior:
            axes.append(np.asarray(d.translation_dir_a, dtype=np.float64))
    cov = np.asarray(u.covariance, dtype=np.float64)
    std = np.asarray(u.std, dtype=np.float64)
    return {"degenerate": bool(u.degenerate), "verdict": u.verdict,
            "undetermined": tuple(words), "undetermined_directions": tuple(dirs),
            "undetermined_translation_axes": np.array(axes).reshape(-1, 3) if axes else None,
            "covariance": cov, "std_deg": tuple(float(x) for x in std[:3]),
            "std_m": tuple(float(x) for x in std[3:]),
            "sigma_rotation_deg": float(np.degrees(np.sqrt(np.trace(cov[:3, :3])))),
            "sigma_translation_m": float(np.sqrt(np.trace(cov[3:, 3:])))}


def _singular_values(sol):
    try:
        return np.asarray(sol.observability.singular_values, dtype=np.float64)
    except Exception:  # noqa: BLE001 - descriptive only
        return None


def _solve_at(st, method, alpha, prior, rng, C, H, pairs=None):
    """(solution, errors dict) at ``alpha``, or (solution or None, failure reason).
    ``pairs``: the motions' datapoint pairs (:func:`pose_pairs`), for the headline."""
    from simcalib.solvers.api import solve
    cfg = st.cfg
    sol = solve(C, H, method=method, alpha=alpha, prior=prior,
                         rng=np.random.default_rng(rng.bit_generator.seed_seq),
                         tolerance_deg=cfg.verdict.tolerance_deg,
                         tolerance_m=cfg.verdict.tolerance_m,
                         correlation_lag=correlation_lag(st), pose_bias=st.pose_bias,
                         pose_pairs=pairs,
                         pose_error_basis=st.pose_error_basis if pairs is not None else None,
                         pose_simulation=st.pose_simulation if pairs is not None and
                         prior is None else None)
    reason = _failure_reason(sol)
    if pairs is not None and prior is None and st.pose_simulation is None \
            and sol.uncertainty is not None and sol.uncertainty.simulation is not None:
        # one simulation per run: the covariance of the alpha-cost minimiser near X serves
        # every solver's headline (each adds its own offset from the minimiser)
        st.pose_simulation = sol.uncertainty.simulation
    if reason is not None:
        return sol, reason
    v = _verdict(sol)
    axes = v.get("undetermined_translation_axes")
    return sol, estimate_errors(sol.X, st.X_true, axes if v["degenerate"] else None)


def _solve_one(st, label, method, prior, prior_info, C, H, rng, choice) -> SolverResult:
    """The headline estimate at the data-chosen alpha (``choice``); with an alpha list in
    the config every alpha is solved too (``sweep``) and the one best against the ground
    truth is reported as ``oracle`` (it never replaces the headline)."""
    sweep = []
    oracle = None
    try:
        if isinstance(st.cfg.alpha, tuple):
            oracle = _alpha_sweep(st, method, prior, rng, C, H, sweep)
        sol, res = _solve_at(st, method, choice["alpha"], prior, rng, C, H, pose_pairs(st))
        convergence = convergence_curve(st, method, choice["alpha"], prior, rng, C, H,
                                        last=(sol, res))
    except Exception as exc:  # noqa: BLE001 - one failing method must not sink the run
        return _failed(label, method, prior_info, f"{type(exc).__name__}: {exc}",
                       sweep, choice, oracle)
    if isinstance(res, str):
        return _failed(label, method, prior_info, res, sweep, choice, oracle, convergence)
    return _estimate(label, method, prior_info, sol, res, sweep, choice, oracle, convergence)


def _alpha_sweep(st, method, prior, rng, C, H, sweep: list) -> dict | None:
    """Solve at every alpha of the config's list, appending each entry to ``sweep`` (as it
    goes: a later failure keeps the entries before it); the ``oracle`` entry — the alpha
    best against the GROUND TRUTH — or None when every alpha failed."""
    best = None
    for alpha in st.cfg.alphas:
        sol_a, res = _solve_at(st, method, alpha, prior, rng, C, H)
        if isinstance(res, str):
            sweep.append({"alpha": float(alpha), "rotation_error_deg": None,
                          "translation_error_m": None,
                          "translation_error_determined_m": None, "cost": None,
                          "runtime_s": float(sol_a.runtime_s), "success": False,
                          "error": res})
            continue
        sweep.append({"alpha": float(alpha), **res, "cost": float(sol_a.cost),
                      "runtime_s": float(sol_a.runtime_s), "success": True,
                      "error": None, "verdict": sol_a.verdict})
        if best is None or res["rotation_error_deg"] < best["rotation_error_deg"]:
            best = {"alpha": float(alpha), **res}
    if best is None:
        return None
    return {"uses_ground_truth": True,
            "note": "the alpha of the config list with the lowest rotation "
                    "error against the GROUND TRUTH (not available with real "
                    "data; the headline uses the data-chosen alpha)",
            "oracle_alpha": best["alpha"],
            "rotation_error_deg": best["rotation_error_deg"],
            "translation_error_m": best["translation_error_m"],
            "translation_error_determined_m": best["translation_error_determined_m"]}


def _estimate(label, method, prior_info, sol, res, sweep, choice, oracle,
              convergence) -> SolverResult:
    """The :class:`SolverResult` of a successful headline solve ``sol`` (errors ``res``)."""
    v = _verdict(sol)
    try:
        message = sol.message
    except Exception as exc:  # noqa: BLE001 - a broken diagnostic must not kill the run
        message = f"{sol.solver_message} (message unavailable: {exc})"
    degenerate = v["degenerate"]
    return SolverResult(
        label=label, method=method, alpha=float(sol.alpha), prior=prior_info,
        X=np.asarray(sol.X, dtype=np.float64), rotation_error_deg=res["rotation_error_deg"],
        translation_error_m=res["translation_error_m"],
        translation_error_determined_m=res["translation_error_determined_m"],
        cost=float(sol.cost), runtime_s=float(sol.runtime_s), success=True,
        degenerate=degenerate, undetermined=v["undetermined"] if degenerate is not False
        else (), undetermined_directions=v.get("undetermined_directions", ()),
        undetermined_translation_axes=v.get("undetermined_translation_axes"),
        singular_values=_singular_values(sol), message=message, sweep=tuple(sweep),
        covariance=v.get("covariance"), std_deg=v.get("std_deg"), std_m=v.get("std_m"),
        sigma_rotation_deg=v.get("sigma_rotation_deg"),
        sigma_translation_m=v.get("sigma_translation_m"), verdict=v["verdict"],
        verdict_directions=v["undetermined"] if degenerate is not False else (),
        alpha_choice=choice, oracle=oracle, convergence=tuple(convergence),
        covariance_calibration=None if sol.uncertainty is None
        else sol.uncertainty.bias_covariance, uncertainty_model=_uncertainty_model(sol))


def _uncertainty_model(sol) -> dict | None:
    """results.json ``uncertainty_model``: the covariance's method ("sandwich" or
    "pose_simulation"), the white pose-noise test of motions sharing poses, the simulated
    bias (deg, m)."""
    u = sol.uncertainty
    if u is None:
        return None
    t = u.pose_noise_test
    b = u.simulated_bias_determined          # null along the undetermined axes
    wn = u.white_pose_noise
    return {"method": u.method,
            "systematic_parameters": int(u.systematic_parameters),
            "white_pose_noise": None if wn is None else {
                "sigma_r_deg": math.degrees(wn[0]), "sigma_t_m": float(wn[1])},
            "pose_noise_test": None if t is None else t.to_dict(digits=4),
            "simulated_bias_deg": None if b is None else [
                float(x) if np.isfinite(x) else None for x in np.degrees(b[:3])],
            "simulated_bias_m": None if b is None else [
                float(x) if np.isfinite(x) else None for x in b[3:]]}


def convergence_points(n: int, points: int, k_min: int = 3) -> tuple[int, ...]:
    """Up to ``points`` log-spaced motion counts from ``k_min`` to ``n`` (distinct, with n)."""
    if points <= 0 or n < k_min:
        return ()
    ks = np.unique(np.round(np.geomspace(k_min, n, points)).astype(int))
    return tuple(int(k) for k in ks)


def convergence_curve(st, method, alpha, prior, rng, C, H, last=None) -> tuple[dict, ...]:
    """Solve on the first k motions for growing k (``verdict.convergence_points`` log-spaced
    values): per k the errors against the ground truth, the predicted 1-sigma (RMS of the
    rotation / translation error; None when undetermined) and the verdict. The curve a user
    looks at to see when the motion became rich enough. ``last``: the headline's
    ``(solution, errors)``, used for k = all motions (the points before it use the
    first-order uncertainty; only the headline runs the pose-noise simulation)."""
    out = []
    for k in convergence_points(C.shape[0], st.cfg.verdict.convergence_points):
        try:
            if last is not None and k == C.shape[0]:
                sol, res = last
            else:
                sol, res = _solve_at(st, method, alpha, prior, rng, C[:k], H[:k])
        except ValueError as exc:   # too few usable motions for this method
            out.append({"k": k, "success": False, "error": str(exc).splitlines()[0]})
            continue
        if isinstance(res, str):
            out.append({"k": k, "success": False, "error": res.splitlines()[0]})
            continue
        v = _verdict(sol)
        out.append({"k": k, "success": True, "rotation_error_deg": res["rotation_error_deg"],
                    "translation_error_m": res["translation_error_m"],
                    "sigma_rotation_deg": v.get("sigma_rotation_deg"),
                    "sigma_translation_m": v.get("sigma_translation_m"),
                    "verdict": v["verdict"]})
    return tuple(out)
