"""Source ``mocap``: the rigid fit, exactness without noise, noise as predicted by the
marker geometry, occlusion dropouts counted (never filled in), the body-to-camera offset
error as a constant bias the covariance includes, and its own config section."""

import math

import numpy as np
import pytest

from simcalib.errors import ConfigError
from simcalib.geometry import (invert_transform, matrix_from_rotvec, rotvec_from_matrix,
                               transform_from_rotation_translation)
from simcalib.pipeline.scenario import load_config
from simcalib.pipeline.state import run_rngs
from simcalib.sources import build_truth, get_source
from simcalib.sources.mocap import MocapConfig, rigid_fit, tracking_cameras

SMALL = ["streams.a.source=mocap", "streams.b.source=mocap", "world.duration_s=12",
         "world.fps=5", "progress=false", "recording.enabled=false"]


def _measure(overrides, scenario="planar", seed=0):
    cfg = load_config(scenario, [*SMALL, f"seed={seed}", *overrides])
    rngs = run_rngs(cfg.seed)
    truth = build_truth(cfg, rngs)
    src = get_source("mocap")
    return cfg, truth, src.measure(truth, cfg, rngs[src.info.rng_stream], ("cam_a", "cam_b"))


def test_rigid_fit_recovers_the_transform_from_any_three_points():
    rng = np.random.default_rng(1)
    P = MocapConfig(markers=6).marker_points()
    T = transform_from_rotation_translation(matrix_from_rotvec(rng.normal(size=(5, 3))),
                                            rng.normal(size=(5, 3)))
    Q = np.einsum("fij,kj->fki", T[:, :3, :3], P) + T[:, None, :3, 3]
    w = np.ones((5, 6))
    w[1, :3] = 0.0                          # a frame with only three markers seen
    Q[1, :3] += 10.0                        # ... whose unseen markers are garbage
    np.testing.assert_allclose(rigid_fit(P, Q, w), T, atol=1e-12)


def test_tracking_cameras_are_high_on_the_walls_and_aim_at_the_middle():
    pos, d = tracking_cameras((4.4, 4.4, 2.6))
    assert pos.shape == (8, 3) and np.all(pos[:, 2] > 2.0)
    assert np.all(np.abs(pos[:, :2]).max(axis=1) > 2.0)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.all(d[:, 2] < 0)                                   # looking down


@pytest.mark.slow
def test_without_noise_or_offset_error_the_stream_is_the_cameras_pose():
    _, truth, out = _measure(["mocap.marker_sigma_m=0"])
    for cam in ("cam_a", "cam_b"):
        s, gt = out.streams[cam], truth.streams[cam]
        assert s.source == "mocap" and s.n_used == gt.n_used
        np.testing.assert_allclose(s.T_world_cam, gt.T_world_cam, atol=1e-9)
        np.testing.assert_array_equal(s.timestamp_s, gt.timestamp_s)


@pytest.mark.slow
def test_noise_follows_the_marker_geometry():
    """Rotation noise ~ marker sigma / body radius: a body half the size is twice as
    noisy, and the measured spread matches the source's own prediction."""
    def rotation_noise(size):
        cfg, truth, out = _measure([f"mocap.body_size_m={size}"])
        s, gt = out.streams["cam_a"], truth.streams["cam_a"]
        d = rotvec_from_matrix(np.swapaxes(gt.T_world_cam[:, :3, :3], 1, 2)
                               @ s.T_world_cam[:, :3, :3])
        return float(np.sqrt(np.mean(d ** 2))), get_source("mocap")._sigmas(cfg)[0]
    big, big_pred = rotation_noise(0.2)
    small, small_pred = rotation_noise(0.1)
    assert 1.6 < small / big < 2.5
    for got, pred in ((big, big_pred), (small, small_pred)):
        assert 0.6 * pred < got < 1.6 * pred, (got, pred)


