"""Feasible candidate motions of a platform, and executing chosen stops in the simulator.

A *candidate* is a stop: the platform's target frame (arm flange / cart base) moved from a
reference pose ``T_world_target_ref`` (the last pose of the recorded run) to
``T_world_target = Trans(p_ref + dp) · R(omega) · R_ref`` (rotation ``omega`` about world
axes through the target, as the scripted paths do). Stops are visited in order (stop and
go); the motion a stop adds to the calibration data is the relative motion of each camera
from the previous stop (``motion`` holds the one from the reference).

Feasibility:

* arm: damped-least-squares IK (:func:`simcalib.world.ik.solve_ik`, warm-started at the
  reference joints) converged within ``world.ik.fail_pos_m`` / ``fail_rot_rad``; the joints
  inside their ranges; no self-collision — MuJoCo contacts between the arm's, the
  pedestal's and the rig's geoms (collision enabled on a copy of the model; pairs already
  touching at the reference pose are allowed, as a MoveIt allowed-collision matrix would);
  every camera inside the room;
* cart: a planar move (x, y, yaw) keeping the cameras inside the room (margin 0.3 m);
* cameras measured by ArUco: at least ``min_markers`` markers fully visible at the target
  pose (:func:`simcalib.world.layout.visible_markers`) in the camera's image — the lens's
  distorted one when ``distortion`` is given (a barrel lens shows markers past the
  pinhole image's edge, as the render does); chosen stops are also rendered and
  detected (:func:`execute_stops`).
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import invert_transform, matrix_from_rotvec

__all__ = ["Candidates", "SelfCollision", "candidates", "joint_candidates", "view_quality",
           "stop_state", "execute_stops", "reference_index", "ROOM_MARGIN_M", "RANGES"]

ROOM_MARGIN_M = 0.05
CART_ROOM_MARGIN_M = 0.3

#: ``(max rotation deg, max translation m)`` of the drawn stops, per range and platform:
#: ``"jog"`` — the moves a user adds without advice (flange rotated up to 40 deg about an
#: axis, moved up to 15 cm; cart yaw +-90 deg, 1 m): the random baseline of
#: :func:`simcalib.studies.advise.verify`; ``"wide"`` — what the planner searches (the arm's flange
#: rotated up to 90 deg, moved up to 30 cm; the same cart moves): advice includes *how far*
#: to move, within what IK, limits, collisions and the markers allow.
RANGES = {"jog": {"arm": (40.0, 0.15), "cart": (90.0, 1.0)},
          "wide": {"arm": (90.0, 0.30), "cart": (90.0, 1.0)}}


@dataclass(frozen=True)
class Candidates:
    """``N`` candidate stops (all arrays aligned, feasible or not).

    ``rotvec_world_rad`` / ``dp_world_m`` ``(N, 3)``: the move of the target frame from the
    reference; ``T_world_target`` ``(N, 4, 4)``; ``qpos`` ``(N, nq)``, ``mocap_pos``,
    ``mocap_quat_wxyz``: the MuJoCo state at the stop; ``T_world_cam``: camera ->
    ``(N, 4, 4)`` true camera poses; ``motion``: camera -> ``(N, 4, 4)`` relative motion of
    the camera (``inv(T_ref) @ T``); ``ik_pos_error_m`` / ``ik_rot_error_rad`` ``(N,)``;
    ``visible``: camera -> ``(N,)`` marker counts (ArUco cameras only); ``feasible`` ``(N,)``;
    ``reason``: why each infeasible one was rejected ("" when feasible). ``ref``: the
    reference state (``qpos``, ``mocap_pos``, ``mocap_quat_wxyz``, ``T_world_target``,
    ``T_world_cam``)."""
    platform: str
    rotvec_world_rad: np.ndarray
    dp_world_m: np.ndarray
    T_world_target: np.ndarray
    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat_wxyz: np.ndarray
    T_world_cam: dict
    motion: dict
    ik_pos_error_m: np.ndarray
    ik_rot_error_rad: np.ndarray
    visible: dict
    feasible: np.ndarray
    reason: tuple
    ref: dict

    @property
    def n(self) -> int:
        return int(self.feasible.shape[0])

    def take(self, idx) -> "Candidates":
        """The candidates at ``idx`` (same reference)."""
        idx = np.asarray(idx, dtype=np.int64)
        sub = {k: v[idx] for k, v in (("rotvec_world_rad", self.rotvec_world_rad),
                                       ("dp_world_m", self.dp_world_m),
                                       ("T_world_target", self.T_world_target),
                                       ("qpos", self.qpos), ("mocap_pos", self.mocap_pos),
                                       ("mocap_quat_wxyz", self.mocap_quat_wxyz),
                                       ("ik_pos_error_m", self.ik_pos_error_m),
                                       ("ik_rot_error_rad", self.ik_rot_error_rad),
                                       ("feasible", self.feasible))}
        return dataclasses.replace(
            self, **sub, T_world_cam={c: v[idx] for c, v in self.T_world_cam.items()},
            motion={c: v[idx] for c, v in self.motion.items()},
            visible={c: v[idx] for c, v in self.visible.items()},
            reason=tuple(self.reason[i] for i in idx))


def reference_index(world) -> int:
    """Index of the frame of camera b used as the reference stop (the last frame)."""
    return int(world.frames("cam_b").n_frames - 1)


def _site_pose(model, data, site) -> np.ndarray:
    import mujoco
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    T = np.eye(4)
    T[:3, :3] = data.site_xmat[sid].reshape(3, 3)
    T[:3, 3] = data.site_xpos[sid]
    return T


def _collision_model(model):
    """A copy of ``model`` with collisions enabled between the platform's and the rig's geoms
    (``arm/*``, ``rig/*`` bodies, the pedestal); returns (model copy, mask of those geoms)."""
    import mujoco
    m = copy.deepcopy(model)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or ""
             for b in m.geom_bodyid]
    gnames = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(m.ngeom)]
    mask = np.array([n.startswith(("arm/", "rig/")) or g == "arm_pedestal"
                     for n, g in zip(names, gnames)])
    m.geom_contype[:] = 0
    m.geom_conaffinity[:] = 0
    m.geom_contype[mask] = 1
    m.geom_conaffinity[mask] = 1
    # the broad phase uses per-body masks computed at compile time (OR over their geoms)
    for attr in ("body_contype", "body_conaffinity"):
        if hasattr(m, attr):
            arr = getattr(m, attr)
            arr[:] = 0
            arr[np.unique(m.geom_bodyid[mask])] = 1
    return m, mask


def _contact_pairs(m, d, qpos) -> set:
    import mujoco
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    pairs = set()
    for i in range(d.ncon):
        c = d.contact[i]
        if c.dist < -1e-4:
            pairs.add((min(c.geom1, c.geom2), max(c.geom1, c.geom2)))
    return pairs


class SelfCollision:
    """Self-collision check of a platform model: ``SelfCollision(model, q_allowed)(q)`` ->
    names of the geom pairs in contact at ``q`` (arm, pedestal and rig geoms), except those
    already in contact at ``q_allowed`` (allowed-collision pairs)."""

    def __init__(self, model, q_allowed=None):
        import mujoco
        self.model, _ = _collision_model(model)
        self.data = mujoco.MjData(self.model)
        self.allowed = set() if q_allowed is None else _contact_pairs(self.model, self.data,
                                                                      q_allowed)

    def __call__(self, q) -> list:
        import mujoco
        hits = _contact_pairs(self.model, self.data, np.asarray(q, dtype=np.float64))
        return [tuple(mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in p)
                for p in sorted(hits - self.allowed)]


def _camera_ids(model, cameras):
    import mujoco
    return [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, c) for c in cameras]


def _inside_room(cfg, p, margin):
    size = np.asarray(cfg.room.size_m, dtype=np.float64)
    half = 0.5 * size
    return ((np.abs(p[..., 0]) <= half[0] - margin) & (np.abs(p[..., 1]) <= half[1] - margin)
            & (p[..., 2] >= margin) & (p[..., 2] <= size[2] - margin))


def _reference(world):
    """MjData at the reference stop, its state, frame index, target pose and camera poses."""
    import mujoco
    from simcalib.world.simulate import camera_poses_from_state
    platform = world.config.platform
    model = world.model
    cams = tuple(world.camera_names)
    fr = world.frames("cam_b")
    k_ref = reference_index(world)
    q_ref = np.asarray(fr.qpos[k_ref], dtype=np.float64)
    mp_ref = np.asarray(fr.mocap_pos[k_ref], dtype=np.float64)
    mq_ref = np.asarray(fr.mocap_quat_wxyz[k_ref], dtype=np.float64)
    data = mujoco.MjData(model)
    data.qpos[:] = q_ref
    if model.nmocap:
        data.mocap_pos[:] = mp_ref
        data.mocap_quat[:] = mq_ref
    mujoco.mj_kinematics(model, data)
    site = world.scene.mount_site
    if platform == "arm":
        T_ref_target = _site_pose(model, data, site)
    else:
        from simcalib.geometry import matrix_from_quat, quat_xyzw_from_wxyz
        T_ref_target = np.eye(4)
        T_ref_target[:3, :3] = matrix_from_quat(quat_xyzw_from_wxyz(mq_ref[0]))
        T_ref_target[:3, 3] = mp_ref[0]
    cam_ids = _camera_ids(model, cams)
    T_ref_cam = camera_poses_from_state(model, q_ref[None], mp_ref[None], mq_ref[None])[0]
    T_ref_cam = {c: T_ref_cam[i] for c, i in zip(cams, cam_ids)}

    return data, q_ref, mp_ref, mq_ref, k_ref, T_ref_target, T_ref_cam


def candidates(world, n: int, rng: np.random.Generator, *, aruco_cameras=(),
               max_rotation_deg: float | None = None, max_translation_m: float | None = None,
               min_rotation_deg: float = 5.0, min_markers: int = 4,
               ranges: str = "jog", distortion=None) -> Candidates:
    """``n`` random candidate stops around the world's reference pose, with feasibility.

    Arm: rotation about a uniform axis by an angle uniform in ``[min_rotation_deg,
    max_rotation_deg]`` and a translation uniform in a ball of radius
    ``max_translation_m``. Cart: yaw uniform in +-``max_rotation_deg`` and a planar
    translation in a disc of radius ``max_translation_m``; roll, pitch and height are not
    drivable. Unset maxima come from ``RANGES[ranges]`` (``"jog"``: arm 40 deg / 0.15 m,
    cart 90 deg / 1 m; ``"wide"``: arm 90 deg / 0.30 m). ``aruco_cameras``: the cameras
    whose poses come from the marker field (visibility checked); ``distortion``: their
    lens (k1, k2, p1, p2, k3, e.g. ``VisionConfig.effects().distortion``; default none:
    pinhole), the markers counted in the distorted image."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1; received {n!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    if ranges not in RANGES:
        raise ValueError(f"ranges must be one of {sorted(RANGES)}; received {ranges!r}")
    cfg = world.config
    platform = cfg.platform
    if platform not in ("arm", "cart"):
        raise ValueError(f"motion advice supports platforms 'arm' and 'cart'; received "
                         f"{platform!r}")
    default_r, default_t = RANGES[ranges][platform]
    model = world.model
    data, q_ref, mp_ref, mq_ref, k_ref, T_ref_target, T_ref_cam = _reference(world)
    site = world.scene.mount_site

    # ---- draw the moves
    if platform == "arm":
        max_r = default_r if max_rotation_deg is None else float(max_rotation_deg)
        max_t = default_t if max_translation_m is None else float(max_translation_m)
        axis = rng.standard_normal((n, 3))
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        ang = np.deg2rad(rng.uniform(min(min_rotation_deg, max_r), max_r, n))
        omega = axis * ang[:, None]
        d = rng.standard_normal((n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        dp = d * (max_t * rng.random(n) ** (1 / 3))[:, None]
    else:
        max_r = default_r if max_rotation_deg is None else float(max_rotation_deg)
        max_t = default_t if max_translation_m is None else float(max_translation_m)
        yaw = np.deg2rad(rng.uniform(-max_r, max_r, n))
        omega = np.zeros((n, 3))
        omega[:, 2] = yaw
        phi = rng.uniform(0, 2 * np.pi, n)
        r = max_t * np.sqrt(rng.random(n))
        dp = np.stack([r * np.cos(phi), r * np.sin(phi), np.zeros(n)], axis=1)
    T_t = np.zeros((n, 4, 4))
    T_t[:, :3, :3] = matrix_from_rotvec(omega) @ T_ref_target[:3, :3]
    T_t[:, :3, 3] = T_ref_target[:3, 3] + dp
    T_t[:, 3, 3] = 1.0

    reason = [""] * n
    ep = np.zeros(n)
    er = np.zeros(n)
    if platform == "arm":
        from simcalib.world.ik import solve_ik
        ik = cfg.ik
        qpos = np.zeros((n, model.nq))
        collide = SelfCollision(model, q_ref)
        lim = model.jnt_limited.astype(bool)
        lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
        for i in range(n):
            q, ep[i], er[i], _ = solve_ik(model, data, site, T_t[i], q_ref, damping=ik.damping,
                                          max_iter=ik.max_iter, tol_pos_m=ik.tol_pos_m,
                                          tol_rot_rad=ik.tol_rot_rad)
            qpos[i] = q
            if ep[i] > ik.fail_pos_m or er[i] > ik.fail_rot_rad:
                reason[i] = (f"IK does not reach it ({ep[i] * 1e3:.3g} mm, "
                             f"{np.rad2deg(er[i]):.3g} deg)")
                continue
            if (lim & ((q < lo - 1e-9) | (q > hi + 1e-9))).any():
                reason[i] = "joint limit"
                continue
            hits = collide(q)
            if hits:
                reason[i] = f"self-collision ({hits[0][0]} / {hits[0][1]})"
        mocap_pos = np.repeat(mp_ref[None], n, axis=0)
        mocap_quat = np.repeat(mq_ref[None], n, axis=0)
    else:
        from simcalib.world.platforms import get_platform
        mot = get_platform("cart").drive(world.scene, T_t, np.arange(n, dtype=float), cfg)
        qpos, mocap_pos, mocap_quat = mot.qpos, mot.mocap_pos, mot.mocap_quat_wxyz
    return _finish(world, platform, omega, dp, T_t, qpos, mocap_pos, mocap_quat, ep, er,
                   reason, aruco_cameras, min_markers, T_ref_cam, q_ref, mp_ref, mq_ref,
                   T_ref_target, k_ref, distortion)


def _finish(world, platform, omega, dp, T_t, qpos, mocap_pos, mocap_quat, ep, er, reason,
            aruco_cameras, min_markers, T_ref_cam, q_ref, mp_ref, mq_ref, T_ref_target, k_ref,
            distortion):
    """Room and marker checks, camera poses and motions of drawn stops -> Candidates."""
    from simcalib.world.layout import visible_markers
    from simcalib.world.simulate import camera_poses_from_state
    model, cfg, cams = world.model, world.config, tuple(world.camera_names)
    cam_ids = _camera_ids(model, cams)
    Tc = camera_poses_from_state(model, qpos, mocap_pos, mocap_quat)
    T_world_cam = {c: Tc[:, i] for c, i in zip(cams, cam_ids)}
    margin = ROOM_MARGIN_M if platform == "arm" else CART_ROOM_MARGIN_M
    for c in cams:
        out = ~_inside_room(cfg, T_world_cam[c][:, :3, 3], margin)
        for i in np.flatnonzero(out):
            reason[i] = reason[i] or f"{c} leaves the room"
    visible = {}
    for c in aruco_cameras:
        v = visible_markers(world.marker_field, T_world_cam[c], world.intrinsics[c],
                            distortion=distortion).sum(axis=1)
        visible[c] = v.astype(np.int64)
        for i in np.flatnonzero(v < min_markers):
            reason[i] = reason[i] or f"{c} sees {int(v[i])} < {min_markers} markers"
    motion = {c: invert_transform(T_ref_cam[c]) @ T_world_cam[c] for c in cams}
    feasible = np.array([r == "" for r in reason])
    ref = {"qpos": q_ref, "mocap_pos": mp_ref, "mocap_quat_wxyz": mq_ref,
           "T_world_target": T_ref_target, "T_world_cam": T_ref_cam, "frame": k_ref}
    return Candidates(platform=platform, rotvec_world_rad=omega, dp_world_m=dp,
                      T_world_target=T_t, qpos=qpos, mocap_pos=mocap_pos,
                      mocap_quat_wxyz=mocap_quat, T_world_cam=T_world_cam, motion=motion,
                      ik_pos_error_m=ep, ik_rot_error_rad=er, visible=visible,
                      feasible=feasible, reason=tuple(reason), ref=ref)


def joint_candidates(world, n: int, rng: np.random.Generator, *, aruco_cameras=(),
                     max_joint_deg: float = 20.0, min_markers: int = 4,
                     distortion=None) -> Candidates:
    """``n`` stops an arm reaches by jogging its joints: every hinge joint moved from the
    reference by an angle uniform in +-``max_joint_deg`` (what a user adds without advice:
    random joint perturbations around the current pose), with the same feasibility checks
    as :func:`candidates` (joint limits, self-collision, room, markers seen through
    ``distortion``). Used as the
    random baseline of :func:`simcalib.studies.advise.verify`; the cart has no joints to jog
    (use :func:`candidates`)."""
    import mujoco
    from simcalib.geometry import rotvec_from_matrix
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1; received {n!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    if not (isinstance(max_joint_deg, (int, float)) and 0 < max_joint_deg <= 180):
        raise ValueError(f"max_joint_deg must be in (0, 180]; received {max_joint_deg!r}")
    cfg = world.config
    if cfg.platform != "arm":
        raise ValueError(f"joint_candidates needs platform 'arm'; received {cfg.platform!r}")
    model = world.model
    data, q_ref, mp_ref, mq_ref, k_ref, T_ref_target, T_ref_cam = _reference(world)
    site = world.scene.mount_site
    hinge = np.zeros(model.nq, bool)
    for j in range(model.njnt):
        if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE):
            hinge[int(model.jnt_qposadr[j])] = True
    qpos = np.repeat(q_ref[None], n, axis=0)
    qpos[:, hinge] += np.deg2rad(rng.uniform(-max_joint_deg, max_joint_deg,
                                             (n, int(hinge.sum()))))
    lim = model.jnt_limited.astype(bool)
    lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
    adr = model.jnt_qposadr
    collide = SelfCollision(model, q_ref)
    reason = [""] * n
    T_t = np.zeros((n, 4, 4))
    for i in range(n):
        data.qpos[:] = qpos[i]
        mujoco.mj_kinematics(model, data)
        T_t[i] = _site_pose(model, data, site)
        q = qpos[i][adr]
        if (lim & ((q < lo - 1e-9) | (q > hi + 1e-9))).any():
            reason[i] = "joint limit"
            continue
        hits = collide(qpos[i])
        if hits:
            reason[i] = f"self-collision ({hits[0][0]} / {hits[0][1]})"
    omega = rotvec_from_matrix(T_t[:, :3, :3] @ T_ref_target[:3, :3].T)
    dp = T_t[:, :3, 3] - T_ref_target[:3, 3]
    return _finish(world, "arm", omega, dp, T_t, qpos, np.repeat(mp_ref[None], n, axis=0),
                   np.repeat(mq_ref[None], n, axis=0), np.zeros(n), np.zeros(n), reason,
                   aruco_cameras, min_markers, T_ref_cam, q_ref, mp_ref, mq_ref,
                   T_ref_target, k_ref, distortion)


def view_quality(world, T_world_cam, camera: str, distortion=None) -> np.ndarray:
    """``(N,)`` quality of camera ``camera``'s view of the marker field at poses
    ``T_world_cam`` ``(N, 4, 4)``: ``sqrt(sum of squared shortest projected edges, px)`` of
    the markers fully visible (0 when none). A marker's PnP pose error scales roughly with
    1 / (its size in pixels), and the errors of several markers average, so the variance
    of the camera pose scales roughly with ``1 / quality**2``: far, oblique views with few
    markers are noisier. ``distortion`` (k1, k2, p1, p2, k3; default none): the markers
    and edges of the lens's distorted image (a barrel lens shows more markers, smaller
    towards the edge)."""
    from simcalib.world.layout import marker_views
    vis, edges = marker_views(world.marker_field, T_world_cam, world.intrinsics[camera],
                              distortion=distortion)
    return np.sqrt(np.sum(np.where(vis, edges, 0.0) ** 2, axis=1))


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
    ids = _camera_ids(world.model, world.camera_names)
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
        res = get_source(name, truth.kind).measure(t2, _stop_config(cfg), r, tuple(cams))
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


def _stop_config(cfg):
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
