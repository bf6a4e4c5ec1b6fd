"""advice.json of a scenario's advice (docs/advice.md, "Outputs"): the proposed stops —
each as the motion from the previous stop (the first from the reference, the recorded
run's last pose) and as an absolute target — their predicted 1-sigma, what the advice
cannot help, and the verification and floor when they were run."""

from __future__ import annotations

import math

import numpy as np

from simcalib.geometry import invert_transform, rotvec_from_matrix
from simcalib.studies.advise.advisor import expected_gain
from simcalib.studies.advise.information import finite_or_none, std_dict

__all__ = ["advice_dict", "relative_motion"]


def relative_motion(T) -> dict:
    """A relative motion ``T`` (4, 4) as ``rotvec_deg``, ``angle_deg``, ``translation_m``."""
    rv = rotvec_from_matrix(T[:3, :3])
    return {"rotvec_deg": np.degrees(rv).tolist(),
            "angle_deg": float(np.degrees(np.linalg.norm(rv))),
            "translation_m": T[:3, 3].tolist()}


def _joint_names(model) -> list:
    import mujoco
    names = [""] * model.nq
    for j in range(model.njnt):
        a = int(model.jnt_qposadr[j])
        if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                      int(mujoco.mjtJoint.mjJNT_SLIDE)):
            names[a] = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"q{a}"
    return names


def _previous_inv(cand, c, chosen, step):
    """Inverse of camera c's motion from the reference to the previous stop (stop and go:
    each advised motion starts at the previous stop, the first at the reference)."""
    return np.eye(4) if step == 0 else invert_transform(cand.motion[c][int(chosen[step - 1])])


def _target_motion(cand, chosen, step) -> dict:
    """The target frame's (flange / cart base) motion from the previous stop in world
    axes: ``rotvec_world_deg``, ``angle_deg``, ``translation_world_m``."""
    prev = (cand.ref["T_world_target"] if step == 0
            else cand.T_world_target[int(chosen[step - 1])])
    T = cand.T_world_target[int(chosen[step])]
    rv = rotvec_from_matrix(T[:3, :3] @ prev[:3, :3].T)
    return {"rotvec_world_deg": np.degrees(rv).tolist(),
            "angle_deg": float(np.degrees(np.linalg.norm(rv))),
            "translation_world_m": (T[:3, 3] - prev[:3, 3]).tolist()}


def _motion(cand, adv, names, step) -> dict:
    """The advice.json entry of the ``step``-th advised stop."""
    j = int(adv.chosen[step])
    m = {"step": step + 1, "candidate": j,
         "from": "the reference stop" if step == 0 else f"stop {step}",
         "waypoint": {"T_world_target": cand.T_world_target[j].tolist(),
                      "dp_world_m": cand.dp_world_m[j].tolist(),
                      "rotvec_world_deg": np.degrees(cand.rotvec_world_rad[j]).tolist()},
         "target_motion": _target_motion(cand, adv.chosen, step),
         "camera_motions": {c: relative_motion(_previous_inv(cand, c, adv.chosen, step)
                                               @ cand.motion[c][j]) for c in cand.motion},
         "predicted_std_after": std_dict(adv.std_after[step]),
         "max_std_tolerance_units_after": finite_or_none(adv.max_std_tol[step + 1])}
    if cand.platform == "arm":
        m["joint_targets_rad"] = {n: float(cand.qpos[j, a]) for a, n in enumerate(names) if n}
        m["ik_error"] = {"position_m": float(cand.ik_pos_error_m[j]),
                         "rotation_rad": float(cand.ik_rot_error_rad[j])}
    else:
        m["cart_pose"] = {"position_m": cand.mocap_pos[j, 0].tolist(),
                          "yaw_deg": float(np.degrees(cand.rotvec_world_rad[j, 2]))}
    m["visible_markers"] = {c: int(v[j]) for c, v in cand.visible.items()}
    m["rendered_markers"] = {c: v[step] for c, v in adv.render_check.items()
                             if step < len(v)}
    return m


