"""Source ``robot_fk``: a camera's (or the flange's) pose as the robot controller reports it.

The world moved the TRUE arm (nominal UR5e DH table + ``world.arm_dh_error``, drawn from
``robot.kinematic_error``); this source reads the joint encoders at the stream's frames
(:func:`simcalib.world.robot_error.encoder_readings`: noise, quantisation, backlash;
``robot.encoder``) and maps them through the NOMINAL table::

    T_world_cam = T_world_base · FK_nominal(q_read) · T_flange_cam

with ``T_world_base`` the arm's base (exact) and ``T_flange_cam`` the camera's mount on the
flange (the rig: ``world.rig``). With cam_a placed on the flange
(``world.rig.rig_cam_a_translation_m = rig_cam_a_rotvec_deg = [0, 0, 0]``, as in
``scenarios/handeye.yaml``) the stream is the flange itself and ``X = T_flange_cam_b``
(eye-in-hand). Needs ``world.platform=arm`` with the built-in arm model.
"""

from __future__ import annotations

import numpy as np

from simcalib.sources.base import CAMERAS, GroundTruth, SourceHooks, SourceInfo, SourceOutput
from simcalib.sources.registry import register
from simcalib.world.robot_error import arm_state

__all__ = ["RobotFKSource"]


def T_flange_cam(rig, cam: str) -> np.ndarray:
    """``(4, 4)`` pose of camera ``cam`` in the flange frame (the rig is the flange)."""
    T = rig.T_rig_cam_a()
    return T if cam == "cam_a" else T @ rig.T_a_b()



class RobotFKSource(SourceHooks):
    info = SourceInfo(name="robot_fk", kinds=("sim",), rng_stream="encoders", reads_joints=True,
                      example=("handeye",),
                      description="arm joint encoders (robot.encoder) through the nominal DH "
                                  "kinematics while the world moves the true arm "
                                  "(robot.kinematic_error): the flange / mounted camera pose "
                                  "as the robot reports it")

    def error_basis(self, world, cfg, cam, T_world_cam, layout, qpos=None, visible=None):
        """The arm's DH deviation (``robot.kinematic_error``) at the joint states ``qpos``
        ``(F, nq)`` (:func:`simcalib.world.robot_error.fk_pose_error_basis`), in the
        ``dh`` columns; None without a joint state or a kinematic error."""
        if qpos is None or not cfg.robot.kinematic_error.active:
            return None
        from simcalib.world.robot_error import fk_pose_error_basis
        adr, _ = arm_state(world)
        B = np.zeros((np.shape(T_world_cam)[0], 6, layout["P"]))
        B[:, :, layout["dh"]] = fk_pose_error_basis(np.asarray(qpos)[:, adr],
                                                    T_flange_cam(world.config.rig, cam),
                                                    cfg.robot.kinematic_error.sigmas)
        return B

    def datapoint_error_basis(self, st, world, cam, T_world_cam, frame_index, layout):
        """:meth:`error_basis` at the joint state of each datapoint's frame."""
        if not st.cfg.robot.kinematic_error.active:
            return None
        qpos = np.asarray(world.frames(cam).qpos)[frame_index]
        return self.error_basis(world, st.cfg, cam, T_world_cam, layout, qpos=qpos)

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        from simcalib.geometry import rotation_error_rad, translation_error_m
        from simcalib.streams import PoseStream
        from simcalib.world.robot_error import UR5E_DH, dh_fk, encoder_readings
        from simcalib.world.sensors import delivered_mask
        world = truth.world
        adr, T_world_base = arm_state(world)
        rig = world.config.rig
        T_flange = {c: T_flange_cam(rig, c) for c in CAMERAS}
        rngs = dict(zip(CAMERAS, rng.spawn(len(CAMERAS))))
        streams, log = {}, {}
        for cam in cameras:
            fr = world.frames(cam)
            order = np.argsort(fr.time_s, kind="stable")    # encoders see motion in time
            q_true = np.asarray(fr.qpos)[:, adr]
            q_read = np.empty_like(q_true)
            q_read[order] = encoder_readings(q_true[order], cfg.robot.encoder, rngs[cam])
            mask = delivered_mask(fr)
            idx = np.flatnonzero(mask)
            T = T_world_base @ dh_fk(q_read[idx], UR5E_DH) @ T_flange[cam]
            gt = np.asarray(fr.T_world_cam)[idx]
            rot = rotation_error_rad(T, gt)
            tr = translation_error_m(T, gt)
            enc = q_read[idx] - q_true[idx]
            streams[cam] = PoseStream(
                camera=cam, source="robot_fk", frame_index=idx,
                timestamp_s=np.asarray(fr.stamp_s, dtype=np.float64)[idx],
                T_world_cam=T, n_frames=fr.n_frames,
                info={"encoder_error_rad": enc, "fk_rotation_error_rad": rot,
                      "fk_translation_error_m": tr},
                drop_reasons={"frame_dropped": int((~mask).sum())} if (~mask).any() else {})
            log[cam] = {"fk_translation_error_m_median": float(np.median(tr)),
                        "fk_translation_error_m_max": float(tr.max()),
                        "fk_rotation_error_deg_median": float(np.rad2deg(np.median(rot))),
                        "encoder_error_rad_rms": float(np.sqrt(np.mean(enc ** 2)))}
        return SourceOutput(streams=streams, log=log)


register(RobotFKSource())
