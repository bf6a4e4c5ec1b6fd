"""A calibration board in the MuJoCo scene: the textured thin box of a
:class:`simcalib.targets.boards.BoardConfig` added to an ``MjSpec`` (on the wall, or on any body,
e.g. the flange for eye-to-hand) and the pose of a wall board. The board itself — its
pattern, corner model, detection and PnP — is :mod:`simcalib.targets.boards`."""

from __future__ import annotations

import numpy as np

from simcalib.targets.boards import BOARD_THICKNESS_M, BoardConfig, T_geom_board, board_png
from simcalib.geometry import invert_transform, quat_from_matrix, quat_wxyz_from_xyzw
from simcalib.world.layout import MARKER_SURFACE_OFFSET_M

__all__ = ["add_board", "T_world_wall_board"]


def add_board(spec, parent_body_name: str, T_parent_board, board: BoardConfig,
              name: str = "board") -> str:
    """Add ``board`` as a textured thin box to a ``mujoco.MjSpec``, its board frame at
    ``T_parent_board`` ``(4, 4)`` in body ``parent_body_name`` (``"world"`` for the
    worldbody). Adds texture ``<name>_tex``, material ``<name>_mat`` and the geom
    ``<name>`` (no contacts, group 1); returns the geom name. Call before compiling."""
    from simcalib.world.render_backend import import_mujoco  # noqa: PLC0415
    mujoco = import_mujoco()
    T = np.asarray(T_parent_board, dtype=np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise ValueError(f"T_parent_board must be a finite (4, 4) pose; received shape "
                         f"{T.shape}")
    body = spec.worldbody if parent_body_name == "world" else spec.body(parent_body_name)
    if body is None:
        raise ValueError(f"add_board: no body {parent_body_name!r} in the spec")
    fname = f"{name}.png"
    spec.assets[fname] = board_png(board)
    spec.add_texture(name=f"{name}_tex", file=fname, type=mujoco.mjtTexture.mjTEXTURE_2D)
    mat = spec.add_material(name=f"{name}_mat", specular=0.0, shininess=0.0,
                            reflectance=0.0, rgba=[1, 1, 1, 1])
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = f"{name}_tex"
    T_pg = T @ invert_transform(T_geom_board(board))
    w, h = board.size_m
    q = board.quiet_zone_m
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX,
                  pos=[float(v) for v in T_pg[:3, 3]],
                  quat=[float(v) for v in quat_wxyz_from_xyzw(quat_from_matrix(T_pg[:3, :3]))],
                  size=[0.5 * w + q, 0.5 * h + q, 0.5 * BOARD_THICKNESS_M],
                  material=f"{name}_mat", contype=0, conaffinity=0, group=1)
    return name


def T_world_wall_board(board: BoardConfig, room_size_m) -> np.ndarray:
    """Pose of a wall board in the world (``board.wall``, ``board.center_m``): upright,
    facing into the room, its printed face ``MARKER_SURFACE_OFFSET_M`` off the wall."""
    sx, sy, _ = (float(v) for v in room_size_m)
    normals = {"+x": (-1.0, 0.0, 0.0), "-x": (1.0, 0.0, 0.0),
               "+y": (0.0, -1.0, 0.0), "-y": (0.0, 1.0, 0.0)}
    n = np.array(normals[board.wall])                     # inward normal
    up = np.array([0.0, 0.0, 1.0])
    right = np.cross(up, n)                               # right, seen from inside
    face = -n * 0.5 * np.array([sx, sy, 0.0]) + n * MARKER_SURFACE_OFFSET_M
    centre = face + board.center_m[0] * right + board.center_m[1] * up
    w, h = board.size_m
    R = np.column_stack([right, -up, -n])                 # board x right, y down, z into wall
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = centre - 0.5 * w * right + 0.5 * h * up
    return T
