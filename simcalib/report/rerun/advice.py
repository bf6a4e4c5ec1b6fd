"""The recording of ``simcalib advise`` (``advice.rrd``): the recorded trajectories, each
camera at the reference stop and at every proposed stop, and the predicted 1-sigma against
the number of added stops."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simcalib.geometry import quat_from_matrix
from simcalib.report.rerun.common import CAMERA_COLORS, open_recording

__all__ = ["record_advice", "record_recorded_advice"]


def record_advice(path, base, adv) -> Path:
    """Recording of motion advice (``simcalib advise``): the marker field, each camera's
    recorded trajectory, its pose at the reference stop and at every proposed stop (axes,
    labelled ``stop k``, a line from the reference), and the predicted 1-sigma per axis
    (deg / cm) against the number of added stops. ``base``/``adv``:
    :class:`simcalib.studies.advise.Baseline` / :class:`simcalib.studies.advise.Advice`. Self-contained."""
    import rerun as rr
    path = Path(path)
    rec = open_recording(rr, "simcalib-advice", path)
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    mf = base.truth.marker_field
    if mf is not None and len(getattr(mf, "ids", ())):
        T = np.asarray(mf.T_world_marker)
        h = 0.5 * float(mf.side_m)
        rec.log("world/markers", rr.Boxes3D(
            centers=T[:, :3, 3], half_sizes=np.tile([h, h, 0.002], (T.shape[0], 1)),
            quaternions=quat_from_matrix(T[:, :3, :3]), colors=(40, 40, 40)), static=True)
    cand = adv.candidates
    for cam, s in base.truth.streams.items():
        _log_stops(rec, rr, cam, np.asarray(s.T_world_cam), cand.ref["T_world_cam"][cam],
                   cand.T_world_cam[cam][adv.chosen])
    _log_predicted_std(rec, rr, adv.std_before, adv.std_after)
    rec.flush() if hasattr(rec, "flush") else None
    rec.disconnect() if hasattr(rec, "disconnect") else None
    return path


def record_recorded_advice(path, T_frame_a, adv) -> Path:
    """Recording of advice for recorded pose files (``simcalib advise a=... b=...``), in
    file a's frame: sensor a's recorded trajectory ``T_frame_a`` (N, 4, 4), sensor b's
    through the estimate (``T_frame_a @ X``), both sensors at the reference and at every
    proposed stop, and the predicted 1-sigma against the number of added stops. ``adv``:
    :class:`simcalib.studies.advise.recorded.RecordedAdvice`. Self-contained."""
    import rerun as rr
    path = Path(path)
    rec = open_recording(rr, "simcalib-advice", path)
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    T_frame_a = np.asarray(T_frame_a, dtype=np.float64)
    stops = adv.T_ref_a @ adv.motion_a[adv.chosen]
    for cam, right in (("cam_a", np.eye(4)), ("cam_b", adv.X)):
        _log_stops(rec, rr, cam, T_frame_a @ right, adv.T_ref_a @ right, stops @ right)
    _log_predicted_std(rec, rr, adv.std_before, adv.std_after)
    rec.flush() if hasattr(rec, "flush") else None
    rec.disconnect() if hasattr(rec, "disconnect") else None
    return path


def _log_stops(rec, rr, cam, T_recorded, ref, Tp) -> None:
    """A camera's recorded trajectory ``T_recorded`` (N, 4, 4), its pose at the reference
    ``ref`` and at the proposed stops ``Tp`` (k, 4, 4): axes, labels, lines from the
    reference."""
    color = CAMERA_COLORS.get(cam, (200, 200, 200))
    rec.log(f"world/recorded/{cam}", rr.LineStrips3D([T_recorded[:, :3, 3]], colors=color,
                                                     radii=0.002), static=True)
    rec.log(f"world/advice/{cam}/reference", rr.Transform3D(
        translation=ref[:3, 3], mat3x3=ref[:3, :3]), rr.TransformAxes3D(0.08), static=True)
    for k, Tk in enumerate(Tp):
        rec.log(f"world/advice/{cam}/stop_{k + 1}", rr.Transform3D(
            translation=Tk[:3, 3], mat3x3=Tk[:3, :3]), rr.TransformAxes3D(0.06), static=True)
    if len(Tp):
        rec.log(f"world/advice/{cam}/stops", rr.Points3D(
            Tp[:, :3, 3], colors=color, radii=0.01,
            labels=[f"stop {k + 1}" for k in range(len(Tp))]), static=True)
        rec.log(f"world/advice/{cam}/moves", rr.LineStrips3D(
            [[ref[:3, 3], p] for p in Tp[:, :3, 3]], colors=color, radii=0.002), static=True)


def _log_predicted_std(rec, rr, before, after) -> None:
    """Predicted 1-sigma per axis (deg / cm) against the number of added stops."""
    names = ["wx [deg]", "wy [deg]", "wz [deg]", "vx [cm]", "vy [cm]", "vz [cm]"]
    rec.log("advice/predicted_std", rr.SeriesLines(names=names), static=True)
    for k, s in enumerate([before] + list(after)):
        rec.set_time("added_stops", sequence=k)
        v = np.concatenate([s[:3], 100.0 * s[3:]])
        rec.log("advice/predicted_std", rr.Scalars(np.where(np.isfinite(v), v, np.nan)))
