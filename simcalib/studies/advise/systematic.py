"""The systematic pose errors of a scenario's stops, and what X's predicted uncertainty is
made of.

The poses share errors through common parameters — the marker map's survey error and each
ArUco camera's calibration error, and for a ``robot_fk`` stream the arm's DH deviation —
so each stop and each recorded pose carries an error basis ``xi = B eta``
(:func:`simcalib.pipeline.uncertainty_inputs.stop_error_basis`); :func:`systematic_model` gives the
planner the recorded motions' summed score and the stops' bases, :func:`limited_by`
splits the predicted variance of each axis by source."""

from __future__ import annotations

import numpy as np

from simcalib.studies.advise.information import (AXES, finite_or_none, systematic_scores,
                                                 variance_shares)

__all__ = ["stop_bases", "systematic_model", "UNCERTAINTY_SOURCES", "cannot_help_axes",
           "limited_by"]


def stop_bases(world, cfg, sources, T_world_cam, qpos, P) -> np.ndarray:
    """``(2, F, 6, P)``: :func:`simcalib.pipeline.uncertainty_inputs.stop_error_basis` of cameras a and b
    (``sources``: camera -> pose source) at the poses ``T_world_cam[camera]`` (F, 4, 4)
    and joint states ``qpos`` (F, nq); zero where a camera's source has none."""
    from simcalib.pipeline.uncertainty_inputs import stop_error_basis
    qpos = np.asarray(qpos)
    out = np.zeros((2, qpos.shape[0], 6, P))
    for k, cam in enumerate(("cam_a", "cam_b")):
        B = stop_error_basis(world, cfg, cam, sources.get(cam), T_world_cam[cam], qpos=qpos)
        if B is not None:
            out[k] = B
    return out


def systematic_model(world, cand, C, H, X, s_r, s_t, recorded, sources, cfg):
    """``((G_base, B_ref, B_cand), groups)``: for :func:`planner.greedy_chain` the recorded
    motions' summed systematic score and the error bases of the reference and candidate
    stops (:func:`simcalib.pipeline.uncertainty_inputs.stop_error_basis` of each camera's source), in the
    columns of the recorded basis, columns no pose uses dropped; ``groups`` the source of
    each kept column (:data:`UNCERTAINTY_SOURCES`)."""
    Ba, Bb, pairs = recorded
    Ba, Bb = np.asarray(Ba, dtype=np.float64), np.asarray(Bb, dtype=np.float64)
    T = {c: np.concatenate([cand.ref["T_world_cam"][c][None], cand.T_world_cam[c]])
         for c in ("cam_a", "cam_b")}
    q = np.concatenate([np.asarray(cand.ref["qpos"])[None], np.asarray(cand.qpos)])
    B = stop_bases(world, cfg, sources, T, q, Ba.shape[2])
    B_ref, B_cand = B[:, 0], B[:, 1:]
    G_base = systematic_scores(C, H, X, s_r, s_t, Ba[pairs[:, 0]], Ba[pairs[:, 1]],
                               Bb[pairs[:, 0]], Bb[pairs[:, 1]]).sum(axis=0)
    used = (np.any(Ba != 0, axis=(0, 1)) | np.any(Bb != 0, axis=(0, 1))
            | np.any(B_ref != 0, axis=(0, 1)) | np.any(B_cand != 0, axis=(0, 1, 2)))
    return (G_base[:, used], B_ref[:, :, used], B_cand[:, :, :, used]), \
        [g for g, u in zip(_column_groups(world), used) if u]


#: each source of X's predicted uncertainty (:func:`limited_by`): name -> (its columns in
#: :func:`simcalib.pipeline.uncertainty_inputs.basis_layout`, None for the white noise; a short name;
#: what would lower its share)
UNCERTAINTY_SOURCES = {
    "white noise": (None, "the pose noise", "more stops, or several frames averaged at "
                    "each stop (stop_frames=), lower it"),
    "marker map": ("map", "the marker map's survey error", "it is shared by every stop: a "
                   "more accurate survey of the markers would lower it "
                   "(vision.map_position_std_m / map_rotation_std_deg describe the survey), "
                   "more stops barely"),
    "calibration of cam_a": ("cal_a", "cam_a's intrinsic calibration error", "it is shared "
                             "by every stop: recalibrating cam_a would lower it "
                             "(vision.intrinsics_error describes it), more stops barely"),
    "calibration of cam_b": ("cal_b", "cam_b's intrinsic calibration error", "it is shared "
                             "by every stop: recalibrating cam_b would lower it "
                             "(vision.intrinsics_error describes it), more stops barely"),
    "DH table of the arm": ("dh", "the arm's kinematic (DH table) error", "it is shared by "
                            "every stop: a kinematic calibration of the arm would lower it "
                            "(robot.kinematic_error describes it), more stops barely"),
}


