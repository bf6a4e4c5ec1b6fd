"""The pan-tilt unit: pure rotations about its pivot, the paths it can and cannot follow
(rejected before any work, naming the time), and what its rotation-only motion
determines: one axis (``rotation``) leaves X's translation along it undetermined, two axes
(``3d``) determine X."""

import math
import re

import numpy as np
import pytest

from simcalib.errors import ConfigError
from simcalib.geometry import invert_transform, rotvec_from_matrix
from simcalib.world import WorldConfig, build_world
from simcalib.world.paths import sample_path
from simcalib.world.platforms.pan_tilt import (PIVOT_HEIGHT_M, TILT_LIMIT_DEG,
                                               pan_tilt_angles)


def _Rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _Ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def test_angles_invert_pan_then_tilt_and_unwrap_the_pan():
    pivot = np.array([0.0, 0.0, PIVOT_HEIGHT_M])
    pan = np.linspace(0.0, 3.0 * np.pi, 50)            # past +-pi: unwrapped, continuous
    tilt = 0.8 * np.radians(TILT_LIMIT_DEG) * np.sin(np.linspace(0.0, 5.0, 50))
    T = np.tile(np.eye(4), (50, 1, 1))
    T[:, :3, :3] = [_Rz(p) @ _Ry(q) for p, q in zip(pan, tilt)]
    T[:, :3, 3] = pivot
    got_pan, got_tilt = pan_tilt_angles(T, pivot, np.arange(50) * 0.1)
    np.testing.assert_allclose(got_pan, pan, atol=1e-12)
    np.testing.assert_allclose(got_tilt, tilt, atol=1e-12)


@pytest.mark.parametrize("change, fragment", [
    ("translate", "moves the head 20 mm off the pivot"),
    ("roll", "turns the head 36.9 deg off any pan x tilt rotation"),
    ("overtilt", re.escape(f"tilts 70.0 deg (the unit's range is +-{TILT_LIMIT_DEG:g} "
                           "deg)")),
])
def test_a_pose_the_unit_cannot_reach_names_the_time(change, fragment):
    pivot = np.array([0.0, 0.0, PIVOT_HEIGHT_M])
    T = np.tile(np.eye(4), (5, 1, 1))
    T[:, :3, 3] = pivot
    if change == "translate":
        T[3, 0, 3] += 0.02
    elif change == "roll":
        T[3, :3, :3] = np.array([[1.0, 0, 0], [0, 0.8, -0.6], [0, 0.6, 0.8]])
    else:
        T[3, :3, :3] = _Ry(math.radians(70.0))
    with pytest.raises(ValueError, match=rf"cannot follow the path at t = 0\.300 s: it "
                                         rf"{fragment}"):
        pan_tilt_angles(T, pivot, np.arange(5) * 0.1)


@pytest.mark.parametrize("kwargs, fragment", [
    ({"path": "3d", "path_params": {"amp_z_m": 0.05}}, "off the pivot"),
    ({"path": "3d", "path_params": {"amp_roll_deg": 5.0}}, "off any pan x tilt rotation"),
    ({"path": "3d", "path_params": {"amp_pitch_deg": 75.0}}, "the unit's range"),
    ({"path": "rotation", "perturbation": {"height_m": 0.01}}, "perturbation must be off"),
    ({"path": "planar"}, "not available on platform 'pan_tilt'"),
])
def test_paths_it_cannot_follow_fail_with_the_config(kwargs, fragment):
    with pytest.raises(ConfigError, match=fragment):
        WorldConfig(platform="pan_tilt", **kwargs)


def test_it_drives_the_existing_paths_it_declares():
    for path in ("rotation", "3d"):
        cfg = WorldConfig(platform="pan_tilt", path=path)
        assert cfg.platform == "pan_tilt"
    # the path is its own; the defaults are the unit's (no translation in 3d)
    params = {k: v for k, v in WorldConfig(platform="pan_tilt", path="3d").path_params.items()}
    assert params == {}
    s = sample_path("3d", "pan_tilt", np.linspace(0, 20, 101), 20.0)
    assert not s.dp.any() and not s.roll.any() and s.yaw.any() and s.pitch.any()


def _relative_axes(T):
    """Unit rotation axes of the consecutive relative motions of poses T (N, 4, 4)."""
    rel = invert_transform(T[:-1]) @ T[1:]
    v = rotvec_from_matrix(rel[:, :3, :3])
    n = np.linalg.norm(v, axis=1)
    return v[n > 1e-6] / n[n > 1e-6, None]


@pytest.mark.slow
def test_cameras_rotate_about_the_pivot_one_axis_or_two():
    for path, rank in (("rotation", 1), ("3d", 3)):
        cfg = WorldConfig(platform="pan_tilt", path=path, duration_s=4.0, fps=5.0)
        world = build_world(cfg, np.random.default_rng(0))
        pivot = world.scene.T_world_home[:3, 3]
        np.testing.assert_allclose(pivot, [0.0, 0.0, PIVOT_HEIGHT_M])
        for cam in ("cam_a", "cam_b"):
            T = world.frames(cam).T_world_cam
            d = np.linalg.norm(T[:, :3, 3] - pivot, axis=1)
            np.testing.assert_allclose(d, d[0], atol=1e-9)       # on a sphere: rotation only
            # in the world, every relative rotation axis is the pan axis (one axis) or
            # they span the space (pan x tilt)
            R0 = T[:, :3, :3]
            axes_world = np.einsum("nij,nj->ni", R0[:-1], _relative_axes(T))
            if rank == 1:
                np.testing.assert_allclose(np.abs(axes_world[:, 2]), 1.0, atol=1e-9)
            else:
                assert np.linalg.matrix_rank(axes_world, tol=0.05) >= 2
        assert world.ik["tilt_range_deg"] == (0.0 if path == "rotation" else
                                              pytest.approx(40.0, abs=1.0))


@pytest.mark.slow
def test_one_axis_leaves_the_translation_along_it_undetermined_two_axes_do_not(tmp_path):
    """Exact poses (source ground_truth): the turntable's motion flags the translation of X
    along the pan axis as undetermined; pan x tilt recovers X."""
    from simcalib.pipeline.scenario import load_config
    from simcalib.pipeline.stages import run
    common = ["world.platform=pan_tilt", "source=ground_truth", "solvers=[dqopt]",
              "world.duration_s=10", "world.fps=5", "progress=false",
              "recording.enabled=false", "prior.enabled=false"]
    one = run(load_config("3d", [*common, "world.path=rotation",
                                 f"output={tmp_path / 'one'}"]))
    two = run(load_config("3d", [*common, f"output={tmp_path / 'two'}"]))
    (s1,), (s2,) = one.solvers, two.solvers
    assert s1.verdict.startswith("undetermined") or s1.undetermined, s1.verdict
    assert "translation" in " ".join(s1.undetermined + s1.verdict_directions)
    assert s2.success and not s2.undetermined, s2.verdict
    assert s2.rotation_error_deg < 1e-4 and s2.translation_error_m < 1e-5
