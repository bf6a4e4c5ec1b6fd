"""A run's measured pose streams -> the motions its solvers get, through the same stages
that calibrate a recording (:func:`simcalib.estimation.path.calibrate_streams`), with
every decision scored against the simulation's truth.

:func:`motions_from_streams` is what the run's ``pairs`` stage calls: with
``estimation.motions=pairing`` the paper's D.1 pairing of the streams as stamped
(:func:`simcalib.estimation.pairing.make_pairs`); otherwise the streams are handed over as files would
hold them (``estimation.b_file``) and go through sampling, reading, clock offset, motion
policy and outlier handling; the solvers then get the inlier motions. The report
(results.json ``estimation``) gives each choice and its score: the offset error against
the cameras' clocks, whether the reading is the true one, the inliers' precision and recall
against the injected outlier poses.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["motions_from_streams", "file_form"]


def file_form(stream, form: str):
    """The :class:`simcalib.importers.PoseStreamData` of a run's ``PoseStream`` as a file
    of ``form`` (:data:`simcalib.estimation.config.FILE_FORMS`) would hold it: inverted
    (``T_cam_world``) and / or its quaternions written w first and read x first."""
    import dataclasses

    from simcalib.geometry import (invert_transform, matrix_from_quat, quat_from_matrix,
                                   transform_from_rotation_translation)
    from simcalib.importers import stream_from_arrays
    T = np.asarray(stream.T_world_cam, dtype=np.float64)
    if form in ("inverted", "inverted_scalar_first"):
        T = invert_transform(T)
    if form in ("scalar_first", "inverted_scalar_first"):
        q = quat_from_matrix(T[:, :3, :3])                       # (x, y, z, w)
        read = np.concatenate([q[:, 3:], q[:, :3]], axis=1)       # w, x, y, z as x, y, z, w
        T = transform_from_rotation_translation(matrix_from_quat(read), T[:, :3, 3])
    s = stream_from_arrays(stream.timestamp_s, T, source=f"<run {stream.camera}>",
                           name=stream.camera, quat_order="xyzw")
    return dataclasses.replace(s, detection=f"the run's {stream.camera} stream, {form}")


def _true_clocks(sensing, t_ref_a: float) -> tuple[float | None, float | None]:
    """``(offset t_b - t_a at a's stamp t_ref_a, drift (s/s))`` of the run's clocks (each
    stamps ``t (1 + drift_ppm 1e-6) + clock_offset_s``); None without them."""
    clocks = sensing.get("clocks") or {}
    if "cam_a" not in clocks or "cam_b" not in clocks:
        return None, None
    ca, cb = clocks["cam_a"], clocks["cam_b"]
    da, db = (1e-6 * float(c.get("clock_drift_ppm", 0.0)) for c in (ca, cb))
    t = (t_ref_a - ca["clock_offset_s"]) / (1.0 + da)       # the instant a stamps t_ref_a
    return (float(cb["clock_offset_s"] - ca["clock_offset_s"] + (db - da) * t),
            (1.0 + db) / (1.0 + da) - 1.0)


def _bracket(t_stream, t_query):
    """Indices of the stream samples at or around each query time (two per query)."""
    k = np.clip(np.searchsorted(t_stream, t_query), 1, t_stream.size - 1)
    return np.stack([k - 1, k], axis=1)


def _contaminated(streams, synced, off, sensing) -> np.ndarray | None:
    """Per synchronised instant: does it rest on an injected outlier pose (of either
    stream: the sample it is, or one of the two it is interpolated from)? None without
    outliers."""
    rep = sensing.get("outliers") or {}
    if not rep.get("enabled"):
        return None
    bad = np.zeros(synced.n, dtype=bool)
    for cam, t_q in (("cam_a", synced.time_s), ("cam_b", off.b_from_a(synced.time_s))):
        lab = rep.get(cam)
        if not lab:
            continue
        s = streams[cam]
        out_frames = np.array([int(d["frame_index"]) for d in lab["labels"]], dtype=np.int64)
        is_out = np.isin(np.asarray(s.frame_index), out_frames)
        ts = np.asarray(s.timestamp_s, dtype=np.float64)
        br = _bracket(ts, t_q)
        d = np.abs(ts[br] - t_q[:, None])
        exact = d.min(axis=1) < 1e-9
        uses = np.where(exact[:, None], d == d.min(axis=1, keepdims=True), True)
        bad |= np.any(is_out[br] & uses, axis=1)
    return bad


def _inlier_scores(ms, inlier, bad_instant) -> dict | None:
    if bad_instant is None:
        return None
    bad = bad_instant[ms.i] | bad_instant[ms.j]
    rejected = ~inlier
    tp = int((rejected & bad).sum())
    return {"contaminated_motions": int(bad.sum()), "rejected": int(rejected.sum()),
            "precision": tp / int(rejected.sum()) if rejected.any() else None,
            "recall": tp / int(bad.sum()) if bad.any() else None}


def _reading_scores(conv, form) -> dict:
    inv_true = form in ("inverted", "inverted_scalar_first")
    swap_true = form in ("scalar_first", "inverted_scalar_first")
    ok = (conv.invert_b != conv.invert_a) == inv_true and conv.swap_scalar_b == swap_true \
        and not conv.swap_scalar_a
    return {"file_form_b": form, "invert_a": conv.invert_a, "invert_b": conv.invert_b,
            "swap_scalar_a": conv.swap_scalar_a, "swap_scalar_b": conv.swap_scalar_b,
            "correct": bool(ok), "ratio": conv.ratio if math.isfinite(conv.ratio) else None,
            "clear": conv.clear, "message": conv.message}


def _pairs(ms, keep, synced, streams, off):
    """:class:`simcalib.estimation.pairing.MotionPairs` of the kept motions; datapoints are the
    synchronised instants (frame of each stream: the nearest sample)."""
    from simcalib.estimation.pairing import MotionPairs
    t_a, t_b = synced.time_s, off.b_from_a(synced.time_s)
    nearest = {}
    for cam, t_q in (("cam_a", t_a), ("cam_b", t_b)):
        ts = np.asarray(streams[cam].timestamp_s, dtype=np.float64)
        br = _bracket(ts, t_q)
        pick = np.where(np.abs(ts[br[:, 0]] - t_q) <= np.abs(ts[br[:, 1]] - t_q),
                        br[:, 0], br[:, 1])
        nearest[cam] = np.asarray(streams[cam].frame_index)[pick]
    counts = {"poses_a": int(streams["cam_a"].n_used), "poses_b": int(streams["cam_b"].n_used),
              "matched": int(synced.n), "datapoints": int(synced.n),
              "candidate_pairs": int(ms.counts.get("formed", ms.n)),
              "surviving_pairs": int(ms.n), "used": int(keep.sum()),
              "dropped_time_diff": 0, "dropped_translation": 0,
              "dropped_rotation": int(ms.counts.get("dropped_small_rotation", 0)),
              "rejected_outliers": int((~keep).sum())}
    return MotionPairs(C=ms.C[keep], H=ms.H[keep], start=ms.i[keep], end=ms.j[keep],
                       frame_a=nearest["cam_a"], frame_b=nearest["cam_b"], time_a_s=t_a,
                       time_b_s=t_b, counts=counts)


def motions_from_streams(streams: dict, cfg, rng, sensing: dict):
    """``(MotionPairs, pairing dict, estimation report or None)`` of a run's measured
    ``streams`` (camera -> PoseStream) under ``cfg`` (the ScenarioConfig: ``estimation``,
    ``pairing``, ``seed``); ``rng`` the run's pairing generator; ``sensing`` the run's
    clocks and outlier labels (the truth the report scores against)."""
    from simcalib.estimation.pairing import make_pairs
    est = cfg.estimation
    if not est.recorded:
        pairs = make_pairs(streams["cam_a"], streams["cam_b"], cfg.pairing, rng)
        return pairs, dict(pairs.counts) | {"mode": cfg.pairing.mode}, None
    from simcalib.estimation.outliers import robust_fit
    from simcalib.estimation.path import align_and_read, synchronised
    from simcalib.estimation.motions import form_motions
    from simcalib.estimation.sampling import classify_sampling
    from simcalib.estimation.units import check_translation_units
    from simcalib.estimation.stamp_units import stamps_to_seconds
    a, b = stamps_to_seconds(file_form(streams["cam_a"], "as_written"),
                             file_form(streams["cam_b"], est.b_file))
    sampling = classify_sampling(a, b)
    forced = ({} if est.reading == "detect" else
              {"invert_a": False, "invert_b": est.b_file.startswith("inverted"),
               "scalar_first_a": False, "scalar_first_b": "scalar_first" in est.b_file,
               "mirror_b": False})
    offset = 0.0 if est.time_offset == "stamps" else est.time_offset
    a, b, conv, off, sampling = align_and_read(a, b, sampling, time_offset=offset,
                                               seed=cfg.seed, forced=forced)
    synced = synchronised(a, b, sampling, off)
    ms = form_motions(synced, est.motions, paired_by_stamp=sampling.paired_by_stamp,
                      index_stamps=sampling.kind == "index_stamps", step_s=est.step_s,
                      min_rotation_deg=est.min_rotation_deg)
    check_translation_units(ms.C, ms.H)
    if est.robust == "none":
        keep, why = np.ones(ms.n, dtype=bool), "none (given)"
    else:
        rob, why = robust_fit(ms.C, ms.H, est.robust, alpha=1.0, method="dqopt",
                              seed=cfg.seed, options=None)
        keep = np.asarray(rob.inlier_mask, dtype=bool)
    pairs = _pairs(ms, keep, synced, streams, off)
    true_off, true_drift = _true_clocks(sensing, off.t_ref_s)
    report = {
        "path": "recorded-data path of simcalib calibrate",
        "sampling": sampling.to_dict(),
        "time_offset": {"offset_s": off.offset_s, "uncertainty_s": off.uncertainty_s
                        if math.isfinite(off.uncertainty_s) else None,
                        "decision": off.decision, "true_offset_s": true_off,
                        "error_ms": None if true_off is None
                        else 1e3 * (off.offset_s - true_off), "t_ref_s": off.t_ref_s,
                        "drift_ppm": 1e6 * off.drift, "true_drift_ppm": None
                        if true_drift is None else 1e6 * true_drift, "message": off.message},
        "reading": _reading_scores(conv, est.b_file),
        "motions": {"policy": ms.policy, "reason": ms.reason, "counts": dict(ms.counts)},
        "robust": {"choice": why, "n_motions": int(ms.n), "n_inliers": int(keep.sum()),
                   "scores": _inlier_scores(ms, keep, _contaminated(streams, synced, off,
                                                                    sensing))},
    }
    pairing = dict(pairs.counts) | {"mode": f"estimation:{ms.policy}"}
    return pairs, pairing, report
