"""Paths registry and WorldConfig validation (no MuJoCo needed)."""

import numpy as np
import pytest

from simcalib.world import (CameraConfig, MarkerFieldConfig, PerturbationConfig, RigConfig,
                            WorldConfig, available_paths, get_path, sample_path)
from simcalib.world.paths import compose_path, perturbation_sample

def test_registry_names_platforms_and_metadata():
    from simcalib.world.paths import PATHS
    from simcalib.world.platforms import available_platforms
    paths = available_paths()
    assert paths and list(paths) == PATHS.names()
    for name, info in paths.items():
        assert info.name == name and get_path(name) is info and PATHS.get(name) is info.fn
        assert info.platforms and set(info.platforms) <= set(available_platforms())
        assert len(info.description) > 20
        for platform in info.platforms:
            assert info.params_for(platform)  # defaults exist and validate


def test_unknown_path_lists_valid_names():
    with pytest.raises(ValueError, match=r"unknown path 'plannar'.*did you mean 'planar'"):
        get_path("plannar")
    listing = ", ".join(sorted(available_paths()))
    with pytest.raises(ValueError, match=rf"available: {listing}"):
        WorldConfig(path="spiral")


def test_nonsensical_pairing_is_a_clear_error():
    with pytest.raises(ValueError, match=r"'3d' is not available on platform 'cart'.*"
                                         r"paths for 'cart': \['circular', 'linear', "
                                         r"'planar', 'rotation'\]"):
        WorldConfig(platform="cart", path="3d")
    with pytest.raises(ValueError, match="platform must be one of"):
        WorldConfig(platform="drone", path="planar")


def test_default_platform_follows_path():
    assert WorldConfig(path="3d").platform == "arm"
    assert WorldConfig(path="circular").platform == "cart"
    assert WorldConfig(path="circular", platform="arm").platform == "arm"


def test_path_param_overrides_validated():
    cfg = WorldConfig(path="linear", path_params={"amp_m": 0.5})
    assert cfg.path_params == {"amp_m": 0.5}
    with pytest.raises(ValueError, match=r"unknown parameter 'amp'.*did you mean 'amp_m'"):
        WorldConfig(path="linear", path_params={"amp": 0.5})
    with pytest.raises(TypeError, match="must be a number"):
        WorldConfig(path="linear", path_params={"amp_m": "big"})


@pytest.mark.parametrize("kwargs, exc, pattern", [
    ({"fps": 0}, ValueError, "fps must be >"),
    ({"fps": float("nan")}, ValueError, "fps must be finite"),
    ({"duration_s": "10"}, TypeError, "duration_s must be a number"),
    ({"duration_s": 0.1, "fps": 5}, ValueError, "at least 3 frames"),
    ({"cam_b": {"capture_jitter_s": 0.05}}, ValueError, "quarter of the frame period"),
    ({"cam_b": {"fovy": 60}}, ValueError, r"cam_b: unknown key 'fovy' \(did you mean 'cam_b.fovy_deg'\?\)"),
    ({"cam_a": {"width": 4000}}, ValueError, r"cam_a.width must be an integer in \[16, 1920\]; received 4000"),
    ({"rig": 3}, TypeError, "must be a RigConfig"),
])
def test_world_config_rejects_bad_input(kwargs, exc, pattern):
    with pytest.raises(exc, match=pattern):
        WorldConfig(**kwargs)


def test_nested_config_checks():
    with pytest.raises(ValueError, match="drop_prob must be < 1"):
        CameraConfig(drop_prob=1.0)
    with pytest.raises(ValueError, match="a_b_translation_m must be 3 finite numbers"):
        RigConfig(a_b_translation_m=(0.0, 0.1))
    with pytest.raises(ValueError, match="surfaces must be distinct names"):
        MarkerFieldConfig(surfaces=("walls", "roof"))
    with pytest.raises(ValueError, match="pitch_m"):
        MarkerFieldConfig(side_m=0.3, pitch_m=0.35)
    with pytest.raises(ValueError, match="roll_deg must be <= 20"):
        PerturbationConfig(roll_deg=45)


