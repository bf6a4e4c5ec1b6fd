"""Scene assembly, ground truth, IK, visibility and the MuJoCo boundary conventions."""

import os
import pickle

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from simcalib.geometry import (invert_transform, matrix_from_quat, quat_wxyz_from_xyzw,
                               random_rotation_matrices, relative_motions,
                               transform_from_rotation_translation)
from simcalib.targets.markers import MarkerField
from simcalib.streams import CameraIntrinsics
from simcalib.world import (MarkerFieldConfig, RigConfig, RoomConfig, WorldConfig,
                            available_paths, build_model, build_scene, build_world,
                            visible_markers)
from simcalib.world.layout import marker_layout
from simcalib.world.platforms import get_platform
from simcalib.world.platforms.arm import R_WORLD_RIG_FORWARD
from simcalib.world.render import MJ_FROM_CV

mujoco = pytest.importorskip("mujoco")

# indoor platforms (room + marker field); the outdoor car has tests/test_world_car.py
PAIRS = [(p, name) for name, info in sorted(available_paths().items())
         for p in info.platforms if not get_platform(p).info.outdoor]


@pytest.fixture(scope="module")
def worlds():
    return {pair: build_world(WorldConfig(platform=pair[0], path=pair[1]),
                              np.random.default_rng(7)) for pair in PAIRS}


def test_every_sensible_pair_is_covered():
    indoor = {p for p, _ in PAIRS}
    assert {"arm", "cart"} <= indoor             # every indoor platform drives some path
    assert ("arm", "3d") in PAIRS and ("cart", "3d") not in PAIRS
    assert ("arm", "scara") in PAIRS and ("cart", "scara") not in PAIRS


@pytest.mark.slow
@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: f"{p[0]}-{p[1]}")
def test_scene_builds_and_ground_truth_is_consistent(worlds, pair):
    w = worlds[pair]
    m = w.model
    assert w.camera_names == ("cam_a", "cam_b")
    assert [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(m.ncam)] == \
        ["cam_a", "cam_b"]
    assert m.vis.global_.offwidth >= 1920 and m.vis.global_.offheight >= 1080
    assert m.ntex == len(w.marker_field.ids) >= 150
    tr = w.trajectory
    n = WorldConfig().n_frames
    for fr in (tr.cam_a, tr.cam_b):
        assert fr.n_frames == n == 201
        assert np.allclose(fr.time_s, np.arange(n) / 10.0)       # zero offset by default
        assert np.all(np.diff(fr.time_s) > 0)
        assert fr.delivered.all()
    # C_i X = X H_i for all pairs of frames (zero time offset)
    i, j = np.triu_indices(n, k=1)
    sel = np.random.default_rng(0).choice(len(i), 2000, replace=False)
    C, H = relative_motions(tr.cam_a.T_world_cam, tr.cam_b.T_world_cam, i[sel], j[sel])
    X = tr.T_a_b
    assert np.abs(C @ X - X @ H).max() < 1e-9
    # X is the configured extrinsic and matches every simulated frame
    assert np.allclose(X, RigConfig().T_a_b(), atol=1e-15)
    X_sim = invert_transform(tr.cam_a.T_world_cam) @ tr.cam_b.T_world_cam
    assert np.abs(X_sim - X).max() < 1e-12
    # the motion is not trivial: > 10 cm of travel or > 30 deg of rotation
    from simcalib.geometry import rotation_error_rad
    travel = np.ptp(tr.cam_a.T_world_cam[:, :3, 3], axis=0).max()
    turn = np.rad2deg(rotation_error_rad(tr.cam_a.T_world_cam, tr.cam_a.T_world_cam[0]).max())
    assert travel > 0.1 or turn > 30.0


