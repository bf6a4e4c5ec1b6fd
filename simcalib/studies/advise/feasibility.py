"""Feasible candidate motions of a platform (the chosen stops are measured by
:mod:`simcalib.studies.advise.stops`).

A *candidate* is a stop: the platform's target frame (arm flange / cart base) moved from a
reference pose ``T_world_target_ref`` (the last pose of the recorded run) to
``T_world_target = Trans(p_ref + dp) · R(omega) · R_ref`` (rotation ``omega`` about world
axes through the target, as the scripted paths do). Stops are visited in order (stop and
go); the motion a stop adds to the calibration data is the relative motion of each camera
from the previous stop (``motion`` holds the one from the reference).

Feasibility:

* the rotations the platform makes: about any axis for a 6-DoF arm, about the vertical
  only for a cart and for an arm standing in for a SCARA (``world.arm.motions='scara'``:
  it translates in 3D and yaws; :func:`rotation_axes`);
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
  detected (:func:`simcalib.studies.advise.stops.execute_stops`).
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from simcalib.geometry import invert_transform, matrix_from_rotvec

__all__ = ["Candidates", "Reference", "SelfCollision", "candidates", "joint_candidates",
           "view_quality", "rotation_axes", "tilt_hint", "lens_distortion", "camera_ids",
           "reference_index", "ROOM_MARGIN_M", "RANGES"]

ROOM_MARGIN_M = 0.05
CART_ROOM_MARGIN_M = 0.3

#: ``(max rotation deg, max translation m)`` of the drawn stops, per range and platform:
#: ``"jog"`` — the moves a user adds without advice (flange rotated up to 40 deg about an
#: axis, moved up to 15 cm; cart yaw +-90 deg, 1 m): the random baseline of
#: :func:`simcalib.studies.advise.verification.verify`; ``"wide"`` — what the planner
#: searches (the arm's flange rotated up to 90 deg, moved up to 30 cm; the same cart
#: moves): advice includes *how far* to move, within what IK, limits, collisions and the
#: markers allow. An arm standing in for a SCARA rotates by the same angles about the
#: vertical only (:func:`rotation_axes`).
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


def camera_ids(model, cameras) -> list:
    """MuJoCo ids of the cameras named ``cameras``."""
    import mujoco
    return [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, c) for c in cameras]


def _inside_room(cfg, p, margin):
    size = np.asarray(cfg.room.size_m, dtype=np.float64)
    half = 0.5 * size
    return ((np.abs(p[..., 0]) <= half[0] - margin) & (np.abs(p[..., 1]) <= half[1] - margin)
            & (p[..., 2] >= margin) & (p[..., 2] <= size[2] - margin))


class Reference(NamedTuple):
    """The reference stop (the last frame of the recorded run): an ``MjData`` posed there,
    the MuJoCo state (``qpos``, ``mocap_pos``, ``mocap_quat_wxyz``), its ``frame`` index,
    the target frame's pose and each camera's pose."""
    data: object
    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat_wxyz: np.ndarray
    frame: int
    T_world_target: np.ndarray
    T_world_cam: dict


def _reference(world) -> Reference:
    """The world's :class:`Reference` stop."""
    import mujoco
    from simcalib.world.simulate import camera_poses_from_state
    model = world.model
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
    if world.config.platform == "arm":
        T_ref_target = _site_pose(model, data, world.scene.mount_site)
    else:
        from simcalib.geometry import matrix_from_quat, quat_xyzw_from_wxyz
        T_ref_target = np.eye(4)
        T_ref_target[:3, :3] = matrix_from_quat(quat_xyzw_from_wxyz(mq_ref[0]))
        T_ref_target[:3, 3] = mp_ref[0]
    cams = tuple(world.camera_names)
    T_cam = camera_poses_from_state(model, q_ref[None], mp_ref[None], mq_ref[None])[0]
    T_ref_cam = {c: T_cam[i] for c, i in zip(cams, camera_ids(model, cams))}
    return Reference(data, q_ref, mp_ref, mq_ref, k_ref, T_ref_target, T_ref_cam)


