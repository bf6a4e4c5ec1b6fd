"""Platform ``car`` (physics vehicle in a world) and the physics arm mode: ground truth from
the physics, roll under turns, determinism, scenarios, clear errors."""

import numpy as np
import pytest

from simcalib.pipeline.scenario import load_config
from simcalib.errors import ConfigError
from simcalib.geometry import invert_transform, matrix_from_rotvec, rotation_error_rad
from simcalib.world import WorldConfig, build_world
from simcalib.world.platforms.car import interpolate_poses, vertical_axis_a

#: A small car world: a 24 m x 10 m figure-eight (~17 s drive at 5 m/s), 2 frames/s.
SMALL = {"platform": "car", "path": "planar", "duration_s": 17.0, "fps": 2.0,
         "path_params": {"amp_x_m": 12.0, "amp_y_m": 5.0}}
#: The same small world through the scenario files (short, low fps, no recording).
SMALL_RUN = ["world.duration_s=17", "world.fps=2", "world.path_params.amp_x_m=12",
             "world.path_params.amp_y_m=5", "world.vehicle.speed_mps=5", "progress=false",
             "recording.enabled=false"]


def _tilt_deg(T_world_cam):
    """Angle between the rig's up (camera a's -y: the rig is upright) and world up."""
    up = -T_world_cam[:, :3, 1]
    return np.degrees(np.arccos(np.clip(up[:, 2], -1.0, 1.0)))


@pytest.fixture(scope="module")
def sprung():
    return build_world(WorldConfig(**SMALL, vehicle={"speed_mps": 5.0}),
                       np.random.default_rng(3))


@pytest.fixture(scope="module")
def rigid():
    return build_world(WorldConfig(**SMALL, vehicle={"speed_mps": 5.0, "sprung": False}),
                       np.random.default_rng(3))


@pytest.mark.slow
def test_turns_roll_the_sprung_car_and_not_the_rigid_one(sprung, rigid):
    """Under the turns the sprung car rolls > 0.5 deg (seen by the cameras); the rigid car on
    flat ground stays level (contact compliance only)."""
    assert sprung.ik["roll_peak_deg"] > 0.5
    assert rigid.ik["roll_peak_deg"] < 0.05
    # the cameras carry it: rig tilt w.r.t. gravity (cam_a is mounted upright)
    assert _tilt_deg(sprung.trajectory.cam_a.T_world_cam).max() > 0.5
    assert _tilt_deg(rigid.trajectory.cam_a.T_world_cam).max() < 0.05
    # and the roll happens in the turns: it follows the lateral acceleration's sign
    tr = sprung.platform_record
    a_lat = tr.speed_mps * np.gradient(tr.yaw_rad, tr.time_s)
    turning = np.abs(a_lat) > 1.5
    assert turning.sum() > 50
    assert abs(np.corrcoef(a_lat[turning], tr.roll_rad[turning])[0, 1]) > 0.8


@pytest.mark.slow
def test_ground_truth_is_the_physics_pose_of_the_camera_sites(sprung):
    """Camera poses = the physics' rig-mount pose at the capture time (interpolated) times
    the rig's fixed mount->camera transform; the rig stays rigid (X at every frame)."""
    tr = sprung.platform_record
    traj = sprung.trajectory
    for cam in ("cam_a", "cam_b"):
        fr = getattr(traj, cam)
        T_mount = interpolate_poses(tr.time_s, tr.T_world_rig_mount, fr.time_s)
        T_mount_cam = invert_transform(T_mount) @ fr.T_world_cam
        np.testing.assert_allclose(T_mount_cam, np.broadcast_to(
            T_mount_cam[0], T_mount_cam.shape), atol=1e-9)
    T_rig_a = sprung.config.rig.T_rig_cam_a()
    T_mount_a = invert_transform(interpolate_poses(tr.time_s, tr.T_world_rig_mount,
                                                   traj.cam_a.time_s[:1])[0]) \
        @ traj.cam_a.T_world_cam[0]
    np.testing.assert_allclose(T_mount_a, T_rig_a, atol=1e-9)
    X = invert_transform(traj.cam_a.T_world_cam) @ traj.cam_b.T_world_cam
    np.testing.assert_allclose(X, np.broadcast_to(traj.T_a_b, X.shape), atol=1e-9)
    # the car is outdoors: it leaves the 4.4 m room without complaint
    assert np.ptp(traj.cam_a.T_world_cam[:, 0, 3]) > 10.0
    assert sprung.marker_field.ids.size == 0


@pytest.mark.slow
def test_same_seed_same_trajectory_to_1e9_m():
    cfg = WorldConfig(platform="car", path="linear", duration_s=6.0, fps=5.0,
                      path_params={"amp_m": 8.0},
                      vehicle={"speed_mps": 5.0, "ground": "uneven", "bump_amplitude_m": 0.02})
    a = build_world(cfg, np.random.default_rng(11))
    b = build_world(cfg, np.random.default_rng(11))
    for cam in ("cam_a", "cam_b"):
        Ta, Tb = (getattr(w.trajectory, cam).T_world_cam for w in (a, b))
        assert np.abs(Ta[:, :3, 3] - Tb[:, :3, 3]).max() <= 1e-9
        assert np.abs(Ta[:, :3, :3] - Tb[:, :3, :3]).max() <= 1e-9
    c = build_world(cfg, np.random.default_rng(12))     # other bumps, other trajectory
    assert np.abs(c.trajectory.cam_a.T_world_cam - a.trajectory.cam_a.T_world_cam).max() > 1e-4


