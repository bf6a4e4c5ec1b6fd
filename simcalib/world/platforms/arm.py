"""Platform ``arm``: a UR5e on a pedestal whose flange carries the rig and is the target
frame; the path is turned into joint angles by IK.

``world.arm.control`` chooses how the joint path is executed:

* ``kinematic`` (default): the arm is *posed* at the IK solution of every capture time;
  the flange is exactly on the path (the clean case).
* ``physics``: the IK joint path (solved at 100 Hz over the run) is the reference of
  torque-limited PD joint servos in MuJoCo physics
  (:func:`simcalib.world.arm_control.track_joint_path`, gains scaled by
  ``world.arm.gain_scale``); the flange lags, overshoots and settles, and the cameras'
  ground truth is where the simulated arm really is at each capture time (its joint
  samples at 500 Hz, interpolated). ``world.arm.capture=continuous`` captures while
  moving at ``k / fps``; ``stop_and_go`` stops the path at every frame and captures when
  the arm has settled (the frames keep the path clock ``k / fps``; the robot's own,
  longer clock is in ``World.platform_record``).

Why one platform with a control mode rather than a second platform ``arm_physics``: the
arm, its mount, home pose, workspace and the paths it supports (with their per-platform
parameters in the path registry) are the same; only the execution differs. A second
platform would duplicate every path's ``arm`` defaults and double the platform x path
matrix for no new geometry, and a scenario switches between ideal and real execution with
one key (``world.arm.control=physics``).

The built-in model is ``models/ur5e.xml`` (UR5e DH kinematics, primitive geoms);
``world.arm_model=menagerie`` loads the Menagerie UR5e from ``$MENAGERIE_ROOT``. The
physics arm is the arm model alone (the rig's small mass is not in its dynamics)."""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import numpy as np

from simcalib.world.platforms.base import PlatformInfo, PlatformMotion
from simcalib.world.platforms.registry import register
from simcalib.world.layout import ARM_HOME_OFFSET_M, arm_base_position

__all__ = ["ArmPlatform", "REFERENCE_RATE_HZ", "ARM_HOME_SEED", "R_WORLD_RIG_FORWARD",
           "PEDESTAL_HEIGHT_M", "MENAGERIE_UR5E"]