def rotation_axes(cfg) -> str:
    """The rotations a platform makes at a stop (``cfg`` its WorldConfig): ``"any"`` axis
    (a 6-DoF arm) or the ``"vertical"`` only (a cart's yaw; an arm standing in for a SCARA,
    ``world.arm.motions='scara'``)."""
    if cfg.platform == "arm" and cfg.arm.motions != "scara":
        return "any"
    return "vertical"


#: how an arm standing in for a SCARA could rotate about another axis (the example in the
#: fix of a direction it cannot determine; a cart's is the information module's default)
TILT_HINT_SCARA = ("a SCARA rotates about the vertical only: e.g. a session with the camera "
                   "on a 6-DoF arm")


def tilt_hint(cfg) -> str | None:
    """How the platform of ``cfg`` (a WorldConfig) could rotate about another axis than the
    vertical, for the fix of a direction it cannot determine (None: the default, a
    cart's)."""
    return TILT_HINT_SCARA if cfg.platform == "arm" and rotation_axes(cfg) != "any" else None


def lens_distortion(run_cfg) -> "np.ndarray | None":
    """The ArUco cameras' lens distortion (k1, k2, p1, p2, k3) of the run's vision
    configuration (what the render images through), None without a run configuration:
    the candidates' visibility and view quality are judged in the image the camera sees."""
    return None if run_cfg is None else np.asarray(run_cfg.vision.effects().distortion,
                                                   dtype=np.float64)


