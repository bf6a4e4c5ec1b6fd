"""What a run knows about its pose errors beyond white noise: the inputs of each estimate's
covariance (``simcalib.solve(..., pose_bias=, pose_error_basis=, pose_pairs=,
correlation_lag=)``).

:func:`calibration_bias` (the cameras' calibration and marker-map uncertainty, constant over
the run), :func:`pose_error_basis` (the systematic pose error of each matched datapoint per
shared parameter, in the columns of :func:`basis_layout`; :func:`stop_error_basis` for
poses of one camera), :func:`pose_pairs` (the datapoints each motion joins) and
:func:`correlation_lag` (how far consecutive motions share poses). Each camera's source
supplies its own terms (:mod:`simcalib.sources`); nothing here names a source.
"""

from __future__ import annotations

import numpy as np

from simcalib.pipeline.state import CAMERAS
from simcalib.sources import get_source

__all__ = ["basis_layout", "calibration_bias", "correlation_lag", "pose_error_basis",
           "pose_pairs", "stop_error_basis"]


def calibration_bias(st) -> tuple:
    """The known calibration uncertainty of the run's cameras, an input of the covariance
    (``solve(..., pose_bias=...)``): ``(PoseBias or None, report)``. A camera measured by
    the ``aruco`` source gets the covariance of the run-constant pose error that
    ``vision.intrinsics_error`` (read as the 1-sigma of the calibration the estimator has)
    and the marker map's error (``vision.map_position_std_m`` / ``map_rotation_std_deg``,
    the survey's accuracy) cause
    (:func:`simcalib.sources.vision.error_model.calibration_pose_bias`, no rendering); other
    sources
    have no calibration term. ``report`` (results.json ``calibration_bias``):
    ``included`` and per camera its 1-sigma (deg, m) and inputs."""
    from simcalib.solvers.diagnostics.uncertainty import PoseBias
    truth = st.truth
    report = {"included": False, "source": "vision.intrinsics_error (1-sigma of the "
              "calibration) and vision.map_position_std_m / map_rotation_std_deg (marker "
              "map) through PnP of the marker corners seen from the true poses",
              "cameras": {}}
    if truth is None or truth.world is None:
        return None, report
    bias = {}
    for name in dict.fromkeys(st.camera_sources.get(c) for c in CAMERAS):
        if name is None:
            continue
        cams = [c for c in CAMERAS if st.camera_sources.get(c) == name]
        bias.update(get_source(name, "sim").calibration_bias(truth.world, st.cfg, cams))
    if not bias:
        return None, report
    report["included"] = True
    report["cameras"] = {c: b.report() for c, b in bias.items()}
    own = [r.get("input") for r in report["cameras"].values()]
    if all(own):                       # every bias names its own input (not ArUco's)
        report["source"] = "; ".join(dict.fromkeys(own))
    covs = [bias[c].covariance if c in bias else None for c in CAMERAS]
    return PoseBias(*covs), report


def _recorded(st) -> bool:
    """The run's motions came through the recorded-data path (``estimation.motions`` not
    ``pairing``)."""
    est = getattr(st.cfg, "estimation", None)
    return bool(est is not None and est.recorded)


def correlation_lag(st) -> int:
    """Pairs ``(k, k + step)`` of consecutive datapoints of pose streams share poses up to
    lag ``step``: the uncertainty corrects for that serial correlation. Relative motions
    from a source (synthetic) or random pairing: independent (0)."""
    if st.motions_from_source is not None or st.cfg.pairing.mode != "consecutive" \
            or _recorded(st):
        return 0
    return int(st.cfg.pairing.step)


