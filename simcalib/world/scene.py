"""Scene assembly with ``mujoco.MjSpec``: room + platform + rig + markers.

The platform (``world.platform``) adds itself through its
:class:`~simcalib.world.platforms.Platform` (``simcalib/world/platforms/<name>.py``).

``build_scene(cfg) -> Scene`` is deterministic in the config (no randomness), so a worker
process can rebuild the identical ``MjModel`` from the (picklable) ``WorldConfig`` alone;
``MjModel`` itself also pickles in mujoco 4.0.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.world.render_backend import import_mujoco as _mujoco

from simcalib.geometry import (invert_transform, quat_from_matrix, quat_wxyz_from_xyzw,
                               transform_from_rotation_translation)
from simcalib.targets.markers import MarkerField, marker_png
from simcalib.config.resources import models_dir
from simcalib.streams import CAMERAS, CameraIntrinsics
from simcalib.world.render import MJ_FROM_CV

__all__ = ["Scene", "build_scene", "build_model", "MODELS_DIR", "CAMERA_NAMES"]

#: Directory holding the MJCF files (room, cart, ur5e, rig).
MODELS_DIR = models_dir()
CAMERA_NAMES = CAMERAS          # the rig's cameras (simcalib.streams.CAMERAS)



@dataclass(frozen=True)
class Scene:
    """A compiled scene. ``model``: the ``MjModel``; ``intrinsics``: per camera;
    ``marker_field``: the known map; ``T_world_home``: the target frame's home pose
    (cart base or arm flange); ``home_qpos``: the matching ``qpos``; ``mount_site``: name
    of the site carrying the rig; ``T_target_cam``: per camera, pose of its OpenCV frame in
    the target frame (cart: cart base; arm: flange); ``board`` / ``T_world_board``: the
    board target (:class:`simcalib.targets.boards.BoardConfig` and its board frame in the world)
    when ``world.target`` is a board, else ``None``."""
    model: object
    platform: str
    intrinsics: dict
    marker_field: MarkerField
    T_world_home: np.ndarray
    home_qpos: np.ndarray
    mount_site: str
    T_target_cam: dict
    T_a_b: np.ndarray
    xml: str
    board: object = None
    T_world_board: np.ndarray | None = None




def _quat_wxyz(R: np.ndarray) -> list[float]:
    return [float(v) for v in quat_wxyz_from_xyzw(quat_from_matrix(R))]


def _resize_room(spec, size_m):
    sx, sy, sz = size_m
    th, ov = 0.05, 0.1
    geoms = {
        "floor": ((0, 0, -th), (0.5 * sx + ov, 0.5 * sy + ov, th)),
        "ceiling": ((0, 0, sz + th), (0.5 * sx + ov, 0.5 * sy + ov, th)),
        "wall_px": ((0.5 * sx + th, 0, 0.5 * sz), (th, 0.5 * sy + ov, 0.5 * sz + ov)),
        "wall_nx": ((-0.5 * sx - th, 0, 0.5 * sz), (th, 0.5 * sy + ov, 0.5 * sz + ov)),
        "wall_py": ((0, 0.5 * sy + th, 0.5 * sz), (0.5 * sx + ov, th, 0.5 * sz + ov)),
        "wall_ny": ((0, -0.5 * sy - th, 0.5 * sz), (0.5 * sx + ov, th, 0.5 * sz + ov)),
    }
    for name, (pos, size) in geoms.items():
        g = spec.geom(name)
        g.pos = list(pos)
        g.size = list(size)


def _add_markers(spec, field: MarkerField, cfg_markers):
    mujoco = _mujoco()
    from simcalib.world.layout import MARKER_SURFACE_OFFSET_M, marker_cells
    cells = marker_cells(field.dictionary)
    cell_px = cfg_markers.texture_cell_px
    half = 0.5 * field.side_m * (cells + 2) / cells          # with a one-cell quiet zone
    th = 0.5 * MARKER_SURFACE_OFFSET_M
    for mid, T in zip(field.ids, field.T_world_marker):
        fname = f"marker_{int(mid):04d}.png"
        spec.assets[fname] = marker_png(int(mid), pixels=cells * cell_px,
                                        dictionary=field.dictionary, quiet_zone_px=cell_px)
        tex = spec.add_texture(name=f"marker_tex_{int(mid)}", file=fname,
                               type=mujoco.mjtTexture.mjTEXTURE_2D)
        del tex
        mat = spec.add_material(name=f"marker_mat_{int(mid)}", specular=0.0, shininess=0.0,
                                reflectance=0.0, rgba=[1, 1, 1, 1])
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = f"marker_tex_{int(mid)}"
        spec.worldbody.add_geom(
            name=f"marker_{int(mid)}", type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[float(v) for v in T[:3, 3] - th * T[:3, 2]], quat=_quat_wxyz(T[:3, :3]),
            size=[half, half, th], material=f"marker_mat_{int(mid)}",
            contype=0, conaffinity=0, group=1)


def _configure_rig(rig_spec, cfg):
    """Place the camera bodies from T_rig_cam_a and X = T_a_b; set fovy/resolution."""
    T_rig_a = cfg.rig.T_rig_cam_a()
    T_rig_b = T_rig_a @ cfg.rig.T_a_b()
    poses = {"cam_a": T_rig_a, "cam_b": T_rig_b}
    for name, cam_cfg in (("cam_a", cfg.cam_a), ("cam_b", cfg.cam_b)):
        body = rig_spec.body(f"{name}_body")
        T = poses[name]
        body.pos = [float(v) for v in T[:3, 3]]
        body.quat = _quat_wxyz(T[:3, :3] @ MJ_FROM_CV)
        cam = rig_spec.camera(name)
        cam.fovy = float(cam_cfg.fovy_deg)
        cam.resolution = [float(cam_cfg.width), float(cam_cfg.height)]
    back = np.array([0.0, 0.0, -0.04])
    bracket = rig_spec.geom("bracket")
    bracket.fromto = [float(v) for v in np.concatenate([T_rig_a[:3, 3] + back,
                                                        T_rig_b[:3, 3] + back])]
    mid = 0.5 * (T_rig_a[:3, 3] + T_rig_b[:3, 3]) + back
    stub = rig_spec.geom("rig_stub")
    stub.fromto = [0.0, 0.0, -0.06] + [float(v) for v in mid]
    return poses


def build_scene(cfg) -> Scene:
    """Assemble and compile the scene of a ``WorldConfig`` (see module docstring)."""
    mujoco = _mujoco()
    from simcalib.world.layout import marker_layout
    spec = mujoco.MjSpec.from_file(str(MODELS_DIR / "room.xml"))
    _resize_room(spec, cfg.room.size_m)
    from simcalib.world.platforms import get_platform
    platform = get_platform(cfg.platform)
    if platform.info.outdoor or cfg.target != "marker_wall":  # no marker field
        field = MarkerField(cfg.markers.dictionary, np.zeros(0, dtype=np.int64),
                            cfg.markers.side_m, np.zeros((0, 4, 4)))
    else:
        field = marker_layout(cfg.room, cfg.markers)
    mount = platform.attach(spec, cfg)

    rig_spec = mujoco.MjSpec.from_file(str(MODELS_DIR / "rig.xml"))
    T_rig_cam = _configure_rig(rig_spec, cfg)
    spec.attach(rig_spec, prefix="rig/", site=spec.site(mount))
    for name in CAMERA_NAMES:           # exact camera names for the renderer
        spec.camera(f"rig/{name}").name = name
    _add_markers(spec, field, cfg.markers)   # after attaching (assets dict on the parent)
    board, T_world_board = None, None
    if cfg.target != "marker_wall" and not platform.info.outdoor:
        from simcalib.world.board_model import T_world_wall_board, add_board
        board = cfg.board
        T_world_board = T_world_wall_board(board, cfg.room.size_m)
        add_board(spec, "world", T_world_board, board)
    model = spec.compile()
    xml = spec.to_xml()

    # home pose of the target frame (cart base or flange)
    data = mujoco.MjData(model)
    T_world_home, home_qpos = platform.home(model, data, mount, cfg)
    data.qpos[:] = home_qpos
    mujoco.mj_kinematics(model, data)
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, mount)
    T_world_mount = transform_from_rotation_translation(
        data.site_xmat[sid].reshape(3, 3).copy(), data.site_xpos[sid].copy())
    T_target_mount = invert_transform(T_world_home) @ T_world_mount
    T_target_cam = {n: T_target_mount @ T_rig_cam[n] for n in CAMERA_NAMES}

    intr = {n: CameraIntrinsics.from_fovy(c.width, c.height, c.fovy_deg)
            for n, c in (("cam_a", cfg.cam_a), ("cam_b", cfg.cam_b))}
    return Scene(model=model, platform=cfg.platform, intrinsics=intr, marker_field=field,
                 T_world_home=T_world_home, home_qpos=home_qpos, mount_site=mount,
                 T_target_cam=T_target_cam, T_a_b=cfg.rig.T_a_b(), xml=xml, board=board,
                 T_world_board=T_world_board)


def build_model(cfg):
    """Only the compiled ``MjModel`` of a ``WorldConfig`` (e.g. in a render worker)."""
    return build_scene(cfg).model