@pytest.mark.slow
@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: f"{p[0]}-{p[1]}")
def test_cameras_stay_in_room_and_see_markers(worlds, pair):
    w = worlds[pair]
    half = 0.5 * np.array(w.config.room.size_m)
    for cam in w.camera_names:
        fr = w.frames(cam)
        p = fr.T_world_cam[:, :3, 3]
        assert (np.abs(p[:, :2]) < half[:2] - 0.1).all()
        assert ((p[:, 2] > 0.3) & (p[:, 2] < half[2] * 2 - 0.3)).all()
        counts = visible_markers(w.marker_field, fr.T_world_cam, w.intrinsics[cam]).sum(1)
        assert np.array_equal(counts, fr.visible_markers)
        assert counts.min() >= 4, f"{cam} sees only {counts.min()} markers in some frame"


def test_intrinsics_follow_config():
    cfg = WorldConfig(cam_b={"width": 1280, "height": 720, "fovy_deg": 70.0})
    scene = build_scene(cfg)
    assert scene.intrinsics["cam_a"] == CameraIntrinsics.from_fovy(640, 480, 60.0)
    assert scene.intrinsics["cam_b"] == CameraIntrinsics.from_fovy(1280, 720, 70.0)
    cid = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_CAMERA, "cam_b")
    assert scene.model.cam_fovy[cid] == 70.0
    assert list(scene.model.cam_resolution[cid]) == [1280, 720]


def test_mocap_quaternion_conversion_and_camera_frame():
    """Set a cart pose from an (x, y, z, w) quaternion; MuJoCo's camera pose must equal the
    independent chain world <- cart <- mount (cart.xml) <- cam_a (RigConfig)."""
    cfg = WorldConfig(platform="cart", path="planar")
    model = build_model(cfg)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    q_xyzw = rng.standard_normal(4)
    q_xyzw /= np.linalg.norm(q_xyzw)
    t = np.array([0.3, -0.2, 0.05])
    data.mocap_pos[0] = t
    data.mocap_quat[0] = quat_wxyz_from_xyzw(q_xyzw)
    mujoco.mj_forward(model, data)
    T_world_cart = transform_from_rotation_translation(matrix_from_quat(q_xyzw), t)
    T_cart_mount = transform_from_rotation_translation(R_WORLD_RIG_FORWARD, [0.16, 0, 1.10])
    for name, T_rig_cam in (("cam_a", cfg.rig.T_rig_cam_a()),
                            ("cam_b", cfg.rig.T_rig_cam_a() @ cfg.rig.T_a_b())):
        expected = T_world_cart @ T_cart_mount @ T_rig_cam
        cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        R = data.cam_xmat[cid].reshape(3, 3) @ MJ_FROM_CV
        assert np.abs(R - expected[:3, :3]).max() < 1e-12
        assert np.abs(data.cam_xpos[cid] - expected[:3, 3]).max() < 1e-12
    # a MuJoCo camera looks along its -z: the OpenCV +z (forward) of cam_a is cart +x
    R_a = data.cam_xmat[0].reshape(3, 3) @ MJ_FROM_CV
    assert np.allclose(R_a[:, 2], T_world_cart[:3, 0], atol=1e-12)


def _dh_fk(q):
    d = [0.1625, 0, 0, 0.1333, 0.0997, 0.0996]
    a = [0, -0.425, -0.3922, 0, 0, 0]
    alpha = [np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0]
    T = np.eye(4)
    for i in range(6):
        ct, st = np.cos(q[i]), np.sin(q[i])
        ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
        T = T @ np.array([[ct, -st * ca, st * sa, a[i] * ct],
                          [st, ct * ca, -ct * sa, a[i] * st],
                          [0, sa, ca, d[i]], [0, 0, 0, 1]])
    return T


def test_arm_matches_published_ur5e_dh_kinematics():
    model = build_model(WorldConfig(path="3d"))
    data = mujoco.MjData(model)
    base = model.body("arm/ur5e_base").id
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "arm/rig_mount")
    rng = np.random.default_rng(0)
    lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
    assert np.allclose(hi, [2 * np.pi, 2 * np.pi, np.pi, 2 * np.pi, 2 * np.pi, 2 * np.pi])
    assert model.jnt_limited.all()
    for _ in range(20):
        q = rng.uniform(lo, hi)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        T_w_base = transform_from_rotation_translation(data.xmat[base].reshape(3, 3),
                                                       data.xpos[base])
        T_w_site = transform_from_rotation_translation(data.site_xmat[site].reshape(3, 3),
                                                       data.site_xpos[site])
        assert np.abs(invert_transform(T_w_base) @ T_w_site - _dh_fk(q)).max() < 1e-12


