"""Platform ``pan_tilt``: a pan-tilt unit on a tripod in the middle of the room carrying the
rig — rotation-only motion about two axes through one point.

The unit is two revolute joints whose axes meet at the *pivot* (:data:`PIVOT_HEIGHT_M`
above the floor at the room's centre): ``pan`` about the vertical, then ``tilt`` about the
pan head's horizontal axis (tilting up and down). The tilt head is the target frame (home:
facing world +x, level); the rig sits on top of it, :data:`RIG_MOUNT_M` above the tilt
axis. A path's pose of the target frame is therefore a pure rotation
``Rz(pan) · Ry(tilt)`` about the pivot: the platform follows exactly the paths whose
offsets are a yaw and a pitch and nothing else. It drives

* ``rotation``: pan only, about one fixed (vertical) axis — a turntable: the translation
  of X along that axis is unobservable (the degeneracy the path names);
* ``3d``: a pan x tilt Lissajous with no translation (the path's ``amp_*_m`` and
  ``amp_roll_deg`` are 0 here and must stay 0): two rotation axes through one point.
  The cameras still translate (they sit off the pivot, on lever arms of
  ``RIG_MOUNT_M + world.rig.*``), so X is determined in principle — how well, with lever
  arms of a few centimetres, is what this platform is for.

A path (or override, or ``world.perturbation``) that translates the head, rolls it or
tilts it past :data:`TILT_LIMIT_DEG` is rejected with the scenario, before any work
(:meth:`PanTiltPlatform.check_config`), and again by :meth:`PanTiltPlatform.drive`, naming
the time. The joints are posed kinematically (no dynamics); their angles are the MuJoCo
state (``qpos``), so the world's joint record is the unit's encoder truth.
"""

from __future__ import annotations

import math

import numpy as np

from simcalib.world.platforms.base import PlatformInfo, PlatformMotion
from simcalib.world.platforms.registry import register

__all__ = ["PanTiltPlatform", "PIVOT_HEIGHT_M", "RIG_MOUNT_M", "TILT_LIMIT_DEG",
           "pan_tilt_angles"]

#: Height of the pivot (where the pan and tilt axes meet) above the floor, metres.
PIVOT_HEIGHT_M = 1.20
#: The rig mount in the tilt head's frame (x forward, z up at home), metres: on top.
RIG_MOUNT_M = (0.0, 0.0, 0.08)
#: Mechanical tilt range, either way from level, degrees.
TILT_LIMIT_DEG = 60.0
#: How far a path pose may be from a pure pan x tilt rotation about the pivot (m, rad):
#: numerical rounding only.
_TOL = 1e-9

#: rig frame in the head frame: z_rig = +x, y_rig = -z, x_rig = -y (as the cart's mount)
_RIG_QUAT_WXYZ = (0.5, -0.5, 0.5, -0.5)


def pan_tilt_angles(T_world_target: np.ndarray, pivot: np.ndarray, t: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """``(pan, tilt)`` ``(N,)`` radians (pan unwrapped over time) that put the tilt head at
    ``T_world_target`` ``(N, 4, 4)`` — ``R = Rz(pan) · Ry(tilt)`` at the ``pivot`` — or a
    ``ValueError`` naming the first time ``t`` whose pose the unit cannot reach."""
    T = np.asarray(T_world_target, dtype=np.float64)
    R = T[:, :3, :3]
    pan = np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))
    tilt = np.arctan2(-R[:, 2, 0], R[:, 2, 2])
    c, s = np.cos(pan), np.sin(pan)
    ct, st = np.cos(tilt), np.sin(tilt)
    R_fit = np.zeros_like(R)
    R_fit[:, 0] = np.stack([c * ct, -s, c * st], axis=-1)
    R_fit[:, 1] = np.stack([s * ct, c, s * st], axis=-1)
    R_fit[:, 2] = np.stack([-st, np.zeros_like(st), ct], axis=-1)
    # angle between R and R_fit: |R - R_fit|_F = 2 sqrt(2) sin(angle / 2) (exact when small)
    chord = np.linalg.norm(R - R_fit, axis=(1, 2)) / (2.0 * math.sqrt(2.0))
    off_rot = 2.0 * np.arcsin(np.clip(chord, 0.0, 1.0))
    off_pos = np.linalg.norm(T[:, :3, 3] - np.asarray(pivot), axis=1)
    too_far = np.abs(tilt) > math.radians(TILT_LIMIT_DEG) + _TOL
    bad = (off_rot > _TOL) | (off_pos > _TOL) | too_far
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        why = [f"tilts {math.degrees(tilt[k]):.1f} deg (the unit's range is "
               f"+-{TILT_LIMIT_DEG:g} deg)"] if too_far[k] else []
        if off_pos[k] > _TOL:
            why.append(f"moves the head {off_pos[k] * 1e3:.3g} mm off the pivot")
        if off_rot[k] > _TOL:
            why.append(f"turns the head {math.degrees(off_rot[k]):.3g} deg off any pan x "
                       "tilt rotation (a roll)")
        raise ValueError(f"the pan-tilt unit cannot follow the path at t = {t[k]:.3f} s: it "
                         f"{' and '.join(why)}; it can only pan and tilt (no translation, "
                         "no roll)")
    return pan, tilt