#: ``home_qpos`` (the flange at ``ARM_HOME_OFFSET_M``, simcalib.world.layout) is solved by IK
#: from this seed (elbow up, wrist away from the cameras' view).
ARM_HOME_SEED = np.array([0.3005, -1.8099, -1.9046, 0.5729, 1.2703, 0.0])
#: The rig frame in world axes when looking along +x: x = -y_w, y = -z_w, z = +x_w.
R_WORLD_RIG_FORWARD = np.column_stack([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
#: Height of the arm's pedestal (the built-in model has it; added for Menagerie arms).
PEDESTAL_HEIGHT_M = 0.6
#: Menagerie file of the optional arm model, relative to ``$MENAGERIE_ROOT``.
MENAGERIE_UR5E = Path("universal_robots_ur5e") / "ur5e.xml"


def _arm_spec(arm_model: str):
    """``(MjSpec, mount site name)`` of the arm: the built-in UR5e (models/ur5e.xml) or
    the Menagerie UR5e under ``$MENAGERIE_ROOT`` (its tool flange site
    ``attachment_site``; added on ``wrist_3_link`` if the file predates it)."""
    import mujoco
    from simcalib.world.scene import MODELS_DIR
    if arm_model == "builtin":
        return mujoco.MjSpec.from_file(str(MODELS_DIR / "ur5e.xml")), "rig_mount"
    if arm_model != "menagerie":
        raise ValueError(f"arm_model must be 'builtin' or 'menagerie'; received {arm_model!r}")
    root = os.environ.get("MENAGERIE_ROOT")
    if not root:
        raise ValueError("arm_model='menagerie' needs the environment variable MENAGERIE_ROOT "
                         "pointing at a local copy of mujoco_menagerie (expected file "
                         f"$MENAGERIE_ROOT/{MENAGERIE_UR5E.as_posix()}); or use "
                         "arm_model='builtin'")
    path = Path(root).expanduser() / MENAGERIE_UR5E
    if not path.is_file():
        raise ValueError(f"MENAGERIE_ROOT={root!r} has no {MENAGERIE_UR5E.as_posix()} "
                         f"(looked for {path}); point it at a mujoco_menagerie checkout")
    spec = mujoco.MjSpec.from_file(str(path))
    for light in spec.lights:                # no shadows in camera renders
        light.castshadow = False
    if spec.site("attachment_site") is None:
        wrist = spec.body("wrist_3_link")
        if wrist is None:
            raise ValueError(f"{path} has neither site 'attachment_site' nor body "
                             "'wrist_3_link'; not a Menagerie UR5e model")
        wrist.add_site(name="attachment_site", pos=[0.0, 0.1, 0.0],
                       quat=[-0.7071067811865476, 0.7071067811865476, 0.0, 0.0])
    return spec, "attachment_site"


def _arm_home_qpos(model, data, site: str, T_world_home: np.ndarray) -> np.ndarray:
    """IK of the home pose from a few seeds; the first exact elbow-up solution wins."""
    import mujoco
    from simcalib.world.ik import solve_ik
    seeds = [ARM_HOME_SEED] + [np.asarray(s) for s in (
        (-1.5708, -1.5708, 1.5708, -1.5708, -1.5708, 0.0), (0.0, -1.57, 1.57, -1.57, -1.57, 0.0),
        (1.5708, -1.5708, 1.5708, 0.0, 1.5708, 0.0), (0.0, -1.0, -1.5, 0.5, 1.57, 0.0))]
    if model.nkey:
        seeds.insert(1, model.key_qpos[0].copy())
    shoulder, elbow = model.jnt_bodyid[1], model.jnt_bodyid[2]
    found = []
    for seed in seeds:
        q, ep, er, _ = solve_ik(model, data, site, T_world_home, seed[:model.nq], max_iter=500)
        if ep <= 1e-9 and er <= 1e-9:
            data.qpos[:] = q
            mujoco.mj_kinematics(model, data)
            if data.xpos[elbow][2] > data.xpos[shoulder][2] + 0.05:
                return q
            found.append(q)
    if found:
        return found[0]
    raise RuntimeError("the arm's home pose is not reachable by IK from any seed; "
                       "the arm model is not a UR5e-like 6-DoF arm")


class ArmPlatform:
    info = PlatformInfo(name="arm", description="UR5e arm on a pedestal posed by IK (joint "
                                                "kinematics, no dynamics); its flange is the "
                                                "target frame")

    def attach(self, spec, cfg) -> str:
        import mujoco
        arm, site_name = _arm_spec(cfg.arm_model)
        if getattr(cfg, "arm_dh_error", None) is not None:   # the true (imperfect) arm
            from simcalib.world.robot_error import apply_dh_to_spec, true_dh
            apply_dh_to_spec(arm, true_dh(cfg.arm_dh_error))
        foot = arm_base_position(cfg.room.size_m)
        if cfg.arm_model == "menagerie":     # the Menagerie arm has no pedestal: add ours
            spec.worldbody.add_geom(name="arm_pedestal", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                                    fromto=[*foot, *(foot + [0, 0, PEDESTAL_HEIGHT_M])],
                                    size=[0.12, 0, 0], rgba=[0.15, 0.15, 0.15, 1],
                                    contype=0, conaffinity=0)
            foot = foot + [0.0, 0.0, PEDESTAL_HEIGHT_M]
        frame = spec.worldbody.add_frame(pos=[float(v) for v in foot])
        spec.attach(arm, prefix="arm/", frame=frame)
        if cfg.arm.mount == "eye_to_hand":   # the camera on a stand (eyetohand.py)
            from simcalib.world.eyetohand import add_fixed_camera, add_flange_board
            add_fixed_camera(spec, cfg)
            add_flange_board(spec, cfg, f"arm/{site_name}")
        return f"arm/{site_name}"

    def home(self, model, data, mount_site, cfg):
        from simcalib.geometry import transform_from_rotation_translation
        T_world_home = transform_from_rotation_translation(
            R_WORLD_RIG_FORWARD, arm_base_position(cfg.room.size_m) + ARM_HOME_OFFSET_M)
        return T_world_home, _arm_home_qpos(model, data, mount_site, T_world_home)

    def drive(self, scene, T_world_target, t, cfg) -> PlatformMotion:
        model = scene.model
        t1 = time.perf_counter()
        res = _ik_path(scene, T_world_target, t, cfg)
        n = T_world_target.shape[0]
        return PlatformMotion(
            qpos=res.qpos, mocap_pos=np.zeros((n, model.nmocap, 3)),
            mocap_quat_wxyz=np.zeros((n, model.nmocap, 4)),
            stats={"max_pos_error_m": float(res.pos_error_m.max()),
                   "max_rot_error_rad": float(res.rot_error_rad.max()),
                   "mean_iterations": float(res.iterations.mean()),
                   "n_waypoints": int(n), "time_s": time.perf_counter() - t1})

    def simulates(self, cfg) -> bool:
        return cfg.arm.control == "physics"

    def simulate(self, scene, target_fn, t, cfg, rng) -> PlatformMotion:
        """Execute the IK joint path under joint control in physics (module docstring)."""
        from simcalib.world.arm_control import track_joint_path
        from simcalib.world.arm_servo import ArmGains
        model = scene.model
        t1 = time.perf_counter()
        t = np.asarray(t, dtype=np.float64)
        t_ref = np.arange(int(math.floor(cfg.duration_s * REFERENCE_RATE_HZ + 1e-9)) + 1
                          ) / REFERENCE_RATE_HZ
        if t_ref[-1] < cfg.duration_s - 1e-9:
            t_ref = np.append(t_ref, cfg.duration_s)
        res = _ik_path(scene, target_fn(t_ref), t_ref, cfg)
        g0, s = ArmGains(), float(cfg.arm.gain_scale)
        gains = ArmGains(kp_nm_per_rad=tuple(s * np.asarray(g0.kp_nm_per_rad)),
                         kd_nm_s_per_rad=tuple(math.sqrt(s) * np.asarray(g0.kd_nm_s_per_rad)))
        spec, site = _arm_spec(cfg.arm_model)
        for act in list(spec.actuators):        # the Menagerie arm brings its own
            spec.delete(act)
        tr = track_joint_path(spec, (t_ref, res.qpos), duration_s=float(t_ref[-1]),
                              gains=gains, capture=cfg.arm.capture, capture_rate_hz=cfg.fps,
                              site=site, sample_rate_hz=500.0,
                              settle_tol_rad=cfg.arm.settle_tol_rad,
                              settle_max_s=cfg.arm.settle_max_s)
        # frame times are path times: map them to the robot's clock (identical when
        # continuous; at a stop, the end of the settling = the capture instant)
        pt, rt = tr.path_time_s, tr.time_s
        last_of_run = np.r_[pt[1:] != pt[:-1], True]
        t_robot = np.interp(t, pt[last_of_run], rt[last_of_run])
        qpos = np.stack([np.interp(t_robot, rt, tr.qpos[:, j])
                         for j in range(tr.qpos.shape[1])], axis=-1)
        n = t.shape[0]
        stats = {"max_pos_error_m": float(res.pos_error_m.max()),
                 "max_rot_error_rad": float(res.rot_error_rad.max()),
                 "n_waypoints": int(t_ref.size), "control": "physics",
                 "capture": cfg.arm.capture, **tr.stats, "robot_time_s": t_robot,
                 "time_s": time.perf_counter() - t1}
        return PlatformMotion(qpos=qpos, mocap_pos=np.zeros((n, model.nmocap, 3)),
                              mocap_quat_wxyz=np.zeros((n, model.nmocap, 4)), stats=stats,
                              record=tr)


#: Rate at which the physics arm's joint reference is solved by IK (then interpolated).
REFERENCE_RATE_HZ = 100.0


def _ik_path(scene, T_world_target, t, cfg):
    """IK of the path (start from the home solution at the first pose); a waypoint the
    arm cannot reach raises ``ValueError`` naming the time."""
    from simcalib.world.ik import solve_ik_path
    from simcalib.world.paths import get_path
    res = solve_ik_path(scene.model, scene.mount_site, T_world_target, scene.home_qpos,
                        cfg.ik)
    if not res.converged.all():
            k = int(np.flatnonzero(~res.converged)[0])
            raise ValueError(
                f"path {cfg.path!r} is not reachable by the arm within its joint limits: at "
                f"t = {t[k]:.3f} s the IK error is {res.pos_error_m[k] * 1e3:.3g} mm / "
                f"{np.rad2deg(res.rot_error_rad[k]):.3g} deg; reduce the path amplitudes "
                f"(path_params) — defaults: {get_path(cfg.path).defaults['arm']}")
    return res


register(ArmPlatform())
