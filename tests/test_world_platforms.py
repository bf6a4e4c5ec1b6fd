"""Platform registry: every platform x every path it supports builds a world whose target
frame follows the path; unsupported combinations are clear errors listing valid ones."""

import numpy as np
import pytest

from simcalib.geometry import invert_transform
from simcalib.world import WorldConfig, build_world
from simcalib.world.paths import available_paths, compose_path, sample_path
from simcalib.world.platforms import (Platform, available_platforms, combinations,
                                      get_platform)

COMBOS = [(p, path) for path, plats in sorted(combinations().items()) for p in plats]
PLATFORMS = list(available_platforms())


def test_registry_finds_the_platform_files_and_rejects_unknown_names():
    assert PLATFORMS                                      # found by discovery of the folder
    for name, info in available_platforms().items():
        assert isinstance(get_platform(name), Platform) and info.name == name
        assert type(get_platform(name)).__module__.startswith("simcalib.world.platforms.")
        assert WorldConfig(platform=name, path=next(
            p for p, plats in combinations().items() if name in plats)).platform == name
    listing = ", ".join(available_platforms())
    with pytest.raises(ValueError, match=r"unknown platform 'crat'.*did you mean 'cart'.*"
                                         rf"available: {listing}"):
        get_platform("crat")
    # every path names only registered platforms, and each platform drives some path
    for path, info in available_paths().items():
        assert set(info.platforms) <= set(PLATFORMS), path
    assert {p for p, _ in COMBOS} == set(PLATFORMS)


def test_unsupported_combination_lists_the_valid_ones():
    unsupported = [(p, path) for path in available_paths() for p in PLATFORMS
                   if (p, path) not in COMBOS]
    assert unsupported, "expected at least one unsupported platform x path"
    p, path = unsupported[0]
    with pytest.raises(ValueError, match=rf"'{path}' is not available on platform '{p}'.*"
                                         r"valid path: \[platforms\] combinations: .*"
                                         r"planar: \['cart', 'arm', 'car'\]"):
        WorldConfig(platform=p, path=path)


#: The physics car drives a path's geometry at its own speed: small versions of the paths
#: (and a capture window covering the drive) keep the test short.
CAR_SMALL = {"planar": {"amp_x_m": 12.0, "amp_y_m": 5.0}, "circular": {"radius_m": 10.0},
             "linear": {"amp_m": 8.0}}


def _simulated_world(platform, path):
    """The car: the physics chassis follows the path's geometry, the cameras are the
    physics' rig-mount poses (interpolated) times a constant mount->camera transform."""
    cfg = WorldConfig(platform=platform, path=path, duration_s=17.0, fps=2.0,
                      path_params=CAR_SMALL[path], vehicle={"speed_mps": 5.0})
    world = build_world(cfg, np.random.default_rng(0))
    tr = world.platform_record
    from simcalib.world.platforms.car import interpolate_poses
    T_target = compose_path(world.scene.T_world_home, sample_path(
        path, platform, np.linspace(0.0, 17.0, 2000), 17.0, cfg.path_params))
    # the controlled point (rear-axle centre) stays near the path (pure pursuit cuts the
    # tight corners of these small paths by up to ~1 m)
    rear = tr.T_world_base[:, :2, :] @ [-0.5 * cfg.vehicle.wheelbase_m, 0.0, 0.0, 1.0]
    d = np.linalg.norm(rear[:, None, :] - T_target[None, :, :2, 3], axis=-1)
    assert d.min(axis=1).max() < 1.5
    assert tr.stats["cross_track_max_m"] < 1.5
    for cam in ("cam_a", "cam_b"):
        fr = getattr(world.trajectory, cam)
        T_mount = interpolate_poses(tr.time_s, tr.T_world_rig_mount, fr.time_s)
        T_mount_cam = invert_transform(T_mount) @ fr.T_world_cam
        np.testing.assert_allclose(T_mount_cam, np.broadcast_to(T_mount_cam[0],
                                                                T_mount_cam.shape), atol=1e-9)
    return world


@pytest.mark.slow
@pytest.mark.parametrize("platform,path", COMBOS)
def test_every_platform_drives_every_supported_path(platform, path):
    if callable(getattr(get_platform(platform), "simulates", None)) and \
            get_platform(platform).simulates(WorldConfig(platform=platform, path=path)):
        traj = _simulated_world(platform, path).trajectory
        X = invert_transform(traj.cam_a.T_world_cam) @ traj.cam_b.T_world_cam
        np.testing.assert_allclose(X, np.broadcast_to(traj.T_a_b, X.shape), atol=1e-9)
        return
    cfg = WorldConfig(platform=platform, path=path, duration_s=2.0, fps=5.0)
    world = build_world(cfg, np.random.default_rng(0))
    scene = world.scene
    traj = world.trajectory
    assert world.trajectory.meta["platform"] == platform
    # the cameras sit where the path puts the target frame (kinematic platforms: exactly)
    t = traj.cam_a.time_s
    T_target = compose_path(scene.T_world_home, sample_path(path, platform, t, 2.0))
    for cam in ("cam_a", "cam_b"):
        T = getattr(traj, cam).T_world_cam
        assert np.isfinite(T).all()
        np.testing.assert_allclose(T, T_target @ scene.T_target_cam[cam], atol=1e-6)
    # and the rig is rigid: X = T_a_b at every frame
    X = invert_transform(traj.cam_a.T_world_cam) @ traj.cam_b.T_world_cam
    np.testing.assert_allclose(X, np.broadcast_to(traj.T_a_b, X.shape), atol=1e-9)