def _check_draw(n, rng, ranges, platform) -> None:
    """ValueError / TypeError for a bad draw of :func:`candidates`."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1; received {n!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    if ranges not in RANGES:
        raise ValueError(f"ranges must be one of {sorted(RANGES)}; received {ranges!r}")
    if platform not in ("arm", "cart"):
        raise ValueError(f"motion advice supports platforms 'arm' and 'cart'; received "
                         f"{platform!r}")


def _unit_rows(rng, n) -> np.ndarray:
    d = rng.standard_normal((n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _draw_moves(platform, axes, n, rng, max_r, max_t, min_r) -> tuple:
    """``(omega (n, 3) rad, dp (n, 3) m)``: world rotation vectors and moves of the target.
    Arm, any axis: a uniform axis, an angle uniform in ``[min_r, max_r]`` deg, a move
    uniform in a ball; arm, vertical axis (SCARA): the same angle about +-z, the same ball;
    cart: yaw uniform in +-``max_r``, a move uniform in a horizontal disc."""
    if platform == "arm":
        if axes == "any":
            axis = _unit_rows(rng, n)
        else:
            axis = np.zeros((n, 3))
            axis[:, 2] = rng.choice([-1.0, 1.0], n)
        ang = np.deg2rad(rng.uniform(min(min_r, max_r), max_r, n))
        dp = _unit_rows(rng, n) * (max_t * rng.random(n) ** (1 / 3))[:, None]
        return axis * ang[:, None], dp
    omega = np.zeros((n, 3))
    omega[:, 2] = np.deg2rad(rng.uniform(-max_r, max_r, n))
    phi = rng.uniform(0, 2 * np.pi, n)
    r = max_t * np.sqrt(rng.random(n))
    return omega, np.stack([r * np.cos(phi), r * np.sin(phi), np.zeros(n)], axis=1)


def candidates(world, n: int, rng: np.random.Generator, *, aruco_cameras=(),
               max_rotation_deg: float | None = None, max_translation_m: float | None = None,
               min_rotation_deg: float = 5.0, min_markers: int = 4,
               ranges: str = "jog", distortion=None) -> Candidates:
    """``n`` random candidate stops around the world's reference pose, with feasibility.

    Arm: rotation about a uniform axis — about the vertical only for an arm standing in for
    a SCARA (``world.arm.motions='scara'``, :func:`rotation_axes`) — by an angle uniform in
    ``[min_rotation_deg, max_rotation_deg]`` and a translation uniform in a ball of radius
    ``max_translation_m``. Cart: yaw uniform in +-``max_rotation_deg`` and a planar
    translation in a disc of radius ``max_translation_m``; roll, pitch and height are not
    drivable. Unset maxima come from ``RANGES[ranges]`` (``"jog"``: arm 40 deg / 0.15 m,
    cart 90 deg / 1 m; ``"wide"``: arm 90 deg / 0.30 m). ``aruco_cameras``: the cameras
    whose poses come from the marker field (visibility checked); ``distortion``: their
    lens (k1, k2, p1, p2, k3, e.g. ``VisionConfig.effects().distortion``; default none:
    pinhole), the markers counted in the distorted image."""
    cfg = world.config
    _check_draw(n, rng, ranges, cfg.platform)
    default_r, default_t = RANGES[ranges][cfg.platform]
    max_r = default_r if max_rotation_deg is None else float(max_rotation_deg)
    max_t = default_t if max_translation_m is None else float(max_translation_m)
    ref = _reference(world)
    omega, dp = _draw_moves(cfg.platform, rotation_axes(cfg), n, rng, max_r, max_t,
                            min_rotation_deg)
    T_t = np.zeros((n, 4, 4))
    T_t[:, :3, :3] = matrix_from_rotvec(omega) @ ref.T_world_target[:3, :3]
    T_t[:, :3, 3] = ref.T_world_target[:3, 3] + dp
    T_t[:, 3, 3] = 1.0
    if cfg.platform == "arm":
        states = _arm_states(world, ref, T_t)
    else:
        from simcalib.world.platforms import get_platform
        mot = get_platform("cart").drive(world.scene, T_t, np.arange(n, dtype=float), cfg)
        states = (mot.qpos, mot.mocap_pos, mot.mocap_quat_wxyz, np.zeros(n), np.zeros(n),
                  [""] * n)
    return _finish(world, ref, omega, dp, T_t, states, aruco_cameras, min_markers, distortion)


def _arm_states(world, ref: Reference, T_t) -> tuple:
    """``(qpos, mocap_pos, mocap_quat, ik position error, ik rotation error, reason)`` of
    the arm at the target poses ``T_t`` (IK from the reference joints; reason: why each
    is infeasible — IK, joint limit, self-collision — "" when it is not)."""
    from simcalib.world.ik import solve_ik
    model, ik, n = world.model, world.config.ik, T_t.shape[0]
    qpos, ep, er, reason = np.zeros((n, model.nq)), np.zeros(n), np.zeros(n), [""] * n
    collide = SelfCollision(model, ref.qpos)
    lim = model.jnt_limited.astype(bool)
    lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
    for i in range(n):
        q, ep[i], er[i], _ = solve_ik(model, ref.data, world.scene.mount_site, T_t[i],
                                      ref.qpos, damping=ik.damping, max_iter=ik.max_iter,
                                      tol_pos_m=ik.tol_pos_m, tol_rot_rad=ik.tol_rot_rad)
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
    return (qpos, np.repeat(ref.mocap_pos[None], n, axis=0),
            np.repeat(ref.mocap_quat_wxyz[None], n, axis=0), ep, er, reason)


def _finish(world, ref: Reference, omega, dp, T_t, states, aruco_cameras, min_markers,
            distortion) -> Candidates:
    """Room and marker checks, camera poses and motions of drawn stops -> Candidates
    (``states``: qpos, mocap_pos, mocap_quat, IK errors and reasons of :func:`_arm_states`)."""
    from simcalib.world.layout import visible_markers
    from simcalib.world.simulate import camera_poses_from_state
    qpos, mocap_pos, mocap_quat, ep, er, reason = states
    model, cfg, cams = world.model, world.config, tuple(world.camera_names)
    Tc = camera_poses_from_state(model, qpos, mocap_pos, mocap_quat)
    T_world_cam = {c: Tc[:, i] for c, i in zip(cams, camera_ids(model, cams))}
    margin = ROOM_MARGIN_M if cfg.platform == "arm" else CART_ROOM_MARGIN_M
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
    motion = {c: invert_transform(ref.T_world_cam[c]) @ T_world_cam[c] for c in cams}
    refd = {"qpos": ref.qpos, "mocap_pos": ref.mocap_pos,
            "mocap_quat_wxyz": ref.mocap_quat_wxyz, "T_world_target": ref.T_world_target,
            "T_world_cam": ref.T_world_cam, "frame": ref.frame}
    return Candidates(platform=cfg.platform, rotvec_world_rad=omega, dp_world_m=dp,
                      T_world_target=T_t, qpos=qpos, mocap_pos=mocap_pos,
                      mocap_quat_wxyz=mocap_quat, T_world_cam=T_world_cam, motion=motion,
                      ik_pos_error_m=ep, ik_rot_error_rad=er, visible=visible,
                      feasible=np.array([r == "" for r in reason]), reason=tuple(reason),
                      ref=refd)


def joint_candidates(world, n: int, rng: np.random.Generator, *, aruco_cameras=(),
                     max_joint_deg: float = 20.0, min_markers: int = 4,
                     distortion=None) -> Candidates:
    """``n`` stops an arm reaches by jogging its joints: every hinge joint moved from the
    reference by an angle uniform in +-``max_joint_deg`` (what a user adds without advice:
    random joint perturbations around the current pose), with the same feasibility checks
    as :func:`candidates` (joint limits, self-collision, room, markers seen through
    ``distortion``). Used as the random baseline of
    :func:`simcalib.studies.advise.verification.verify`; the cart has no joints to jog, and
    jogging the UR5e's six joints tilts the flange, which an arm standing in for a SCARA
    cannot (both: use :func:`candidates`)."""
    import mujoco
    from simcalib.geometry import rotvec_from_matrix
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1; received {n!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    if not (isinstance(max_joint_deg, (int, float)) and 0 < max_joint_deg <= 180):
        raise ValueError(f"max_joint_deg must be in (0, 180]; received {max_joint_deg!r}")
    cfg = world.config
    if cfg.platform != "arm" or rotation_axes(cfg) != "any":
        raise ValueError(f"joint_candidates needs a 6-DoF arm (platform 'arm', arm.motions "
                         f"'6dof'); received platform {cfg.platform!r}, motions "
                         f"{cfg.arm.motions!r}")
    model = world.model
    ref = _reference(world)
    hinge = np.zeros(model.nq, bool)
    for j in range(model.njnt):
        if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE):
            hinge[int(model.jnt_qposadr[j])] = True
    qpos = np.repeat(ref.qpos[None], n, axis=0)
    qpos[:, hinge] += np.deg2rad(rng.uniform(-max_joint_deg, max_joint_deg,
                                             (n, int(hinge.sum()))))
    T_t, reason = _jog_states(world, ref, qpos)
    omega = rotvec_from_matrix(T_t[:, :3, :3] @ ref.T_world_target[:3, :3].T)
    dp = T_t[:, :3, 3] - ref.T_world_target[:3, 3]
    states = (qpos, np.repeat(ref.mocap_pos[None], n, axis=0),
              np.repeat(ref.mocap_quat_wxyz[None], n, axis=0), np.zeros(n), np.zeros(n), reason)
    return _finish(world, ref, omega, dp, T_t, states, aruco_cameras, min_markers, distortion)


def _jog_states(world, ref: Reference, qpos) -> tuple[np.ndarray, list]:
    """``(T_world_target (n, 4, 4), reason)`` of the joint states ``qpos``: the flange pose
    and why each is infeasible (joint limit, self-collision; "" when it is not)."""
    import mujoco
    model, data, n = world.model, ref.data, qpos.shape[0]
    lim = model.jnt_limited.astype(bool)
    lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
    collide = SelfCollision(model, ref.qpos)
    reason = [""] * n
    T_t = np.zeros((n, 4, 4))
    for i in range(n):
        data.qpos[:] = qpos[i]
        mujoco.mj_kinematics(model, data)
        T_t[i] = _site_pose(model, data, world.scene.mount_site)
        q = qpos[i][model.jnt_qposadr]
        if (lim & ((q < lo - 1e-9) | (q > hi + 1e-9))).any():
            reason[i] = "joint limit"
            continue
        hits = collide(qpos[i])
        if hits:
            reason[i] = f"self-collision ({hits[0][0]} / {hits[0][1]})"
    return T_t, reason


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


