"""Scene assembly with ``mujoco.MjSpec``: room + platform (cart or arm) + rig + markers.

``build_scene(cfg) -> Scene`` is deterministic in the config (no randomness), so a worker
process can rebuild the identical ``MjModel`` from the (picklable) ``WorldConfig`` alone;
``MjModel`` itself also pickles in mujoco 4.0.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path


import numpy as np

from simcalib.geometry import (invert_transform, quat_from_matrix, quat_wxyz_from_xyzw,
                               transform_from_rotation_translation)
from simcalib.markers import MarkerField, marker_png
from simcalib.streams import CameraIntrinsics

__all__ = ["Scene", "build_scene", "build_model", "MODELS_DIR", "ARM_HOME_OFFSET_M",
           "arm_base_position", "CAMERA_NAMES", "MJ_FROM_CV"]

#: Directory holding the MJCF files (room, cart, ur5e, rig).
MODELS_DIR = Path(__file__).resolve().parents[2] / "models"
CAMERA_NAMES = ("cam_a", "cam_b")
#: OpenCV camera frame <-> MuJoCo camera frame (its own inverse): R_mj = R_cv @ MJ_FROM_CV.
MJ_FROM_CV = np.diag([1.0, -1.0, -1.0])
#: Arm home: the flange frame equals the rig frame looking along world +x (flange z = +x,
#: y = -z, x = -y), ``ARM_HOME_OFFSET_M`` from the pedestal foot (0.55 m in front of the
#: base axis, 0.30 m above the shoulder). ``home_qpos`` is solved by IK from this seed
#: (elbow up, wrist away from the cameras' view).
ARM_HOME_OFFSET_M = np.array([0.55, 0.0, 0.6 + 0.1625 + 0.30])
ARM_HOME_SEED = np.array([0.3005, -1.8099, -1.9046, 0.5729, 1.2703, 0.0])
#: The rig frame in world axes when looking along +x: x = -y_w, y = -z_w, z = +x_w.
R_WORLD_RIG_FORWARD = np.column_stack([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
#: Distance from the arm's base axis to the +x wall (the rig looks at that wall).
ARM_BASE_TO_WALL_M = 1.75


#: Height of the arm's pedestal (the built-in model has it; added for Menagerie arms).
PEDESTAL_HEIGHT_M = 0.6
#: Menagerie file of the optional arm model, relative to ``$MENAGERIE_ROOT``.
MENAGERIE_UR5E = Path("universal_robots_ur5e") / "ur5e.xml"


def _arm_spec(arm_model: str):
    """``(MjSpec, mount site name)`` of the arm: the built-in UR5e (models/ur5e.xml) or
    the Menagerie UR5e under ``$MENAGERIE_ROOT`` (its tool flange site
    ``attachment_site``; added on ``wrist_3_link`` if the file predates it)."""
    mujoco = _mujoco()
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
    mujoco = _mujoco()
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


def arm_base_position(room_size_m) -> np.ndarray:
    """World position of the arm's pedestal foot for a room of inner size ``room_size_m``."""
    return np.array([0.5 * room_size_m[0] - ARM_BASE_TO_WALL_M, 0.0, 0.0])


@dataclass(frozen=True)
class Scene:
    """A compiled scene. ``model``: the ``MjModel``; ``intrinsics``: per camera;
    ``marker_field``: the known map; ``T_world_home``: the target frame's home pose
    (cart base or arm flange); ``home_qpos``: the matching ``qpos``; ``mount_site``: name
    of the site carrying the rig; ``T_target_cam``: per camera, pose of its OpenCV frame in
    the target frame (cart: cart base; arm: flange)."""
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


def _mujoco():
    from simcalib.render import import_mujoco  # decides MUJOCO_GL once
    return import_mujoco()


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
    field = marker_layout(cfg.room, cfg.markers)

    if cfg.platform == "cart":
        platform_spec = mujoco.MjSpec.from_file(str(MODELS_DIR / "cart.xml"))
        frame = spec.worldbody.add_frame()
        spec.attach(platform_spec, prefix="cart/", frame=frame)
        mount = "cart/rig_mount"
    elif cfg.platform == "arm":
        platform_spec, site_name = _arm_spec(cfg.arm_model)
        foot = arm_base_position(cfg.room.size_m)
        if cfg.arm_model == "menagerie":     # the Menagerie arm has no pedestal: add ours
            spec.worldbody.add_geom(name="arm_pedestal", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                                    fromto=[*foot, *(foot + [0, 0, PEDESTAL_HEIGHT_M])],
                                    size=[0.12, 0, 0], rgba=[0.15, 0.15, 0.15, 1],
                                    contype=0, conaffinity=0)
            foot = foot + [0.0, 0.0, PEDESTAL_HEIGHT_M]
        frame = spec.worldbody.add_frame(pos=[float(v) for v in foot])
        spec.attach(platform_spec, prefix="arm/", frame=frame)
        mount = f"arm/{site_name}"
    else:  # WorldConfig validates this; keep a clear error for direct callers
        raise ValueError(f"platform must be 'cart' or 'arm'; received {cfg.platform!r}")

    rig_spec = mujoco.MjSpec.from_file(str(MODELS_DIR / "rig.xml"))
    T_rig_cam = _configure_rig(rig_spec, cfg)
    spec.attach(rig_spec, prefix="rig/", site=spec.site(mount))
    for name in CAMERA_NAMES:           # exact camera names for the renderer
        spec.camera(f"rig/{name}").name = name
    _add_markers(spec, field, cfg.markers)   # after attaching (assets dict on the parent)
    model = spec.compile()
    xml = spec.to_xml()

    # home pose of the target frame (cart base or flange)
    data = mujoco.MjData(model)
    if cfg.platform == "cart":
        T_world_home = np.eye(4)
        home_qpos = np.zeros(model.nq)
    else:
        from simcalib.world.ik import solve_ik
        T_world_home = transform_from_rotation_translation(
            R_WORLD_RIG_FORWARD, arm_base_position(cfg.room.size_m) + ARM_HOME_OFFSET_M)
        home_qpos = _arm_home_qpos(model, data, mount, T_world_home)
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
                 T_target_cam=T_target_cam, T_a_b=cfg.rig.T_a_b(), xml=xml)


def build_model(cfg):
    """Only the compiled ``MjModel`` of a ``WorldConfig`` (e.g. in a render worker)."""
    return build_scene(cfg).model
