"""What a set of stops gives, measured: dqopt's errors against the true X with the stops
added (:func:`solve_errors`), their medians and ratios over seeds
(:func:`median_summary`), and the size of the stop-to-stop motions.

A platform that cannot determine some direction of X (``cannot_help``: e.g. the vertical
translation for a SCARA or a cart, which rotate about the vertical only) leaves dqopt's
estimate along it to the noise, whatever the stops: the errors are measured on the other
directions — the translation error with those directions projected out
(:func:`simcalib.evaluation.estimate_errors`), the largest 1-sigma over the other axes —
and the full translation error is kept beside it (``translation_error_total_cm``)."""

from __future__ import annotations

import numpy as np

from simcalib.studies.advise.information import (finite_or_none, largest_std, std_dict)

__all__ = ["solve_errors", "errors_against", "undetermined_translations", "median_summary",
           "motion_size", "median_size", "ERROR_KEYS"]

#: the errors of a solve that :func:`median_summary` gives medians of
ERROR_KEYS = ("rotation_error_deg", "translation_error_cm", "max_std_deg", "max_std_cm")


def undetermined_translations(cannot_help) -> np.ndarray:
    """``(k, 3)``: the translation directions (camera-a frame) of the ``cannot_help``
    statements that have one (:func:`simcalib.studies.advise.information.
    describe_direction`)."""
    dirs = [h["translation_dir_a"] for h in cannot_help
            if np.any(np.asarray(h.get("translation_dir_a", ())) != 0)]
    return np.asarray(dirs, dtype=np.float64).reshape(-1, 3)


def errors_against(X, X_true, undetermined=None) -> dict:
    """``rotation_error_deg`` and ``translation_error_cm`` of the estimate ``X`` against
    ``X_true``; with ``undetermined`` translation directions ``(k, 3)`` (camera-a frame,
    k >= 1) the translation error along the others and ``translation_error_total_cm``."""
    from simcalib.evaluation import estimate_errors
    U = None if undetermined is None or not np.size(undetermined) else undetermined
    e = estimate_errors(X, X_true, U)
    out = {"rotation_error_deg": e["rotation_error_deg"],
           "translation_error_cm": 100.0 * e["translation_error_determined_m"]}
    if U is not None:
        out["translation_error_total_cm"] = 100.0 * e["translation_error_m"]
    return out


def solve_errors(C, H, X_true, alpha, *, tolerance_deg=1.0, tolerance_m=0.01,
                 pose_pairs=None, pose_error_basis=None, cannot_help=()) -> dict:
    """dqopt on ``C``, ``H``: actual errors against ``X_true`` (:func:`errors_against`, the
    ``cannot_help`` directions left out) and the predicted 1-sigma (with ``pose_pairs`` /
    ``pose_error_basis``: the systematic pose errors included, as in a run; ``max_std_*``
    over the axes the ``cannot_help`` directions leave)."""
    from simcalib.solvers.api import solve
    from simcalib.studies.advise.systematic import cannot_help_axes
    sol = solve(C, H, method="dqopt", alpha=alpha, tolerance_deg=tolerance_deg,
                tolerance_m=tolerance_m, pose_pairs=pose_pairs,
                pose_error_basis=pose_error_basis)
    X = np.asarray(sol.X, dtype=np.float64)
    if not sol.success or not np.isfinite(X).all():
        return {"success": False, "error": sol.solver_message, "n_motions": int(C.shape[0])}
    err = errors_against(X, X_true, undetermined_translations(cannot_help))
    try:
        std = np.asarray(sol.std, dtype=np.float64)
        verdict = sol.verdict
    except Exception as exc:  # noqa: BLE001 - report, never pretend
        std, verdict = np.full(6, np.nan), f"unavailable: {exc}"
    deg, cm = largest_std(std, cannot_help_axes(cannot_help))
    return {"success": True, "n_motions": int(C.shape[0]), **err,
            "predicted_std": std_dict(std), "verdict": verdict,
            "max_std_deg": finite_or_none(deg), "max_std_cm": finite_or_none(cm)}


def median_summary(res_adv, res_rand) -> tuple[dict, dict]:
    """``(medians, ratios)``: the medians of :data:`ERROR_KEYS` over the successful results
    ``res_rand`` (a failed key counts as inf) and the ratios of ``res_adv``'s errors to
    them."""
    med = {}
    for key in ERROR_KEYS:
        vals = [np.inf if r.get(key) is None else r[key] for r in res_rand
                if r.get("success")]
        med[key] = finite_or_none(np.median(vals)) if vals else None
    ratio = {}
    for key in ("rotation_error_deg", "translation_error_cm"):
        a, m = res_adv.get(key), med.get(key)
        ratio[key] = None if a is None or not m else float(a / m)
    return med, ratio


def motion_size(cand, idx) -> dict:
    """Median rotation (deg) and translation (cm) of camera a's stop-to-stop motions."""
    from simcalib.geometry import invert_transform, rotvec_from_matrix
    idx = np.asarray(idx, dtype=np.int64)
    if idx.size == 0:
        return {"rotation_deg": None, "translation_cm": None}
    T = np.concatenate([np.eye(4)[None], cand.motion["cam_a"][idx]])
    D = invert_transform(T[:-1]) @ T[1:]
    ang = np.degrees(np.linalg.norm(rotvec_from_matrix(D[:, :3, :3]), axis=1))
    return {"rotation_deg": float(np.median(ang)),
            "translation_cm": float(100 * np.median(np.linalg.norm(D[:, :3, 3], axis=1)))}


def median_size(sizes) -> dict:
    """The median of several :func:`motion_size` results (None without any)."""
    sizes = [s for s in sizes if s and s.get("rotation_deg") is not None]
    if not sizes:
        return {"rotation_deg": None, "translation_cm": None}
    return {k: float(np.median([s[k] for s in sizes]))
            for k in ("rotation_deg", "translation_cm")}
