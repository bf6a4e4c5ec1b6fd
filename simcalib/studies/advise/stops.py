"""Measuring chosen stops in the simulator: the platform is driven to the reference stop and
then to each chosen candidate (stop and go) and every camera is measured there by the
run's pose sources, with the recorded run's rig (:func:`execute_stops`); the motions
between the measured stops (:func:`stop_motions`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from simcalib.geometry import invert_transform
from simcalib.studies.advise.feasibility import Candidates, camera_ids

__all__ = ["stop_state", "execute_stops", "average_stop_frames", "recorded_rig_entropy",
           "stop_config", "stop_motions"]


def stop_state(cand: Candidates, idx) -> tuple:
    """``(qpos, mocap_pos, mocap_quat_wxyz)`` of the stops: the reference first, then the
    candidates ``idx`` (stop-and-go: the platform rests at each)."""
    idx = np.asarray(idx, dtype=np.int64)
    r = cand.ref
    return (np.concatenate([r["qpos"][None], cand.qpos[idx]]),
            np.concatenate([r["mocap_pos"][None], cand.mocap_pos[idx]]),
            np.concatenate([r["mocap_quat_wxyz"][None], cand.mocap_quat_wxyz[idx]]))


def execute_stops(truth, cfg, cand: Candidates, idx, rng: np.random.Generator,
                  stop_interval_s: float = 2.0, frames_per_stop: int = 1) -> dict:
    """Drive the platform to the reference stop and then to the candidates ``idx`` (stop and
    go), measure each camera there with the run's pose sources (ArUco renders and detects,
    robot_fk reads the encoders ...), and return camera -> ``PoseStream`` over the stops
    (frame 0 = the reference stop; stops without a pose are absent). The rig is the recorded
    run's: the same true arm (DH deviation), marker map survey and camera calibrations
    (:func:`recorded_rig_entropy`); ``rng`` draws only the per-frame noise (images,
    encoders). ``frames_per_stop``:
    frames recorded while the platform rests at each stop (at the run's fps, each with its
    own sensor noise); a stop's pose is their mean (:func:`average_stop_frames`)."""
    from simcalib.sources import camera_sources, get_source
    from simcalib.streams import Trajectory
    from simcalib.world.simulate import SimCameraFrames, camera_poses_from_state
    if isinstance(frames_per_stop, bool) or not isinstance(frames_per_stop, (int, np.integer)) \
            or frames_per_stop < 1:
        raise ValueError(f"frames_per_stop must be an integer >= 1; received "
                         f"{frames_per_stop!r}")
    world = truth.world
    qpos, mpos, mquat = stop_state(cand, idx)
    stop_of = np.repeat(np.arange(qpos.shape[0]), int(frames_per_stop))
    qpos, mpos, mquat = qpos[stop_of], mpos[stop_of], mquat[stop_of]
    n = qpos.shape[0]
    t_end = float(np.max(world.frames("cam_b").time_s))
    t = (t_end + stop_interval_s * (1 + stop_of)
         + (np.arange(n) % int(frames_per_stop)) / float(world.config.fps))
    Tc = camera_poses_from_state(world.model, qpos, mpos, mquat)
    ids = camera_ids(world.model, world.camera_names)
    from simcalib.world.layout import visible_markers
    frames = {}
    for c, i in zip(world.camera_names, ids):
        vis = visible_markers(world.marker_field, Tc[:, i], world.intrinsics[c]).sum(axis=1)
        frames[c] = SimCameraFrames(camera=c, time_s=t, T_world_cam=Tc[:, i], qpos=qpos,
                                    mocap_pos=mpos, mocap_quat_wxyz=mquat, nominal_time_s=t,
                                    stamp_s=t, delivered=np.ones(n, bool),
                                    visible_markers=vis.astype(np.int64))
    traj = Trajectory(cam_a=frames["cam_a"], cam_b=frames["cam_b"],
                      T_a_b=world.trajectory.T_a_b, meta=dict(world.trajectory.meta))
    w2 = dataclasses.replace(world, trajectory=traj)
    t2 = dataclasses.replace(truth, world=w2, rig_entropy=recorded_rig_entropy(cfg))
    srcs = camera_sources(cfg, truth.kind)
    by_source: dict = {}
    for cam, name in srcs.items():
        by_source.setdefault(name, []).append(cam)
    out = {}
    children = rng.spawn(len(by_source))
    for (name, cams), r in zip(sorted(by_source.items()), children):
        res = get_source(name, truth.kind).measure(t2, stop_config(cfg), r, tuple(cams))
        out.update({c: res.streams[c] for c in cams})
    if frames_per_stop > 1:
        out = {c: average_stop_frames(s, stop_of) for c, s in out.items()}
    return out


