"""Simulation: scene + path + timing knobs -> per-camera ground truth (``Trajectory``).

The platform (:mod:`simcalib.world.platforms`) turns the path's target poses into MuJoCo
states for every capture time (cart: mocap pose; arm: joints from IK), then MuJoCo's
forward kinematics gives each camera's pose
(``cam_xpos``, ``cam_xmat @ diag(1, -1, -1)`` = OpenCV frame). Each camera has its own
capture times (``k / fps + capture_offset_s + jitter``, its own ``fps`` if set), so with a time offset the two
cameras are sampled at different platform poses, exactly as an unsynchronised real rig.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field

import numpy as np

from simcalib.world.render_backend import import_mujoco as _mujoco

from simcalib.targets.markers import MarkerField
from simcalib.streams import CameraFrames, CameraIntrinsics, Trajectory
from simcalib.world.config import WorldConfig
from simcalib.world.paths import compose_path, get_path, perturbation_sample, sample_path
from simcalib.world.render import T_world_cv_from_mujoco
from simcalib.world.scene import CAMERA_NAMES, Scene, build_scene

__all__ = ["SimCameraFrames", "World", "build_world", "camera_poses_from_state"]


@dataclass(frozen=True)
class SimCameraFrames(CameraFrames):
    """:class:`CameraFrames` plus the camera's clock and delivery record:

    ``nominal_time_s`` ``(F,)`` (``k / fps``), ``stamp_s`` ``(F,)`` the timestamps the
    camera reports (true capture time + clock offset + stamp jitter), ``delivered``
    ``(F,)`` bool (False = frame dropped at the stream level: no pose source may use it),
    ``visible_markers`` ``(F,)`` number of markers fully in view (projection test, no
    occlusion)."""
    nominal_time_s: np.ndarray = None
    stamp_s: np.ndarray = None
    delivered: np.ndarray = None
    visible_markers: np.ndarray = None


@dataclass(frozen=True)
class World:
    """A built world (``build_world``).

    ``model``: compiled ``mujoco.MjModel`` (pickles; or rebuild it from ``config`` with
    :func:`simcalib.world.build_model`); ``camera_names`` ``("cam_a", "cam_b")``;
    ``intrinsics``: camera -> ``CameraIntrinsics``; ``marker_field``: the known map;
    ``trajectory``: ground truth (``cam_a``/``cam_b`` are :class:`SimCameraFrames`,
    ``T_a_b`` the true X); ``config``; ``scene``: assembly details (home pose, mount site,
    MJCF text); ``ik``: the platform's statistics (arm IK errors, physics stats; ``None`` for
    the cart); ``timing_s``: build and simulate wall times; ``platform_record``: a simulated
    platform's full record (``VehicleTrajectory`` / ``ArmTrajectory``), else ``None``."""
    config: WorldConfig
    model: object
    camera_names: tuple
    intrinsics: dict
    marker_field: MarkerField
    trajectory: Trajectory
    scene: Scene = field(repr=False)
    ik: dict | None = None
    timing_s: dict = field(default_factory=dict)
    platform_record: object = field(default=None, repr=False)

    def frames(self, camera: str) -> SimCameraFrames:
        if camera not in self.camera_names:
            raise ValueError(f"unknown camera {camera!r}; valid: {list(self.camera_names)}")
        return getattr(self.trajectory, camera)




def camera_poses_from_state(model, qpos: np.ndarray, mocap_pos: np.ndarray,
                            mocap_quat_wxyz: np.ndarray, data=None) -> np.ndarray:
    """``(F, ncam, 4, 4)`` OpenCV camera poses in the world for ``F`` MuJoCo states
    (``qpos`` ``(F, nq)``, ``mocap_pos`` ``(F, nmocap, 3)``, ``mocap_quat_wxyz``
    ``(F, nmocap, 4)``) — the one place MuJoCo camera frames become OpenCV poses."""
    mujoco = _mujoco()
    data = mujoco.MjData(model) if data is None else data
    n = qpos.shape[0]
    pos = np.zeros((n, model.ncam, 3))
    mat = np.zeros((n, model.ncam, 9))
    for k in range(n):
        if model.nq:
            data.qpos[:] = qpos[k]
        if model.nmocap:
            data.mocap_pos[:] = mocap_pos[k]
            data.mocap_quat[:] = mocap_quat_wxyz[k]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        pos[k] = data.cam_xpos
        mat[k] = data.cam_xmat
    return T_world_cv_from_mujoco(pos, mat)