@pytest.mark.slow
def test_occlusion_drops_frames_and_counts_them():
    """A plate that faces forward (normal = viewing direction) with markers seen only
    within 35 deg of it: as the cart turns, too few mocap cameras see it."""
    _, truth, out = _measure(["mocap.body_rotvec_deg=[0,0,0]", "mocap.marker_view_deg=35",
                              "mocap.min_views=2"])
    for cam in ("cam_a", "cam_b"):
        s = out.streams[cam]
        occluded = s.drop_reasons.get("occluded", 0)
        assert 0 < occluded < s.n_frames, s.drop_reasons
        assert s.n_used + s.n_dropped == s.n_frames and s.n_dropped >= occluded
        assert np.all(s.info["markers_seen"] >= 3)
        assert set(s.frame_index) <= set(truth.streams[cam].frame_index)
        assert out.log[cam]["occluded_frames"] == occluded


@pytest.mark.slow
def test_offset_error_is_a_constant_bias_in_the_camera_frame():
    cfg, truth, out = _measure(["mocap.marker_sigma_m=0", "mocap.offset_sigma_m=0.003",
                                "mocap.offset_sigma_deg=0.5"])
    for cam in ("cam_a", "cam_b"):
        s, gt = out.streams[cam], truth.streams[cam]
        N = invert_transform(gt.T_world_cam) @ s.T_world_cam      # right-multiplied error
        np.testing.assert_allclose(N, np.broadcast_to(N[0], N.shape), atol=1e-9)
        assert 0.0 < np.linalg.norm(N[0, :3, 3]) < 0.03
        assert 0.0 < math.degrees(np.linalg.norm(rotvec_from_matrix(N[0, :3, :3]))) < 5.0
    bias = get_source("mocap").calibration_bias(truth.world, cfg, ["cam_a"])
    cov = bias["cam_a"].covariance
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), [math.radians(0.5)] * 3 + [0.003] * 3)
    assert bias["cam_a"].report()["std_m"] == pytest.approx([0.003] * 3)
    assert get_source("mocap").calibration_bias(truth.world, load_config(
        "planar", ["streams.a.source=mocap"]), ["cam_a"]) == {}


@pytest.mark.slow
def test_a_run_reports_the_offset_error_in_the_estimate_and_its_sigma(tmp_path):
    """Both cameras tracked, the arm's general motion: the estimate carries the drawn
    offset errors (X_est = N_a^-1 X N_b), and the covariance includes them."""
    from simcalib.pipeline.stages import run
    cfg = load_config("3d", ["source=mocap", "solvers=[dqopt]", "progress=false",
                             "recording.enabled=false", "mocap.marker_sigma_m=0.00005",
                             "mocap.offset_sigma_m=0.002", "mocap.offset_sigma_deg=0.3",
                             f"output={tmp_path}"])
    res = run(cfg)
    (sol,) = res.solvers
    report = res.sensing["calibration_bias"]
    assert report["included"] and report["source"].startswith("mocap.offset_sigma_deg")
    assert set(report["cameras"]) == {"cam_a", "cam_b"}
    assert sol.success and sol.translation_error_m > 5e-4          # the offset, not noise
    # the offset errors are 1-sigma 2 mm / 0.3 deg per axis and camera: the predicted
    # sigma of X covers them (it would not without the bias term)
    assert sol.sigma_translation_m > 2e-3 and sol.sigma_rotation_deg > 0.3
    assert sol.translation_error_m < 4.0 * sol.sigma_translation_m
    assert sol.rotation_error_deg < 4.0 * sol.sigma_rotation_deg


def test_config_section_checks_and_outdoor_platforms():
    cfg = load_config("planar", ["streams.a.source=mocap", "mocap.markers=5",
                                 "mocap.offset_sigma_deg=0.2"])
    assert isinstance(cfg.mocap, MocapConfig) and cfg.mocap.markers == 5
    with pytest.raises(ConfigError, match=r"mocap.markers must be an integer in \[3, 6\]"):
        load_config("planar", ["mocap.markers=2"])
    with pytest.raises(ConfigError, match="mocap.marker_sigma_m"):
        load_config("planar", ["mocap.marker_sigma_m=-1"])
    with pytest.raises(ConfigError, match="tracks inside the room.*'car' drives outdoors"):
        load_config("car", ["source=mocap"])
    m, deg = get_source("mocap").pose_margins(cfg)
    assert 0.0 < m < 0.01 and 0.0 < deg < 2.0
