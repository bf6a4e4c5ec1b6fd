"""Advice for recorded pose files: which motions to record next when there is no model of
the scene (``python -m simcalib advise a=PATH b=PATH platform=free|cart``).

The recorded motions come from :func:`simcalib.pipeline.calibrate.calibrate` (read, detect
conventions, align the clocks, reject outliers, solve); the noise is fitted to their
residuals and the choice is the planner's (:func:`simcalib.studies.advise.planner.greedy_chain`,
the same criterion as for a scenario, without systematic errors: nothing about the
user's marker map, calibrations or robot is known). The candidate stops are motions of
sensor a from the last recorded pose (the reference), in sensor a's own frame:

* ``free``: no platform model: a rotation about a uniform axis by 5-90 deg and a move
  uniform in a 30 cm ball (the arm's ``"wide"`` ranges of
  :data:`simcalib.studies.advise.feasibility.RANGES`). Reachability, collisions and whether the
  target stays visible are **not** checked: each stop must be checked on the robot.
* ``cart``: drivable planar motions: a yaw about the plane's normal (estimated from the
  recorded rotations, which must all be about one axis, with translations in the plane)
  of up to +-90 deg and a move up to 1 m in the plane. Obstacles are not checked.

Directions no candidate can determine (a cart cannot determine X's translation along
the plane's normal) are stated with their fix, as for a scenario.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

import simcalib.studies.advise.feasibility as fz
import simcalib.studies.advise.information as info
import simcalib.studies.advise.planner as pl
from simcalib.studies.advise.advice_json import relative_motion
from simcalib.studies.advise.advisor import (StopPlan, check_when_determined,
                                             determined_message, predicted_along_chain,
                                             recorded_information)

__all__ = ["PLATFORMS", "RecordedAdvice", "plane_normal", "motion_candidates",
           "advise_recorded", "recorded_advice_dict"]

PLATFORMS = ("free", "cart")
#: the recorded rotations of a cart must lie within this angle of one axis (RMS, deg)
MAX_AXIS_SPREAD_DEG = 10.0
#: ... and rotate by at least this much in total to define that axis (deg); their
#: translations must stay within MAX_AXIS_SPREAD_DEG of the plane normal to it unless they
#: leave it by less than MIN_OFF_PLANE_M (RMS)
MIN_TOTAL_ROTATION_DEG = 5.0
MIN_OFF_PLANE_M = 0.002


def plane_normal(C) -> np.ndarray:
    """Unit normal ``(3,)`` (sensor-a frame) of the plane a cart moved in: the axis all the
    recorded rotations of sensor a turn about (principal axis of the rotation vectors).
    ValueError when the motions rotate too little to define it, not about one axis, or
    translate out of the plane normal to it."""
    from simcalib.geometry import rotvec_from_matrix
    C = np.asarray(C, dtype=np.float64)
    if C.ndim != 3 or C.shape[1:] != (4, 4) or C.shape[0] == 0:
        raise ValueError(f"C must be (N, 4, 4) with N >= 1; received shape {C.shape}")
    w = rotvec_from_matrix(C[:, :3, :3])
    total = float(np.degrees(np.linalg.norm(w, axis=1).sum()))
    if total < MIN_TOTAL_ROTATION_DEG:
        raise ValueError(f"platform 'cart' needs recorded rotations to find the plane of "
                         f"motion; the recorded motions of sensor a rotate by {total:.3g} deg "
                         f"in total (at least {MIN_TOTAL_ROTATION_DEG:g} needed)")
    lam, U = np.linalg.eigh(w.T @ w)
    n = U[:, -1]
    spread = math.degrees(math.atan(math.sqrt(max(lam[0] + lam[1], 0.0) / lam[-1])))
    if spread > MAX_AXIS_SPREAD_DEG:
        raise ValueError(f"platform 'cart' expects planar motion (every rotation about one "
                         f"axis); the recorded rotations of sensor a spread {spread:.3g} deg "
                         f"RMS around their main axis (at most {MAX_AXIS_SPREAD_DEG:g}); use "
                         f"platform=free")
    n = n if n[np.argmax(np.abs(n))] > 0 else -n
    t = C[:, :3, 3]
    along = float(np.sqrt(np.mean((t @ n) ** 2)))
    across = float(np.sqrt(np.mean(np.sum((t - np.outer(t @ n, n)) ** 2, axis=1))))
    tilt = math.degrees(math.atan2(along, across))
    if along > MIN_OFF_PLANE_M and tilt > MAX_AXIS_SPREAD_DEG:
        raise ValueError(f"platform 'cart' expects planar motion (translations in the plane "
                         f"normal to the rotation axis); the recorded translations of sensor "
                         f"a leave that plane by {tilt:.3g} deg RMS ({1e3 * along:.3g} mm RMS "
                         f"along the axis; at most {MAX_AXIS_SPREAD_DEG:g} deg); use "
                         f"platform=free")
    return n


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def motion_candidates(C, n: int, rng: np.random.Generator, platform: str, *,
                      max_rotation_deg: float | None = None,
                      max_translation_m: float | None = None,
                      min_rotation_deg: float = 5.0) -> np.ndarray:
    """``(n, 4, 4)`` candidate motions of sensor a from the reference (sensor-a frame) for
    ``platform`` (see the module text); ``C`` the recorded motions (the cart's plane)."""
    if platform not in PLATFORMS:
        raise ValueError(f"platform must be one of {list(PLATFORMS)}; received {platform!r}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1; received {n!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    from simcalib.geometry import matrix_from_rotvec
    r_def, t_def = fz.RANGES["wide"]["arm" if platform == "free" else "cart"]
    max_r = r_def if max_rotation_deg is None else float(max_rotation_deg)
    max_t = t_def if max_translation_m is None else float(max_translation_m)
    if platform == "free":
        axis = _unit(rng.standard_normal((n, 3)))
        omega = axis * np.deg2rad(rng.uniform(min(min_rotation_deg, max_r), max_r, n))[:, None]
        dp = _unit(rng.standard_normal((n, 3))) * (max_t * rng.random(n) ** (1 / 3))[:, None]
    else:
        nrm = plane_normal(C)
        e1 = _unit(np.cross(nrm, np.eye(3)[np.argmin(np.abs(nrm))]))
        e2 = np.cross(nrm, e1)
        omega = np.deg2rad(rng.uniform(-max_r, max_r, n))[:, None] * nrm
        phi = rng.uniform(0, 2 * np.pi, n)
        r = max_t * np.sqrt(rng.random(n))
        dp = (r * np.cos(phi))[:, None] * e1 + (r * np.sin(phi))[:, None] * e2
    M = np.zeros((n, 4, 4))
    M[:, :3, :3] = matrix_from_rotvec(omega)
    M[:, :3, 3] = dp
    M[:, 3, 3] = 1.0
    return M


@dataclass(frozen=True)
class RecordedAdvice(StopPlan):
    """A :class:`~simcalib.studies.advise.advisor.StopPlan` for recorded pose files: ``motion_a``
    (n, 4, 4) the candidate motions of sensor a from the reference ``T_ref_a`` (its last
    recorded pose, in file a's frame); ``chosen`` indexes them."""
    platform: str = "free"
    motion_a: np.ndarray | None = None
    T_ref_a: np.ndarray | None = None
    recorded_motions: int = 0
    message: str = ""


def advise_recorded(C, H, X, T_ref_a, k: int = 5, *, platform: str, rng: np.random.Generator,
                    alpha: float = 1.0, n_candidates: int = 1000, tolerance_deg: float = 1.0,
                    tolerance_m: float = 0.01, when_determined: str = "advise", passes: int = 1,
                    **ranges) -> RecordedAdvice:
    """The next ``k`` stops after the recorded motions ``C``, ``H`` (N, 4, 4; the estimate
    ``X``) for ``platform`` (``"free"`` or ``"cart"``); ``T_ref_a`` (4, 4): sensor a's last
    recorded pose, from which the stops start. ``passes``: how many times the recorded
    motions pass over the same poses (``MotionSet.passes``, one set per span): their summed
    information is divided by it, so the poses' noise counts once. ``ranges``:
    ``max_rotation_deg``, ``max_translation_m``, ``min_rotation_deg`` of
    :func:`motion_candidates`."""
    check_when_determined(when_determined)
    T_ref_a = np.asarray(T_ref_a, dtype=np.float64)
    if T_ref_a.shape != (4, 4) or not np.isfinite(T_ref_a).all():
        raise ValueError(f"T_ref_a must be a finite (4, 4) pose; received shape "
                         f"{T_ref_a.shape}")
    t0 = time.perf_counter()
    kw = dict(tolerance_deg=tolerance_deg, tolerance_m=tolerance_m)
    s_r, s_t, F_base, L = recorded_information(C, H, X, alpha, **kw)
    F_base = F_base / max(int(passes), 1)
    M = motion_candidates(C, n_candidates, rng, platform, **ranges)
    Cc, Hc = info.predicted_motions(M, X)
    F_cand = info.motion_information(Cc, Hc, X, s_r, s_t)
    U = info.undeterminable_directions(F_base, F_cand, range_m=L, **kw)
    U = U if U.shape[1] else None
    message, propose = determined_message(F_base, when_determined, **kw)
    feasible = np.full(M.shape[0], propose)
    g, added = pl.greedy_chain(F_base, M, X, s_r, s_t, k, feasible=feasible, undetermined=U,
                               **kw)
    before, after = predicted_along_chain(F_base, added, None, None, L, U, **kw)
    cannot = [info.describe_direction(u, info.PRIOR_KEYS_CALIBRATE)
              for u in (U.T if U is not None else ())]
    return RecordedAdvice(int(k), g.order, before, after, g.max_std_tol, g.criterion,
                          (s_r, s_t), tolerance_deg, tolerance_m, cannot,
                          np.asarray(X, dtype=np.float64), {"total": time.perf_counter() - t0},
                          undetermined=U, platform=platform, motion_a=M, T_ref_a=T_ref_a,
                          recorded_motions=int(np.asarray(C).shape[0]), message=message)


NOT_CHECKED = {
    "free": ("no platform model: reachability, joint limits, collisions and whether the "
             "target stays in view at each stop are not checked; check each stop on the "
             "robot before recording it"),
    "cart": ("drivable planar motions of a holonomic cart: obstacles, the turning radius of "
             "a non-holonomic vehicle and whether the target stays in view are not "
             "checked"),
}


def recorded_advice_dict(adv: RecordedAdvice, source: dict | None = None) -> dict:
    """advice.json for recorded pose files (docs/advice.md, "Advice for your pose files")."""
    from simcalib.geometry import invert_transform
    X, Xi = adv.X, invert_transform(adv.X)
    motions, prev = [], np.eye(4)
    for step, j in enumerate(adv.chosen):
        Mj = adv.motion_a[int(j)]
        rel = invert_transform(prev) @ Mj
        motions.append({
            "step": step + 1,
            "T_frame_a_target": (adv.T_ref_a @ Mj).tolist(),
            "from": "the reference" if step == 0 else f"stop {step}",
            "sensor_motions": {"a": relative_motion(rel), "b": relative_motion(Xi @ rel @ X)},
            "predicted_std_after": info.std_dict(adv.std_after[step]),
            "max_std_tolerance_units_after": info.finite_or_none(adv.max_std_tol[step + 1])})
        prev = Mj
    return {"source": dict(source or {}), "platform": adv.platform, "k": adv.k,
            "criterion": ("greedy along the stop-and-go chain, then exchange passes: "
                          "minimise max + mean of 1/(lambda + 1e-6) of the information in "
                          "tolerance units (no systematic errors: none is modelled for "
                          "recorded files)"),
            "tolerance": {"deg": adv.tolerance_deg, "m": adv.tolerance_m},
            "noise_fitted": {"sigma_r_deg": math.degrees(adv.noise[0]),
                             "sigma_t_m": adv.noise[1]},
            "recorded_motions": adv.recorded_motions,
            "X": adv.X.tolist(),
            "reference": {"T_frame_a": adv.T_ref_a.tolist(),
                          "meaning": "sensor a's last recorded pose T_world_a in file "
                                     "a's world frame (after the conventions detected, see "
                                     "source.conventions)"},
            "predicted_std_before": info.std_dict(adv.std_before),
            "max_std_tolerance_units_before": info.finite_or_none(adv.max_std_tol[0]),
            "message": adv.message, "motions": motions, "cannot_help": adv.cannot_help,
            "not_checked": NOT_CHECKED[adv.platform],
            "candidates": {"drawn": int(adv.motion_a.shape[0])},
            "timing_s": dict(adv.timing_s)}