@pytest.mark.parametrize("path", ["3d", "planar", "circular"])
def test_ik_reaches_waypoints_within_joint_limits(worlds, path):
    w = worlds[("arm", path)]
    assert w.ik["max_pos_error_m"] < 1e-6 and w.ik["max_rot_error_rad"] < 1e-6
    q = w.trajectory.cam_a.qpos
    lo, hi = w.model.jnt_range[:, 0], w.model.jnt_range[:, 1]
    assert ((q >= lo) & (q <= hi)).all()
    assert np.abs(np.diff(q, axis=0)).max() < 0.3          # continuous, no branch flips
    # the achieved flange poses are the path's targets
    from simcalib.world.paths import compose_path, sample_path
    t = w.trajectory.cam_a.time_s
    target = compose_path(w.scene.T_world_home, sample_path(path, "arm", t, 20.0))
    achieved = w.trajectory.cam_a.T_world_cam @ invert_transform(
        w.scene.T_target_cam["cam_a"])
    assert np.abs(achieved - target).max() < 1e-6


@pytest.mark.slow
def test_unreachable_arm_path_is_a_clear_error():
    cfg = WorldConfig(path="linear", platform="arm", path_params={"amp_m": 1.5})
    with pytest.raises(ValueError, match="not reachable by the arm within its joint limits"):
        build_world(cfg, np.random.default_rng(0))


def test_camera_leaving_room_is_a_clear_error():
    cfg = WorldConfig(path="linear", platform="cart", path_params={"amp_m": 2.5})
    with pytest.raises(ValueError, match="camera cam_a leaves the room"):
        build_world(cfg, np.random.default_rng(0))


def test_model_pickles_and_rebuilds_identically(worlds):
    w = worlds[("cart", "planar")]
    m2 = pickle.loads(pickle.dumps(w.model))
    m3 = build_model(w.config)
    for m in (m2, m3):
        assert (m.ngeom, m.ntex, m.ncam, m.nmocap) == (w.model.ngeom, w.model.ntex, 2, 1)
        assert np.array_equal(m.tex_data, w.model.tex_data)
        assert np.array_equal(m.geom_pos, w.model.geom_pos)
        assert np.array_equal(m.cam_quat, w.model.cam_quat)


def test_marker_layout_frames_and_geoms():
    field = marker_layout(RoomConfig(), MarkerFieldConfig())
    assert isinstance(field, MarkerField)
    T = field.T_world_marker
    assert np.allclose(np.linalg.det(T[:, :3, :3]), 1.0)
    assert np.array_equal(field.ids, np.arange(len(field.ids)))
    # every marker faces into the room and sits just in front of a wall
    normal, centre = T[:, :3, 2], T[:, :3, 3]
    assert (np.einsum("mi,mi->m", normal, -centre + [0, 0, 1.3]) > 0).all()
    assert np.allclose(np.abs(centre[:, :2]).max(axis=1), 2.2 - 0.002)
    assert np.allclose(T[:, :3, 1], [0, 0, 1])                 # upright
    # geoms carry the same frames (geom centre half a thickness behind the face)
    model = build_model(WorldConfig())
    for k in (0, 57, len(field.ids) - 1):
        g = model.geom(f"marker_{k}")
        R = matrix_from_quat(np.r_[g.quat[1:], g.quat[:1]])
        assert np.allclose(R, T[k, :3, :3], atol=1e-12)
        assert np.allclose(g.pos + g.size[2] * T[k, :3, 2], T[k, :3, 3], atol=1e-12)
        assert g.size[0] == pytest.approx(0.5 * 0.2 * 8 / 6)   # marker + 1-cell quiet zone
    with pytest.raises(ValueError, match="needs .* ids but DICT_4X4_50 holds 50"):
        marker_layout(RoomConfig(), MarkerFieldConfig(dictionary="DICT_4X4_50"))
    with pytest.raises(ValueError, match="unknown ArUco dictionary"):
        marker_layout(RoomConfig(), MarkerFieldConfig(dictionary="DICT_4X4_7"))


