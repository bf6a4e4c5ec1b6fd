"""Platform registry: every platform x every path it supports builds a world whose target
frame follows the path; unsupported combinations are clear errors listing valid ones."""

import numpy as np
import pytest

from simcalib.geometry import invert_transform
from simcalib.world import PLATFORMS, WorldConfig, build_world
from simcalib.world.paths import available_paths, compose_path, sample_path
from simcalib.world.platforms import (Platform, available_platforms, combinations,
                                      get_platform)

COMBOS = [(p, path) for path, plats in sorted(combinations().items()) for p in plats]


def test_registry_matches_the_config_and_rejects_unknown_names():
    assert tuple(available_platforms()) == PLATFORMS
    for name in PLATFORMS:
        assert isinstance(get_platform(name), Platform)
    with pytest.raises(ValueError, match=r"unknown platform 'crat'.*did you mean 'cart'.*"
                                         r"available: cart, arm"):
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
                                         r"planar: \['cart', 'arm'\]"):
        WorldConfig(platform=p, path=path)


@pytest.mark.parametrize("platform,path", COMBOS)
def test_every_platform_drives_every_supported_path(platform, path):
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