class PanTiltPlatform:
    info = PlatformInfo(
        name="pan_tilt", rig_mount_m=RIG_MOUNT_M,
        description="pan-tilt unit on a tripod at the room's centre: rotation-only motion "
                    "about a vertical (pan) and a horizontal (tilt) axis through one point",
        paths={"rotation": {"turns": 0.0, "arc_deg": 120.0},
               "3d": {"amp_x_m": 0.0, "amp_y_m": 0.0, "amp_z_m": 0.0, "amp_roll_deg": 0.0,
                      "amp_pitch_deg": 20.0, "amp_yaw_deg": 60.0, "cycles": 1.0}})

    def attach(self, spec, cfg) -> str:
        import mujoco
        dark, grey = [0.12, 0.12, 0.12, 1.0], [0.45, 0.47, 0.5, 1.0]
        geom = dict(contype=0, conaffinity=0)
        pivot_z = PIVOT_HEIGHT_M
        base = spec.worldbody.add_body(name="pan_tilt/tripod", pos=[0.0, 0.0, 0.0])
        for k in range(3):                                   # three legs and the column
            a = 2.0 * math.pi * k / 3.0
            base.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[0.012, 0, 0], rgba=dark,
                          fromto=[0.35 * math.cos(a), 0.35 * math.sin(a), 0.0,
                                  0.0, 0.0, pivot_z - 0.45], **geom)
        base.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.02, 0, 0], rgba=dark,
                      fromto=[0.0, 0.0, pivot_z - 0.45, 0.0, 0.0, pivot_z - 0.09], **geom)
        pan = base.add_body(name="pan_tilt/pan", pos=[0.0, 0.0, pivot_z])
        pan.add_joint(name="pan_tilt/pan", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        pan.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.07, 0.03],
                     pos=[0.0, 0.0, -0.06], rgba=grey, **geom)
        tilt = pan.add_body(name="pan_tilt/tilt", pos=[0.0, 0.0, 0.0])
        tilt.add_joint(name="pan_tilt/tilt", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                       range=[-math.radians(TILT_LIMIT_DEG), math.radians(TILT_LIMIT_DEG)])
        tilt.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.03, 0.05, 0],
                      quat=[0.7071067811865476, 0.7071067811865476, 0.0, 0.0], rgba=dark,
                      **geom)
        tilt.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.06, 0.05, 0.01],
                      pos=[0.0, 0.0, RIG_MOUNT_M[2] - 0.01], rgba=grey, **geom)
        tilt.add_site(name="pan_tilt/rig_mount", pos=list(RIG_MOUNT_M),
                      quat=list(_RIG_QUAT_WXYZ), size=[0.01, 0, 0])
        return "pan_tilt/rig_mount"

    def home(self, model, data, mount_site, cfg):
        return _home_pose(), np.zeros(model.nq)

    def check_config(self, cfg) -> None:
        """The path (with ``cfg.path_params``) at 2,001 instants over the run is a pan x
        tilt rotation within the tilt range, and nothing is added on top of it."""
        from simcalib.world.paths import compose_path, sample_path
        if cfg.perturbation.active:
            raise ValueError("world.perturbation must be off on the pan-tilt unit (it can "
                             "only pan and tilt: no roll, no height change)")
        t = np.linspace(0.0, cfg.duration_s, 2001)
        home = _home_pose()
        T = compose_path(home, sample_path(cfg.path, "pan_tilt", t, cfg.duration_s,
                                           cfg.path_params))
        pan_tilt_angles(T, home[:3, 3], t)

    def drive(self, scene, T_world_target, t, cfg) -> PlatformMotion:
        model = scene.model
        pan, tilt = pan_tilt_angles(T_world_target, scene.T_world_home[:3, 3], t)
        n = pan.shape[0]
        qpos = np.zeros((n, model.nq))
        qpos[:, model.joint("pan_tilt/pan").qposadr[0]] = pan
        qpos[:, model.joint("pan_tilt/tilt").qposadr[0]] = tilt
        return PlatformMotion(
            qpos=qpos, mocap_pos=np.zeros((n, model.nmocap, 3)),
            mocap_quat_wxyz=np.zeros((n, model.nmocap, 4)),
            stats={"pan_range_deg": float(np.degrees(np.ptp(pan))),
                   "tilt_range_deg": float(np.degrees(np.ptp(tilt)))})


def _home_pose() -> np.ndarray:
    """The tilt head at the pivot, facing world +x, level."""
    T = np.eye(4)
    T[2, 3] = PIVOT_HEIGHT_M
    return T


register(PanTiltPlatform())
