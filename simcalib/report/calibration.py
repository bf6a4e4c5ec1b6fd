"""``calibration.json`` and the console report of a calibration of recorded poses
(:func:`simcalib.pipeline.calibrate.calibrate`): :func:`report_dict` (schema :data:`SCHEMA`,
docs/calibrate.md) and :func:`format_report`, which renders the same content for people.
"""

from __future__ import annotations

import math

import numpy as np

from simcalib.errors import EXIT_DEGENERATE, EXIT_OK

__all__ = ["SCHEMA", "report_dict", "format_report", "other_readings_lines", "sigma_line",
           "verdict_line"]

SCHEMA = "simcalib.calibration/1"


def _fin(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _pose(X) -> dict:
    from simcalib.geometry import quat_from_matrix, rotvec_from_matrix
    X = np.asarray(X, dtype=np.float64)
    return {"T_a_b": X.tolist(), "translation_m": X[:3, 3].tolist(),
            "quaternion_xyzw": quat_from_matrix(X[:3, :3]).tolist(),
            "rotvec_deg": np.degrees(rotvec_from_matrix(X[:3, :3])).tolist()}


def _stream(s) -> dict:
    return {"file": s.source, "name": s.name, "format": s.format, "detection": s.detection,
            "poses": s.n, "duration_s": s.duration_s, "rate_hz": _fin(s.rate_hz),
            "quaternion_order_in_file": s.quat_order, "inverted": s.inverted,
            "quaternion_order_swapped": s.scalar_first_reinterpreted,
            "sample_index_as_time": s.synthetic_time, "repairs": dict(s.repairs)}


#: what no sigma from the data can hold (docs/calibrate-coverage.md, robot_error)
NOT_IN_SIGMA = ("an error common to every pose (a robot's absolute accuracy, a target's "
                "scale) moves X without a residual: no recording shows it")


def _uncertainty(a, common=None) -> dict:
    """``common``: the stated :class:`simcalib.estimation.common_error.CommonError` that the
    covariance includes (None: none stated)."""
    return {"source": a.source, "std_rotation_deg": a.std_rot_deg,
            "std_translation_m": a.std_trans_m,
            # why an axis' 1-sigma is null (not a number), else null
            "std_reason": _std_reason(a), "covariance": a.covariance,
            "covariance_order": "(wx, wy, wz, vx, vy, vz), rad and m, frame a",
            "common_error_included": None if common is None else common.to_dict(),
            "not_included": NOT_IN_SIGMA if common is None else (
                "an error common to every pose beyond the stated common_error.*")}


def _verdict(a) -> dict:
    return {"verdict": a.verdict, "degenerate": a.degenerate,
            "directions": list(a.undetermined),
            # each flagged direction: kind, axes, state and sigma (the words above)
            "direction_details": [dict(d) for d in a.direction_records], "message": a.summary}


def report_dict(opts, r, a, solver_kernels: str = "compiled") -> dict:
    """The content of ``calibration.json`` (schema :data:`SCHEMA`, docs/calibrate.md) of the
    calibration ``r`` (:class:`simcalib.estimation.path.StreamCalibration`) with options
    ``opts`` and assessment ``a`` (:class:`simcalib.pipeline.calibrate.Assessment`)."""
    from simcalib.config.engine import to_dict
    rob, s = r.robust, r.summary
    status = {EXIT_OK: "determined", EXIT_DEGENERATE: "degenerate"}.get(a.exit_code,
                                                                        "failed")
    if a.implausible and not a.degenerate and a.verdict != "FAILED":
        status = "implausible"
    return {
        "schema": SCHEMA,
        "status": status,
        "solver_kernels": solver_kernels,
        "exit_code": a.exit_code,
        "X": _pose(r.X),
        "frames": "X = T_a_b: pose of sensor b in sensor a (p_a = X p_b); metres, "
                  "quaternion (x, y, z, w)",
        "uncertainty": _uncertainty(a, getattr(r, "common_error", None)),
        "verdict": _verdict(a),
        "time_offset": _time_offset(r.time_offset),
        "scale_b": None if getattr(r, "scale", None) is None else r.scale.to_dict(),
        "sampling": r.sampling.to_dict(),
        "motions": {"policy": r.motions.policy, "reason": r.motions.reason,
                    "counts": dict(r.motions.counts)},
        "consistency": None if r.consistency is None else r.consistency.to_dict(),
        "weighting_check": None if r.weighting is None else r.weighting.to_dict(),
        "inliers": {"robust": rob.method, "n_motions": int(r.C.shape[0]),
                    "choice": r.robust_choice,
                    "n_inliers": rob.n_inliers, "threshold": _fin(rob.threshold),
                    "message": rob.message},
        "residuals": {"inliers": s["residuals_inliers"], "all": s["residuals_all"],
                      "definition": "per-motion errors of C X = X H (rotation angle, "
                                    "translation norm)"},
        "conventions": _conventions(r.conventions),
        "streams": {"a": _stream(r.stream_a), "b": _stream(r.stream_b),
                    "synchronised": dict(r.synced.counts), "reference": r.synced.reference},
        "plain": None if r.X_plain is None else {
            "description": "dqopt, offset 0, all motions, no rejection",
            "X": _pose(r.X_plain), "n_motions": s["n_motions_plain"],
            "residuals": s["residuals_plain"]},
        "aligned_no_rejection": {"description": "dqopt, offset as above, all "
                                 "motions, no rejection", "X": _pose(r.X_aligned),
                                 "residuals": s["residuals_aligned"]},
        "solution": rob.solution.to_dict() if rob.solution is not None else None,
        "options": to_dict(opts),
        "plausibility": None if a.plausibility is None else a.plausibility.to_dict(),
        "warnings": list(a.warnings),
        "mount_change": s.get("mount_change"),
        "files": {"motions": "motions.npz",
                  "recording": "recording.rrd" if opts.recording else None},
    }


def _time_offset(off) -> dict:
    """calibration.json ``time_offset`` (:class:`simcalib.estimation.alignment.TimeOffset`)."""
    return {"offset_s": off.offset_s, "uncertainty_s": _fin(off.uncertainty_s),
            "estimated": off.decision == "estimated",
            "decision": off.decision, "evidence": _fin(off.evidence),
            "peak_z": _fin(off.peak_z),
            "window_s": [_fin(x) for x in off.window_s],
            "coarse_offset_s": off.coarse_offset_s,
            "peak_correlation": _fin(off.peak_correlation),
            "drift": off.drift, "drift_sigma": off.drift_sigma, "t_ref_s": off.t_ref_s,
            "steps": [st.to_dict() for st in getattr(off, "steps", ())],
            "signal": off.signal if off.decision not in ("given", "shared_stamps") else None,
            "convention": "offset_s = t_b - t_a for the same instant",
            "message": off.message}


def _conventions(conv) -> dict:
    """calibration.json ``conventions``: the reading used and how clearly it won."""
    return {"invert_a": conv.invert_a, "invert_b": conv.invert_b,
            "swap_scalar_a": conv.swap_scalar_a,
            "swap_scalar_b": conv.swap_scalar_b, "ratio": _fin(conv.ratio),
            "clear": conv.clear, "runner_up": conv.runner_up,
            "scores": conv.scores, "forced": list(conv.forced),
            "mirror_b": conv.mirror_b, "mirror_ratio": _fin(conv.mirror_ratio),
            "mirror_told": conv.mirror_told,
            "mirror_T_a_b": None if conv.mirror_X is None else np.asarray(conv.mirror_X).tolist(),
            "message": conv.message}


def _std_reason(a) -> str | None:
    from simcalib.report.directions import REASON_AXIS_INFINITE
    std = list(a.std_rot_deg or ()) + list(a.std_trans_m or ())
    return REASON_AXIS_INFINITE if any(x is None for x in std) and std else None


def sigma_line(u: dict) -> str:
    """The 1-sigma per axis of calibration.json's ``uncertainty`` in words: every report
    of a calibration (console, the recording's summary) says it so; an axis with no
    finite 1-sigma is :data:`~simcalib.report.directions.NOT_MEASURED`."""
    from simcalib.report.directions import NOT_MEASURED, axis_sigmas
    if not u.get("std_rotation_deg"):
        return "uncertainty (1 sigma, frame a): not available"
    rot = ", ".join(axis_sigmas(u["std_rotation_deg"], 1.0, 4))
    tr = ", ".join(axis_sigmas(u["std_translation_m"], 1e3, 2))
    return (f"uncertainty (1 sigma, frame a): rotation [{rot}] deg, translation [{tr}] mm"
            + (f" ({NOT_MEASURED}: {u['std_reason']})" if u.get("std_reason") else ""))


def verdict_line(v: dict, bold: bool = False) -> str:
    """``verdict: WORD - <each flagged direction: state (sigma)>; <notes>`` (``bold``: the
    words up to the verdict in markdown bold)."""
    head = f"verdict: {v['verdict'].upper()}"
    return (f"**{head}**" if bold else head) + (f" - {v['message']}" if v["message"] else "")


def _scale_lines(sc: dict | None) -> list[str]:
    """The console's line on the scale of b's translations (calibration.json ``scale_b``)."""
    if sc is None:
        return []
    head = {"rescaled": "RESCALED", "given": "given", "kept": "1 (kept)",
            "not_told": "1 (not told)"}[sc["decision"]]
    line = f"scale of b's translations: {head} - {sc['message']}"
    chk = sc.get("check_after_rescale")
    if chk and chk.get("scale") is not None:
        line += (f" (the data as rescaled read {chk['scale']:.4g}"
                 + (f" +- {chk['sigma']:.2g})" if chk.get("sigma") is not None else ")"))
    return [line]


def _vec(v, scale=1.0, digits=3):
    if v is None:
        return "n/a"
    return "[" + ", ".join("inf" if x is None else f"{scale * x:.{digits}f}" for x in v) + "]"


def _offset_line(off: dict, sampling: dict) -> str:
    """``time offset t_b - t_a: ...`` in ms, or in samples for sample-number stamps of a
    continuous motion (``motion_step``: their unit is not known); ``+- sigma`` wherever the
    offset used has a 1-sigma (estimated, or 0 used where the data do not tell one: the
    sigma X's covariance carries); how it was decided; the drift where one was fitted."""
    sig = off["uncertainty_s"]
    if sampling.get("motion_step"):
        head = (f"time offset t_b - t_a: {off['offset_s']:.3f}"
                + (f" +- {sig:.2g} samples" if sig else " samples"))
    else:
        head = (f"time offset t_b - t_a: {1e3 * off['offset_s']:.2f}"
                + (f" +- {1e3 * sig:.2f} ms" if sig else " ms"))
    drift = (f", drift {off['drift'] * 1e6:.1f}" + (
        f" +- {off['drift_sigma'] * 1e6:.1f}" if off.get("drift_sigma") else "") + " ppm"
             if off["drift"] else "")
    return head + {"estimated": " (estimated)", "zero": " (not told by the data: 0 used)",
                   "given": " (given)", "shared_stamps": " (paired by stamp)"}[
                       off["decision"]] + drift


def other_readings_lines(rep: dict) -> list[str]:
    """The console lines giving the X of readings the data fit as well: both streams
    inverted (``plausibility.twin_T_a_b``) and b mirrored where the handedness is not told
    (``conventions.mirror_T_a_b``)."""
    plaus = rep.get("plausibility") or {}
    readings = (
        (plaus.get("twin_T_a_b"), "both streams inverted", "this X's T_world_a_world_b",
         f"both files hold the inverse of the poses as read ({plaus.get('twin_hint')})"),
        ((rep.get("conventions") or {}).get("mirror_T_a_b"), "b mirrored (z negated)",
         "T_a_b' with b' = b's frame with its z axis negated",
         "b's file is left-handed (mirror_b=true)"))
    lines = []
    for T, read, frame, when in readings:
        if T is not None:
            alt = _pose(T)
            lines.append(f"  read with {read}, the same data give X: t = "
                         f"{_vec(alt['translation_m'], 1e3, 2)} mm, rotvec "
                         f"{_vec(alt['rotvec_deg'], digits=3)} deg ({frame}): that is X if "
                         f"{when}")
    return lines


def _step_line(st: dict) -> str:
    """The console's line on one clock step (calibration.json ``time_offset.steps``)."""
    return (f"CLOCK STEP of b: {st['size_s'] * 1e3:+.1f} +- {st['size_sigma_s'] * 1e3:.1f} ms"
            f" at b's t = {st['at_b_s']:.3f} s (a's {st['at_a_s']:.3f} s): offset "
            f"{st['offset_before_s'] * 1e3:.1f} +- {st['sigma_before_s'] * 1e3:.1f} ms "
            f"before, {st['offset_after_s'] * 1e3:.1f} +- {st['sigma_after_s'] * 1e3:.1f} ms"
            f" after (a clock step, not a drift); b's {st['b_rows_shifted']} stamps from it "
            f"shifted by {-st['size_s'] * 1e3:+.1f} ms")


def format_report(rep: dict) -> str:
    """The console report of one calibration (from the calibration.json content)."""
    X = np.asarray(rep["X"]["T_a_b"])
    u, v, off, inl = rep["uncertainty"], rep["verdict"], rep["time_offset"], rep["inliers"]
    res, conv = rep["residuals"]["inliers"], rep["conventions"]
    rows = "\n".join("    " + " ".join(f"{x:+.6f}" for x in row) for row in X)
    lines = [
        f"X = T_a_b (pose of b in a):\n{rows}",
        f"  translation (m):        {_vec(rep['X']['translation_m'], digits=5)}",
        f"  quaternion (x,y,z,w):   {_vec(rep['X']['quaternion_xyzw'], digits=6)}",
        f"  rotation vector (deg):  {_vec(rep['X']['rotvec_deg'], digits=3)}",
        f"{sigma_line(u)}  [{u['source']}]",
        *(["  in sigma: the stated common error ("
           + ", ".join(f"{k} {v:g}" for k, v in u["common_error_included"].items() if v)
           + ")"] if u.get("common_error_included") else []),
        f"  not in sigma: {u['not_included']}",
        verdict_line(v),
        *_scale_lines(rep.get("scale_b")),
        f"sampling: {rep['sampling']['reason']}",
        f"motions: {rep['motions']['policy']} ({rep['motions']['reason']})",
        _offset_line(off, rep["sampling"]),
        *[_step_line(st) for st in off.get("steps") or ()],
        f"  {off['message']}",
        f"inliers: {inl['n_inliers']} of {inl['n_motions']} motions ({inl['choice']}): "
        f"{inl['message']}",
        f"residuals of C X = X H over the inliers: rotation median {res['rot_median_deg']:.3f}"
        f" / rms {res['rot_rms_deg']:.3f} deg, translation median "
        f"{res['trans_median_mm']:.2f} / rms {res['trans_rms_mm']:.2f} mm",
        f"conventions: {conv['message']}",
    ]
    lines += other_readings_lines(rep)
    lines += [f"  note: {n}" for n in (rep.get("plausibility") or {}).get("notes") or ()]
    for k in ("a", "b"):
        s = rep["streams"][k]
        rep_txt = ", ".join(f"{n}: {c}" for n, c in s["repairs"].items() if c) or "none"
        lines.append(f"stream {k}: {s['file']}{' [' + s['name'] + ']' if s['name'] else ''}"
                     f" - {s['poses']} poses, {s['duration_s']:.2f} s, ~{s['rate_hz']:.1f} Hz,"
                     f" {s['detection']}; repairs: {rep_txt}")
    p = rep["plain"]
    if p is None:
        lines.append("plain solve (offset 0): none, the streams do not overlap at offset 0")
    else:
        lines.append(f"plain solve (offset 0, no rejection, {p['n_motions']} motions): t = "
                     f"{_vec(p['X']['translation_m'], 1e3, 2)} mm, rotvec "
                     f"{_vec(p['X']['rotvec_deg'], digits=3)} deg, residual rms "
                     f"{p['residuals']['rot_rms_deg']:.3f} deg / "
                     f"{p['residuals']['trans_rms_mm']:.2f} mm")
    lines += [f"WARNING: {w}" for w in rep["warnings"]]
    lines.append(f"status: {rep['status']} (exit {rep['exit_code']})")
    return "\n".join(lines)
