"""Eye-to-hand on the ``arm`` platform (``world.arm.mount = "eye_to_hand"``).

A camera on a stand (fixed in the room, camera ``fixed_cam``) watches a board carried by
the arm's flange. simcalib's rigid pair is then flange + board, both on the flange:

* sensor a = the flange: ``T_base_flange`` from the robot's forward kinematics
  (source ``robot_fk``; its world is the robot base / room);
* sensor b = the board: ``T_cam_board`` as the fixed camera sees it (its world is the fixed
  camera: the truth and measured streams of ``cam_b`` are re-expressed in that frame by
  :func:`express_in_fixed_camera`).

``C_i X = X H_i`` holds with ``X = T_flange_board`` (the rig's ``T_a_b`` with cam_a at the
flange). The fixed camera's pose in the robot base ``T_base_cam`` is a by-product:
``T_base_cam ≈ T_base_flange_i · X · inv(T_cam_board_i)`` for every common frame ``i``,
averaged and reported in results.json (``eye_to_hand``: :mod:`simcalib.pipeline.eye_to_hand`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["MOUNTS", "FIXED_CAMERA", "STAND_OFFSET_M", "T_world_fixed_camera",
           "add_fixed_camera", "add_flange_board", "express_in_fixed_camera", "is_eye_to_hand"]

#: ``world.arm.mount`` values: the rig on the flange seen from the flange
#: (``eye_in_hand``, default) or a fixed camera seeing the flange's board (``eye_to_hand``).
MOUNTS = ("eye_in_hand", "eye_to_hand")
#: Name of the fixed camera in the scene.
FIXED_CAMERA = "fixed_cam"
#: The stand camera's position relative to the arm's home flange position (world axes):
#: in front of the arm (towards the +x wall, which the home flange faces), a little higher.
STAND_OFFSET_M = np.array([0.6, 0.05, 0.1])


def is_eye_to_hand(cfg) -> bool:
    """Is the world the arm with a fixed camera watching the flange's board?"""
    return cfg.platform == "arm" and cfg.arm.mount == "eye_to_hand"


def T_world_fixed_camera(cfg) -> np.ndarray:
    """``(4, 4)`` pose of the fixed camera's OpenCV frame (z forward, y down) in the world:
    ``STAND_OFFSET_M`` from the home flange position, looking at it."""
    from simcalib.world.layout import ARM_HOME_OFFSET_M, arm_base_position
    target = arm_base_position(cfg.room.size_m) + ARM_HOME_OFFSET_M
    eye = target + STAND_OFFSET_M
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross([0.0, 0.0, -1.0], z)            # x = y × z with y_cv ~ world down
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, y, z])
    T[:3, 3] = eye
    return T


def add_fixed_camera(spec, cfg) -> None:
    """Add the stand (a post on the floor) and the fixed camera ``fixed_cam`` (MuJoCo
    camera frame: looks along -z, +y up) to ``spec``'s world body."""
    import mujoco
    from simcalib.geometry import quat_from_matrix
    T = T_world_fixed_camera(cfg)
    R_mj = T[:3, :3] @ np.diag([1.0, -1.0, -1.0])     # OpenCV -> MuJoCo camera axes
    x, y, z, w = quat_from_matrix(R_mj)
    pos = T[:3, 3]
    stand = spec.worldbody.add_body(name="camera_stand", pos=[float(pos[0]), float(pos[1]), 0.0])
    stand.add_geom(name="camera_stand_post", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                   fromto=[0, 0, 0, 0, 0, float(pos[2]) - 0.04], size=[0.02, 0, 0],
                   rgba=[0.2, 0.2, 0.2, 1], contype=0, conaffinity=0)
    stand.add_camera(name=FIXED_CAMERA, pos=[0.0, 0.0, float(pos[2])],
                     quat=[float(w), float(x), float(y), float(z)],
                     fovy=float(cfg.cam_b.fovy_deg) if hasattr(cfg.cam_b, "fovy_deg") else 60.0)


def add_flange_board(spec, cfg, mount_site: str) -> str | None:
    """Add ``cfg.board`` (the world's board, when ``world.target`` is one) on the flange at
    the board frame ``T_flange_board = rig T_rig_cam_a · T_a_b`` (cam_b's frame): call after
    the arm is attached. Returns the board geom's name, ``None`` without a board."""
    board = getattr(cfg, "board", None)
    if board is None or cfg.target == "marker_wall":
        return None
    from simcalib.world.board_model import add_board
    from simcalib.geometry import matrix_from_quat, quat_xyzw_from_wxyz
    site = spec.site(mount_site)
    T_body_site = np.eye(4)
    T_body_site[:3, :3] = matrix_from_quat(quat_xyzw_from_wxyz(np.asarray(site.quat, float)))
    T_body_site[:3, 3] = site.pos
    T_body_board = T_body_site @ cfg.rig.T_rig_cam_a() @ cfg.rig.T_a_b()
    return add_board(spec, site.parent.name, T_body_board, board, name="flange_board")


def _in_camera(stream, T_cam_world):
    if stream is None:
        return None
    info = dict(stream.info) | {"world": FIXED_CAMERA}
    return dataclasses.replace(stream, T_world_cam=T_cam_world @ np.asarray(stream.T_world_cam),
                               info=info)


def express_in_fixed_camera(truth, measured: dict, cfg):
    """``(truth, measured)`` with cam_b's streams (the board) expressed in the fixed camera
    frame: ``T_cam_board = inv(T_world_cam) · T_world_board``. Unchanged when the mount is
    not eye-to-hand."""
    if not is_eye_to_hand(cfg) or truth.world is None:
        return truth, measured
    from simcalib.geometry import invert_transform
    T_cam_world = invert_transform(T_world_fixed_camera(cfg))
    streams = dict(truth.streams)
    streams["cam_b"] = _in_camera(streams.get("cam_b"), T_cam_world)
    measured = dict(measured)
    if "cam_b" in measured:
        measured["cam_b"] = _in_camera(measured["cam_b"], T_cam_world)
    return dataclasses.replace(truth, streams=streams), measured