def _criterion_text(adv) -> str:
    if adv.systematic_parameters:
        return ("greedy along the stop-and-go chain, then exchange passes: minimise max + "
                "mean eigenvalue of the covariance in tolerance units, (F + 1e-6 I)^-1 + "
                "(F + 1e-6 I)^-1 G G^T (F + 1e-6 I)^-1 with the systematic pose errors' "
                "score G (marker map, calibrations, the arm's DH table)")
    return ("greedy along the stop-and-go chain, then exchange passes: minimise max + mean "
            "of 1/(lambda + 1e-6) of the information in tolerance units (lambda_min = "
            "1/largest sigma^2)")


def _candidate_counts(cand, adv) -> dict:
    """Candidates drawn, feasible and rejected, by reason."""
    reasons: dict = {}
    for r in cand.reason:
        key = r.split(" (")[0] if r else "feasible"
        key = "cam sees too few markers" if "markers" in key else key
        reasons[key] = reasons.get(key, 0) + 1
    return {"drawn": cand.n, "feasible": int(cand.feasible.sum()), "by_reason": reasons,
            "rejected_by_render_check": list(adv.rejected_by_render)}


def advice_dict(base, adv, ver=None, floor: dict | None = None) -> dict:
    """advice.json (see docs/advice.md) of the advice ``adv`` after the recorded run
    ``base``; ``ver``: its verification, if any; ``floor``: :func:`bounds.choice_floor`'s
    result, if any."""
    cand = adv.candidates
    names = _joint_names(base.truth.world.model) if cand.platform == "arm" else []
    criterion = _criterion_text(adv)
    if adv.cannot_help:
        criterion += (" — on the directions the platform can determine (those of "
                      "cannot_help left out)")
    out = {"scenario": base.cfg.scenario, "platform": cand.platform,
           "path": base.cfg.world.path, "seed": base.cfg.seed, "k": adv.k,
           "criterion": criterion,
           "systematic_parameters": int(adv.systematic_parameters),
           "limited_by": adv.limited_by, "expected_gain": expected_gain(adv),
           "tolerance": {"deg": adv.tolerance_deg, "m": adv.tolerance_m},
           "noise_fitted": {"sigma_r_deg": math.degrees(adv.noise[0]),
                            "sigma_t_m": adv.noise[1]},
           "recorded_motions": int(base.C.shape[0]),
           "reference": {"frame": int(cand.ref["frame"]),
                         "T_world_target": cand.ref["T_world_target"].tolist(),
                         **({"joints_rad": {n: float(cand.ref["qpos"][a])
                                            for a, n in enumerate(names) if n}}
                            if names else {})},
           "predicted_std_before": std_dict(adv.std_before),
           "max_std_tolerance_units_before": finite_or_none(adv.max_std_tol[0]),
           "message": adv.message,
           "motions": [_motion(cand, adv, names, s) for s in range(len(adv.chosen))],
           "cannot_help": adv.cannot_help,
           "candidates": _candidate_counts(cand, adv),
           "timing_s": dict(adv.timing_s)}
    if floor:
        out["choice_floor"] = floor
    if ver is not None:
        out["verification"] = _verification_dict(ver)
    return out


def _verification_dict(ver) -> dict:
    """advice.json ``verification`` of a :class:`verification.Verification`."""
    out = {"baseline": ver.baseline, "advised": ver.advised, "random": ver.random,
           "random_median": ver.random_median, "ratio_advised_to_random_median": ver.ratio,
           "random_joint": ver.random_joint, "random_joint_median": ver.random_joint_median,
           "ratio_advised_to_random_joint_median": ver.ratio_joint,
           "motion_size": ver.motion_size, "advised_seeds": ver.advised_seeds,
           "advised_median": ver.advised_median, "random_wide": ver.random_wide,
           "random_wide_median": ver.random_wide_median,
           "ratio_advised_to_random_wide_median": ver.ratio_wide,
           "frames_per_stop": ver.frames_per_stop, "timing_s": ver.timing_s}
    if ver.hindsight:
        out["hindsight"] = ver.hindsight
        out["ratio_hindsight_to_random_median"] = ver.ratio_hindsight
    return out