def test_default_rig_is_the_papers_extrinsic():
    X = RigConfig().T_a_b()
    assert np.allclose(X[:3, 3], [-0.007, 0.281, -0.001])
    from simcalib.geometry import rotvec_from_matrix
    assert np.allclose(np.rad2deg(rotvec_from_matrix(X[:3, :3])), [2.35, -0.92, -48.93])


@pytest.mark.parametrize("name", sorted(available_paths()))
def test_paths_are_smooth_and_shape_independent_of_duration(name):
    for platform in available_paths()[name].platforms:
        T = 20.0
        t = np.linspace(0.0, T, 4001)
        s = sample_path(name, platform, t, T)
        poses = compose_path(np.eye(4), s)
        assert poses.shape == (4001, 4, 4) and np.isfinite(poses).all()
        # smooth: second differences O(dt^2), no jumps
        d2 = np.abs(np.diff(poses[:, :3, :], n=2, axis=0)).max()
        assert d2 < 1e-4 * max(1.0, np.abs(poses[:, :3, 3]).max())   # relative (car scale)
        # the shape (pose at the same fraction of the run) does not depend on duration
        s2 = sample_path(name, platform, t * 3.0, 3.0 * T)
        assert np.allclose(compose_path(np.eye(4), s2), poses, atol=1e-12)


def test_path_kinematics_match_their_names():
    t = np.linspace(0, 20, 401)
    lin = compose_path(np.eye(4), sample_path("linear", "cart", t, 20.0))
    assert np.allclose(lin[:, :3, :3], np.eye(3))              # no rotation
    d = lin[:, :3, 3] - lin[0, :3, 3]
    assert np.linalg.matrix_rank(d, tol=1e-9) == 1             # one direction
    rot = compose_path(np.eye(4), sample_path("rotation", "cart", t, 20.0))
    assert np.allclose(rot[:, :3, 3], 0.0)                     # in place
    yaw = np.unwrap(np.arctan2(rot[:, 1, 0], rot[:, 0, 0]))
    assert yaw[-1] - yaw[0] == pytest.approx(2 * np.pi)        # one full turn
    circ = compose_path(np.eye(4), sample_path("circular", "cart", t, 20.0))
    assert np.allclose(np.linalg.norm(circ[:, :2, 3], axis=1), 0.8)   # radius 0.8 m
    assert np.allclose(circ[:, 2, 3], 0.0)
    planar = compose_path(np.eye(4), sample_path("planar", "cart", t, 20.0))
    assert np.allclose(planar[:, 2, :3], [0, 0, 1]) and np.allclose(planar[:, 2, 3], 0)
    p3 = compose_path(np.eye(4), sample_path("3d", "arm", t, 20.0))
    from simcalib.geometry import rotvec_from_matrix
    # genuinely 6-DoF: translations and rotation vectors span 3 dimensions each
    assert np.linalg.matrix_rank(p3[:, :3, 3] - p3[:, :3, 3].mean(0), tol=1e-3) == 3
    assert np.linalg.matrix_rank(rotvec_from_matrix(p3[:, :3, :3]), tol=1e-3) == 3


def test_perturbation_bounded_and_seeded():
    cfg = PerturbationConfig(roll_deg=2.0, pitch_deg=1.0, height_m=0.01)
    t = np.linspace(0, 30, 3001)
    a = perturbation_sample(t, cfg, np.random.default_rng(1))
    b = perturbation_sample(t, cfg, np.random.default_rng(1))
    c = perturbation_sample(t, cfg, np.random.default_rng(2))
    assert np.array_equal(a.roll, b.roll) and not np.allclose(a.roll, c.roll)
    assert np.abs(np.rad2deg(a.roll)).max() <= 2.0 and np.abs(np.rad2deg(a.pitch)).max() <= 1.0
    assert np.abs(a.dp[:, 2]).max() <= 0.01 and np.abs(a.dp[:, 2]).max() > 0.002


def test_world_package_import_is_light():
    import subprocess
    import sys
    code = ("import sys, simcalib.world as W; W.WorldConfig(path='3d'); "
            "print(sorted(m for m in ('mujoco', 'cv2', 'rerun') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"