def cannot_help_axes(cannot_help) -> list:
    """The axes (:data:`AXES`) the directions of :func:`information.undeterminable` move (a
    component above 0.3 of the rotation axis or translation direction)."""
    out = set()
    for h in cannot_help:
        for block, key in ((0, "rotation_axis_a"), (3, "translation_dir_a")):
            v = np.abs(np.asarray(h.get(key, np.zeros(3)), dtype=np.float64))
            out.update(AXES[block + i] for i in np.flatnonzero(v > 0.3))
    return [a for a in AXES if a in out]


def _column_groups(world) -> list:
    """The source name (:data:`UNCERTAINTY_SOURCES`) of each column of
    :func:`simcalib.pipeline.uncertainty_inputs.basis_layout`."""
    from simcalib.pipeline.uncertainty_inputs import basis_layout
    lay = basis_layout(world)
    out = [""] * lay["P"]
    for name, (key, _, _) in UNCERTAINTY_SOURCES.items():
        if key is not None:
            out[lay[key]] = [name] * (lay[key].stop - lay[key].start)
    return out


def limited_by(F, G, groups, std, *, tolerance_deg: float = 1.0, tolerance_m: float = 0.01,
               range_m: float = 1.0, exclude=(), undetermined=None) -> dict:
    """What X's predicted uncertainty is made of (:func:`information.variance_shares`, over
    the directions determined and not ``undetermined``) with the
    information ``F``, the systematic score ``G`` (6, P) and its column ``groups``, and
    ``std`` (6,) the 1-sigma per axis: ``per_axis`` (axis -> source -> share of the
    variance), ``axis`` (the largest 1-sigma in tolerance units), its ``std`` and
    ``shares``, the ``dominant`` source and a ``statement`` saying what would lower it.
    ``exclude``: axes no motion of the platform determines (:func:`cannot_help_axes`),
    left to the ``cannot_help`` statements. Empty when no other axis is determined."""
    std = np.asarray(std, dtype=np.float64)
    tol = np.array([tolerance_deg] * 3 + [tolerance_m] * 3)
    in_tol = np.where(np.isfinite(std) & ~np.isin(AXES, list(exclude)), std / tol, -np.inf)
    if not np.isfinite(in_tol).any():
        return {}
    shares, names = variance_shares(F, G, groups, tolerance_deg=tolerance_deg,
                                    tolerance_m=tolerance_m, range_m=range_m,
                                    undetermined=undetermined)
    per_axis = {a: {n: finite_or_none(v) for n, v in zip(names, row)}
                for a, row in zip(AXES, shares)}
    w = int(np.argmax(in_tol))
    row = {n: float(v) for n, v in zip(names, shares[w]) if np.isfinite(v)}
    if not row:
        return {}
    order = sorted(row, key=row.get, reverse=True)
    top = order[0]
    unit = f"{std[w]:.3g} deg" if w < 3 else f"{100 * std[w]:.3g} cm"

    def short(n):
        return UNCERTAINTY_SOURCES.get(n, (None, n, ""))[1]
    parts = ", ".join(f"{100 * row[n]:.0f} % {short(n)}" for n in order if row[n] >= 0.05)
    but = (f" (apart from {', '.join(exclude)}, which no motion of this platform "
           f"determines: see cannot_help)" if len(exclude) else "")
    statement = (f"the largest predicted 1-sigma{but} ({AXES[w]}: {unit}) comes from "
                 f"{parts}; the largest share, {short(top)}: "
                 f"{UNCERTAINTY_SOURCES.get(top, (None, '', 'n/a'))[2]}")
    return {"axis": AXES[w], "std": float(std[w]), "shares": row, "dominant": top,
            "statement": statement, "per_axis": per_axis}