def average_stop_frames(stream, stop_of) -> object:
    """``stream`` (a PoseStream over the frames at rest) with one pose per stop: frame ``f``
    belongs to stop ``stop_of[f]``; a stop's pose is the chordal mean rotation and the
    mean translation of its measured frames; ``info["frames_averaged"]`` counts them,
    the other ``info`` arrays keep the stop's first measured frame. Stops no frame
    measured stay absent."""
    from simcalib.geometry import chordal_mean_rotation
    fi = np.asarray(stream.frame_index, dtype=np.int64)
    stop_of = np.asarray(stop_of, dtype=np.int64)
    stops, first = np.unique(stop_of[fi], return_index=True)
    T = np.asarray(stream.T_world_cam)
    mean = np.repeat(np.eye(4)[None], stops.size, axis=0)
    count = np.zeros(stops.size, dtype=np.int64)
    for k, st in enumerate(stops):
        rows = np.flatnonzero(stop_of[fi] == st)
        mean[k, :3, :3] = chordal_mean_rotation(T[rows, :3, :3])
        mean[k, :3, 3] = T[rows, :3, 3].mean(axis=0)
        count[k] = rows.size
    info = {key: np.asarray(v)[first] for key, v in stream.info.items()
            if np.ndim(v) >= 1 and len(v) == fi.size}
    info["frames_averaged"] = count
    return dataclasses.replace(stream, frame_index=stops,
                               timestamp_s=np.asarray(stream.timestamp_s)[first],
                               T_world_cam=mean, n_frames=int(stop_of.max()) + 1, info=info)


def recorded_rig_entropy(cfg) -> dict:
    """``{"vision": n}``: the number the recorded run of ``cfg`` drew for its rig's fixed
    errors (marker map survey, camera calibrations): the stops are measured by the same rig
    (the same map and calibrations as the recorded run), with their own per-frame noise."""
    from simcalib.pipeline.state import run_rngs
    from simcalib.sources.vision.stream import rig_entropy_of
    return {"vision": rig_entropy_of(run_rngs(cfg.seed)["vision"])}


def stop_config(cfg):
    """``cfg`` for measuring stops: rendering in this process (small batches: no worker
    pool) and with the platform **at rest**: one instantaneous render per frame. At rest
    motion blur and rolling shutter vanish; the sub-frame renders would instead interpolate
    the state towards the next stop, seconds away, as if the platform moved through the
    exposure."""
    try:
        cfg = dataclasses.replace(cfg, workers=1)
    except (TypeError, ValueError):
        return cfg
    vision = getattr(cfg, "vision", None)
    if vision is not None and dataclasses.is_dataclass(vision):
        cfg = dataclasses.replace(cfg, vision=dataclasses.replace(vision, subframes=1))
    return cfg


def stop_motions(streams: dict, chain: bool = True
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(C, H, stop index)``: the motion of each camera between the stops both cameras
    measured: from the previous measured stop to each stop (``chain``, stop and go), or from
    the reference stop (0) to each (``chain=False``)."""
    sa, sb = streams["cam_a"], streams["cam_b"]
    fa, fb = np.asarray(sa.frame_index), np.asarray(sb.frame_index)
    if 0 not in fa or 0 not in fb:
        return np.zeros((0, 4, 4)), np.zeros((0, 4, 4)), np.zeros(0, dtype=np.int64)
    common = np.intersect1d(fa, fb)
    common = common[common > 0]
    ia = {int(f): k for k, f in enumerate(fa)}
    ib = {int(f): k for k, f in enumerate(fb)}
    Ta = np.asarray(sa.T_world_cam)
    Tb = np.asarray(sb.T_world_cam)
    if not common.size:
        return np.zeros((0, 4, 4)), np.zeros((0, 4, 4)), common
    start = np.concatenate([[0], common[:-1]]) if chain else np.zeros_like(common)
    Ta0 = Ta[[ia[int(f)] for f in start]]
    Tb0 = Tb[[ib[int(f)] for f in start]]
    C = invert_transform(Ta0) @ Ta[[ia[int(f)] for f in common]]
    H = invert_transform(Tb0) @ Tb[[ib[int(f)] for f in common]]
    return C, H, common