def test_visible_markers_geometry():
    T_m = np.eye(4)[None]
    field = MarkerField("DICT_4X4_250", np.array([0]), 0.2, T_m)
    intr = CameraIntrinsics.from_fovy(640, 480, 60.0)
    # camera 1 m in front of the marker, looking at it (OpenCV z towards -z_marker)
    R = np.diag([1.0, -1.0, -1.0])
    facing = transform_from_rotation_translation(R, [0, 0, 1.0])
    behind = transform_from_rotation_translation(np.diag([1.0, 1.0, 1.0]), [0, 0, 1.0])
    far = transform_from_rotation_translation(R, [0, 0, 20.0])
    edge = transform_from_rotation_translation(
        random_rotation_matrices(np.random.default_rng(0), ()) * 0 + np.array(
            [[0, 0, -1], [0, -1, 0], [-1, 0, 0]]) @ np.eye(3), [1.0, 0, 0.0])
    vis = visible_markers(field, np.stack([facing, behind, far, edge]), intr)
    assert vis[:, 0].tolist() == [True, False, False, False]



def test_visible_markers_through_a_barrel_lens_sees_past_the_pinhole_edge():
    """The distorted image of a barrel lens reaches beyond the pinhole image: a marker just
    outside the pinhole view is fully visible through the lens (the markers the PnP rests
    on, the systematic error basis of a stop)."""
    from simcalib.sources.vision.camera_effects import PRESETS
    T_m = np.eye(4)[None]
    field = MarkerField("DICT_4X4_250", np.array([0]), 0.1, T_m)
    intr = CameraIntrinsics.from_fovy(640, 480, 60.0)
    R = np.diag([1.0, -1.0, -1.0])
    dist = PRESETS["realistic"].distortion
    found = []
    for x in np.linspace(0.0, 1.2, 121):       # slide the camera: the marker moves left
        T = transform_from_rotation_translation(R, [x, 0.0, 1.0])[None]
        found.append((visible_markers(field, T, intr)[0, 0],
                      visible_markers(field, T, intr, distortion=dist)[0, 0]))
    found = np.array(found)
    assert found[0].all()                                   # centred: both
    assert (found[:, 0] <= found[:, 1]).all()               # the lens never sees less here
    assert (found[:, 1] & ~found[:, 0]).any()               # and sees past the pinhole edge
    assert not found[-1].any()                              # far off: neither

def test_project_points_is_the_pinhole_model():
    from simcalib.geometry import project_points
    from simcalib.streams import CameraIntrinsics
    from simcalib.world.layout import project_points as project_world
    intr = CameraIntrinsics(640, 480, 500.0, 510.0, 319.5, 239.5)
    T_world_cam = np.stack([np.eye(4), np.eye(4)])
    T_world_cam[1, :3, 3] = [0.1, -0.2, -1.0]
    p = np.array([[[0.2, 0.1, 2.0], [-0.3, 0.4, 4.0]]])                  # (1, 2, 3)
    uv, z = project_world(T_world_cam, intr, p)
    assert uv.shape == (2, 1, 2, 2) and z.shape == (2, 1, 2)
    pc = p[0] - T_world_cam[1, :3, 3]
    np.testing.assert_allclose(z[1, 0], pc[:, 2])
    np.testing.assert_allclose(uv[1, 0], np.column_stack([500 * pc[:, 0] / pc[:, 2] + 319.5,
                                                          510 * pc[:, 1] / pc[:, 2] + 239.5]))
    uv2, z2 = project_points(np.linalg.inv(T_world_cam), p, intr.K)
    np.testing.assert_allclose(uv2, uv)
    np.testing.assert_allclose(z2, z)