def basis_layout(world) -> dict:
    """Columns of the systematic pose-error basis of a world (:func:`pose_error_basis`):
    ``map`` (6 per marker of the field: the survey error), ``cal_a`` / ``cal_b`` (8 each:
    the cameras' calibrations), ``dh`` (24: the arm's DH table, 4 per joint), ``P`` the
    total."""
    M = world.marker_field.T_world_marker.shape[0] if world.marker_field is not None else 0
    n = 6 * M
    return {"map": slice(0, n), "cal_a": slice(n, n + 8), "cal_b": slice(n + 8, n + 16),
            "dh": slice(n + 16, n + 40), "P": n + 40}


def stop_error_basis(world, cfg, cam: str, source: str, T_world_cam, qpos=None,
                     visible=None) -> np.ndarray | None:
    """``(F, 6, P)`` (:func:`basis_layout`) systematic pose errors of camera ``cam``
    measured by ``source`` at the poses ``T_world_cam`` (F, 4, 4): ``aruco`` — the marker
    map's and the camera's calibration errors
    (:func:`simcalib.sources.vision.error_model.pose_error_basis`;
    ``visible`` the markers each pose rests on, default the layout's); ``robot_fk`` — the
    arm's DH deviation (``robot.kinematic_error``, :func:`simcalib.world.robot_error.
    fk_pose_error_basis`; ``qpos`` (F, nq) the MuJoCo joint state at each pose). None for
    other sources or when the configuration has no such error."""
    if source is None:
        return None
    return get_source(source, "sim").error_basis(world, cfg, cam, T_world_cam,
                                                 basis_layout(world), qpos=qpos,
                                                 visible=visible)


def pose_error_basis(st, compress: bool = True):
    """The known systematic pose errors of the run's datapoints, an input of the
    covariance (``solve(..., pose_error_basis=...)``; with :func:`pose_pairs`): ``(Ba, Bb)``
    ``(D, 6, P)`` for the ``D`` matched datapoints, or None. Per camera
    :func:`stop_error_basis` of its source at its measured poses (ArUco: with the markers
    the PnP used; robot_fk: the joint state of each frame), in the columns of
    :func:`basis_layout` (the map and the DH table are shared, each calibration is its
    camera's); other sources have zero columns. ``compress``: drop the columns no
    datapoint uses (markers never seen); False keeps the full layout (e.g. to add stops'
    bases in the same columns)."""
    truth = st.truth
    if pose_pairs(st) is None or truth is None or truth.world is None:
        return None
    world = truth.world
    frames = {"cam_a": np.asarray(st.pairs.frame_a), "cam_b": np.asarray(st.pairs.frame_b)}
    D = frames["cam_a"].shape[0]
    out = []
    for cam in CAMERAS:
        src = st.camera_sources.get(cam)
        B = None
        if src is not None and get_source(src, "sim").has_error_basis \
                and cam in world.camera_names and cam in st.measured:
            m = st.measured[cam]
            pos = {int(f): k for k, f in enumerate(np.asarray(m.frame_index))}
            if not all(int(f) in pos for f in frames[cam]):
                return None
            T = np.asarray(m.T_world_cam)[[pos[int(f)] for f in frames[cam]]]
            B = get_source(src, "sim").datapoint_error_basis(st, world, cam, T, frames[cam],
                                                              basis_layout(world))
        out.append(np.zeros((D, 6, basis_layout(world)["P"])) if B is None else B)
    used = np.any(out[0] != 0, axis=(0, 1)) | np.any(out[1] != 0, axis=(0, 1))
    if not used.any():
        return None
    if not compress:
        return tuple(out)
    return tuple(B[:, :, used] for B in out)     # markers never seen carry nothing


def pose_pairs(st):
    """``(N, 2)`` datapoint indices (start, end) of the run's motions when they are pairs of
    consecutive datapoints of the pose streams, or the recorded-data path's pairs of
    synchronised instants (they then share poses: the uncertainty tests the pose noise for
    whiteness and, if white, simulates with that structure); else None."""
    if st.pairs is None or (correlation_lag(st) == 0 and not _recorded(st)):
        return None
    return np.stack([np.asarray(st.pairs.start), np.asarray(st.pairs.end)], axis=1)