def test_interpolate_poses_is_linear_and_slerp():
    t = np.array([0.0, 1.0, 2.0])
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    T = np.zeros((3, 4, 4))
    for i, ti in enumerate(t):
        T[i, :3, :3] = matrix_from_rotvec(axis * 0.4 * ti)
        T[i, :3, 3] = [ti, 2.0 * ti, -ti]
        T[i, 3, 3] = 1.0
    q = interpolate_poses(t, T, np.array([-1.0, 0.0, 0.25, 1.5, 2.0, 3.0]))
    np.testing.assert_allclose(q[[0, 1]], T[[0, 0]], atol=1e-12)     # held before start
    np.testing.assert_allclose(q[[4, 5]], T[[2, 2]], atol=1e-12)     # held after the end
    np.testing.assert_allclose(q[2, :3, 3], [0.25, 0.5, -0.25], atol=1e-12)
    # constant rotation rate: SLERP is exact
    for k, tk in ((2, 0.25), (3, 1.5)):
        assert rotation_error_rad(q[k], np.block([[matrix_from_rotvec(axis * 0.4 * tk),
                                                   np.zeros((3, 1))], [np.zeros((1, 3)),
                                                                       np.ones((1, 1))]])) \
            < 1e-12


@pytest.mark.slow
def test_scenarios_build_and_run_small(tmp_path):
    import simcalib
    res = simcalib.run(load_config("car", [*SMALL_RUN, f"output={tmp_path / 'car'}"]),
                       echo=False)
    assert res.status == "complete"
    dq = res.solver("dqopt")
    assert dq.rotation_error_deg < 1.0
    up = vertical_axis_a(res.config.world)
    np.testing.assert_allclose(up, [0.0, -1.0, 0.0], atol=1e-12)   # upright cam_a
    # the horizontal translation of X is determined to a few mm by the turns
    e = dq.X[:3, 3] - res.X_true[:3, 3]
    assert np.linalg.norm(e - (e @ up) * up) < 0.02
    flat = simcalib.run(load_config("car-flat", [*SMALL_RUN, f"output={tmp_path / 'flat'}"]),
                        echo=False)
    s = flat.solver("dqopt")
    assert s.degenerate
    assert any("translation of X along" in u for u in s.undetermined)


@pytest.mark.parametrize("overrides, match", [
    (["source=aruco"], r"source=aruco needs a marker field.*platform 'car'"),
    (["world.vehicle.speed_mps=-1"], r"world.vehicle.*speed_mps must be in"),
    (["world.vehicle.drive=tank"], r"drive must be one of \['ackermann', 'differential'\]"),
    (["world.perturbation.roll_deg=1"], r"perturbation must be off with platform 'car'"),
])
def test_car_config_errors_are_clear(overrides, match):
    with pytest.raises(ConfigError, match=match):
        load_config("car", overrides)


def test_a_path_that_reverses_is_rejected():
    cfg = WorldConfig(platform="car", path="circular", duration_s=10.0, fps=2.0,
                      path_params={"radius_m": 10.0, "turns": 0.0, "arc_deg": 90.0})
    with pytest.raises(ValueError, match=r"reverses on itself.*drives forward only"):
        build_world(cfg, np.random.default_rng(0))


# ------------------------------------------------------------------ arm under control
@pytest.fixture(scope="module")
def arm_worlds():
    base = dict(platform="arm", path="3d", duration_s=4.0, fps=5.0)
    return {mode: build_world(WorldConfig(**base, arm=arm), np.random.default_rng(0))
            for mode, arm in (("kinematic", {}),
                              ("continuous", {"control": "physics"}),
                              ("stop_and_go", {"control": "physics",
                                               "capture": "stop_and_go"}))}


@pytest.mark.slow
def test_physics_arm_lags_while_moving_and_settles_at_stops(arm_worlds):
    ref = arm_worlds["kinematic"].trajectory.cam_a.T_world_cam

    def off_mm(mode):
        T = arm_worlds[mode].trajectory.cam_a.T_world_cam
        return 1e3 * np.linalg.norm(T[:, :3, 3] - ref[:, :3, 3], axis=1)

    cont, stop = off_mm("continuous"), off_mm("stop_and_go")
    # moving captures: the servos' tracking error (~mm at the flange, as the gains imply)
    assert 0.2 < cont.max() < 10.0
    # stop-and-go captures: settled to within a fraction of a millimetre
    assert stop.max() < 0.3
    rec = arm_worlds["stop_and_go"].platform_record
    assert rec.capture == "stop_and_go" and rec.capture_settled.all()
    assert rec.time_s[-1] > 4.0 * 1.3                 # the robot's clock ran longer
    stats = arm_worlds["continuous"].ik
    assert stats["control"] == "physics" and stats["torque_saturated_fraction"] < 0.05
    for w in arm_worlds.values():                      # the rig stays rigid
        tr = w.trajectory
        X = invert_transform(tr.cam_a.T_world_cam) @ tr.cam_b.T_world_cam
        np.testing.assert_allclose(X, np.broadcast_to(tr.T_a_b, X.shape), atol=1e-9)


def test_arm_control_config_errors():
    with pytest.raises(ConfigError, match=r"arm.control must be one of 'kinematic', "
                                          r"'physics'"):
        load_config("3d", ["world.arm.control=dynamic"])
    with pytest.raises(ConfigError, match=r"arm.capture must be one of"):
        load_config("3d", ["world.arm.capture=burst"])