def _capture_times(cfg: WorldConfig, camera: str, rng: np.random.Generator):
    cam_cfg = getattr(cfg, camera)
    t_nom = cfg.nominal_times_s(camera)
    n = t_nom.shape[0]
    jitter = rng.normal(0.0, cam_cfg.capture_jitter_s, n) if cam_cfg.capture_jitter_s else 0.0
    t_cap = t_nom + cam_cfg.capture_offset_s + jitter
    stamp_noise = rng.normal(0.0, cam_cfg.stamp_jitter_s, n) if cam_cfg.stamp_jitter_s else 0.0
    drift = t_cap * (cam_cfg.clock_drift_ppm * 1e-6) if cam_cfg.clock_drift_ppm else 0.0
    stamp = t_cap + drift + cam_cfg.clock_offset_s + stamp_noise
    delivered = rng.random(n) >= cam_cfg.drop_prob if cam_cfg.drop_prob else np.ones(n, bool)
    return t_nom, t_cap, stamp, delivered


def build_world(cfg: WorldConfig, rng: np.random.Generator) -> World:
    """Build the scene, run the path and return the :class:`World`.

    All randomness (perturbation phases/frequencies, capture jitter, stamp jitter, frame
    drops) comes from children of ``rng`` (``rng.spawn``): the same config and the same
    seed give identical worlds. Raises ``ValueError`` if the arm cannot reach the path
    (naming the first failing time and error) or a camera leaves the room."""
    if not isinstance(cfg, WorldConfig):
        raise TypeError(f"cfg must be a WorldConfig; received {type(cfg).__name__}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    mujoco = _mujoco()
    t0 = time.perf_counter()
    scene = build_scene(cfg)
    model = scene.model
    t_build = time.perf_counter() - t0

    # the 4th child (physics platforms) leaves the first three as they always were
    rng_pert, rng_a, rng_b, rng_platform = rng.spawn(4)
    timing = {"cam_a": _capture_times(cfg, "cam_a", rng_a),
              "cam_b": _capture_times(cfg, "cam_b", rng_b)}
    t_all = np.concatenate([timing["cam_a"][1], timing["cam_b"][1]])
    t_unique, inverse = np.unique(t_all, return_inverse=True)
    platform, motion = _platform_motion(cfg, scene, _path_target(cfg, scene, rng_pert),
                                        t_unique, rng_platform)

    T_cams = camera_poses_from_state(model, motion.qpos, motion.mocap_pos,
                                     motion.mocap_quat_wxyz)   # (nu, ncam, 4, 4)
    cam_ids = {name: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
               for name in CAMERA_NAMES}
    if not platform.info.outdoor:
        _check_inside_room(cfg, T_cams[:, [cam_ids[c] for c in CAMERA_NAMES]], t_unique)
    frames = _sim_camera_frames(scene, timing, inverse, T_cams, cam_ids, motion)
    traj = Trajectory(cam_a=frames["cam_a"], cam_b=frames["cam_b"], T_a_b=scene.T_a_b,
                      meta=_trajectory_meta(cfg, frames, timing))
    total = time.perf_counter() - t0
    return World(config=cfg, model=model, camera_names=CAMERA_NAMES,
                 intrinsics=dict(scene.intrinsics), marker_field=scene.marker_field,
                 trajectory=traj, scene=scene, ik=motion.stats,
                 platform_record=motion.record,
                 timing_s={"build_scene": t_build, "simulate": total - t_build,
                           "total": total})


def _path_target(cfg: WorldConfig, scene: Scene, rng_pert: np.random.Generator):
    """``target_fn(t)``: path poses of the target frame at any times (the perturbation's
    draws are the same at every call: each call draws from a copy of ``rng_pert``)."""
    def target_fn(tt):
        tt = np.asarray(tt, dtype=np.float64)
        samples = [sample_path(cfg.path, cfg.platform, tt, cfg.duration_s, cfg.path_params)]
        if cfg.perturbation.active:
            samples.append(perturbation_sample(tt, cfg.perturbation, copy.deepcopy(rng_pert)))
        return compose_path(scene.T_world_home, *samples)
    return target_fn


def _platform_motion(cfg: WorldConfig, scene: Scene, target_fn, t_unique: np.ndarray,
                     rng_platform: np.random.Generator) -> tuple:
    """``(platform, motion)``: the platform's MuJoCo states at the capture times — posed
    from the path targets, or simulated (physics platforms)."""
    from simcalib.world.platforms import get_platform
    platform = get_platform(cfg.platform)
    if callable(getattr(platform, "simulates", None)) and platform.simulates(cfg):
        return platform, platform.simulate(scene, target_fn, t_unique, cfg, rng_platform)
    return platform, platform.drive(scene, target_fn(t_unique), t_unique, cfg)


def _sim_camera_frames(scene: Scene, timing: dict, inverse: np.ndarray, T_cams: np.ndarray,
                       cam_ids: dict, motion) -> dict:
    """Each camera's :class:`SimCameraFrames`: its rows of the shared capture instants
    (``inverse``), poses, MuJoCo states, clock and markers in view."""
    from simcalib.world.layout import visible_markers
    n_cam = {c: timing[c][1].shape[0] for c in CAMERA_NAMES}
    first = {"cam_a": 0, "cam_b": n_cam["cam_a"]}
    qpos, mocap_pos, mocap_quat = motion.qpos, motion.mocap_pos, motion.mocap_quat_wxyz
    frames = {}
    for name in CAMERA_NAMES:
        t_nom, t_cap, stamp, delivered = timing[name]
        idx = inverse[first[name]:first[name] + n_cam[name]]
        T_wc = T_cams[idx, cam_ids[name]]
        vis = visible_markers(scene.marker_field, T_wc, scene.intrinsics[name]).sum(axis=1)
        frames[name] = SimCameraFrames(
            camera=name, time_s=t_cap, T_world_cam=T_wc, qpos=qpos[idx],
            mocap_pos=mocap_pos[idx], mocap_quat_wxyz=mocap_quat[idx],
            nominal_time_s=t_nom, stamp_s=stamp, delivered=delivered,
            visible_markers=vis.astype(np.int64))
    return frames


def _trajectory_meta(cfg: WorldConfig, frames: dict, timing: dict) -> dict:
    """``Trajectory.meta``: platform, path and its parameters, timing per camera, fewest
    markers in view."""
    info = get_path(cfg.path)
    return {"platform": cfg.platform, "path": cfg.path, "fps": cfg.fps,
            "duration_s": cfg.duration_s, "n_frames": cfg.n_frames,
            "path_params": info.params_for(cfg.platform, cfg.path_params),
            "path_description": info.description, "degenerate": info.degenerate,
            "perturbation": cfg.perturbation.active,
            "capture_offset_s": {c: getattr(cfg, c).capture_offset_s for c in CAMERA_NAMES},
            "camera_fps": {c: cfg.camera_fps(c) for c in CAMERA_NAMES},
            "camera_n_frames": {c: timing[c][1].shape[0] for c in CAMERA_NAMES},
            "min_visible_markers": {c: int(frames[c].visible_markers.min())
                                    for c in CAMERA_NAMES}}


def _check_inside_room(cfg: WorldConfig, T_cams: np.ndarray, t: np.ndarray,
                       margin_m: float = 0.05) -> None:
    half = 0.5 * np.asarray(cfg.room.size_m)
    p = T_cams[..., :3, 3]                                        # (nu, 2, 3)
    inside = ((np.abs(p[..., 0]) <= half[0] - margin_m)
              & (np.abs(p[..., 1]) <= half[1] - margin_m)
              & (p[..., 2] >= margin_m) & (p[..., 2] <= cfg.room.size_m[2] - margin_m))
    if not inside.all():
        k, c = (int(v) for v in np.argwhere(~inside)[0])
        raise ValueError(f"camera {CAMERA_NAMES[c]} leaves the room at t = {t[k]:.3f} s "
                         f"(position {np.round(p[k, c], 3).tolist()} m, room "
                         f"{list(cfg.room.size_m)} m); reduce the path amplitudes or enlarge "
                         "the room")
