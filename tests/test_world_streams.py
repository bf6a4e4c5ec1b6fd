"""Timing knobs, frame drops, determinism, ground-truth and noisy streams."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from simcalib.geometry import invert_transform, relative_motions
from simcalib.streams import CameraFrames, PoseStream
from simcalib.world import (WorldConfig, build_world, delivered_mask, ground_truth_stream,
                            noisy_stream)

pytest.importorskip("mujoco")

KNOBS = dict(duration_s=10.0, fps=10.0,
             perturbation={"roll_deg": 1.0, "pitch_deg": 1.0, "height_m": 0.01},
             cam_a={"capture_jitter_s": 0.002, "stamp_jitter_s": 0.001, "drop_prob": 0.1},
             cam_b={"capture_offset_s": 0.05, "capture_jitter_s": 0.002,
                    "clock_offset_s": 0.3, "drop_prob": 0.2})


def _arrays(world):
    out = []
    for cam in world.camera_names:
        fr = world.frames(cam)
        out += [fr.time_s, fr.stamp_s, fr.delivered, fr.T_world_cam, fr.qpos, fr.mocap_pos,
                fr.mocap_quat_wxyz]
    return out


@pytest.mark.slow
@pytest.mark.parametrize("platform, path", [("cart", "planar"), ("arm", "3d")])
def test_same_seed_same_world_and_streams(platform, path):
    cfg = WorldConfig(platform=platform, path=path, **KNOBS)
    w1 = build_world(cfg, np.random.default_rng(42))
    w2 = build_world(cfg, np.random.default_rng(42))
    w3 = build_world(cfg, np.random.default_rng(43))
    for a, b in zip(_arrays(w1), _arrays(w2)):
        assert np.array_equal(a, b)
    assert not all(np.array_equal(a, b) for a, b in zip(_arrays(w1), _arrays(w3)))
    n1 = noisy_stream(w1.trajectory.cam_b, 0.01, 0.01, np.random.default_rng(5))
    n2 = noisy_stream(w2.trajectory.cam_b, 0.01, 0.01, np.random.default_rng(5))
    n3 = noisy_stream(w2.trajectory.cam_b, 0.01, 0.01, np.random.default_rng(6))
    assert np.array_equal(n1.T_world_cam, n2.T_world_cam)
    assert not np.allclose(n1.T_world_cam, n3.T_world_cam)


@pytest.mark.slow
def test_time_offset_jitter_and_clock():
    cfg = WorldConfig(platform="cart", path="planar", **KNOBS)
    w = build_world(cfg, np.random.default_rng(0))
    a, b = w.trajectory.cam_a, w.trajectory.cam_b
    nominal = np.arange(cfg.n_frames) / cfg.fps
    assert np.array_equal(a.nominal_time_s, nominal)
    da = a.time_s - nominal
    db = b.time_s - nominal - 0.05
    assert abs(da.mean()) < 0.001 and 0.001 < da.std() < 0.003
    assert abs(db.mean()) < 0.001 and 0.001 < db.std() < 0.003
    assert np.all(np.diff(a.time_s) > 0) and np.all(np.diff(b.time_s) > 0)
    assert np.allclose(b.stamp_s - b.time_s, 0.3)                  # clock offset, no jitter
    sa = a.stamp_s - a.time_s
    assert abs(sa.mean()) < 0.0005 and 0.0005 < sa.std() < 0.0015
    # unsynchronised capture breaks C X = X H by a measurable amount
    i = np.arange(cfg.n_frames - 1)
    C, H = relative_motions(a.T_world_cam, b.T_world_cam, i, i + 1)
    X = w.trajectory.T_a_b
    assert np.abs(C @ X - X @ H).max() > 1e-3
    # ... while each camera still sits where the rig was at its own capture time:
    # cam_b's frame k equals cam_a's pose at the same time composed with X
    cfg_same = WorldConfig(platform="cart", path="planar", duration_s=10.0, fps=10.0,
                           cam_a={"capture_offset_s": 0.05}, cam_b={"capture_offset_s": 0.05})
    w_same = build_world(cfg_same, np.random.default_rng(0))
    cfg_b = WorldConfig(platform="cart", path="planar", duration_s=10.0, fps=10.0,
                        cam_b={"capture_offset_s": 0.05})
    w_b = build_world(cfg_b, np.random.default_rng(0))
    assert np.allclose(w_b.trajectory.cam_b.T_world_cam,
                       w_same.trajectory.cam_a.T_world_cam @ X, atol=1e-12)


def test_drops_are_counted_never_filled():
    cfg = WorldConfig(platform="cart", path="circular", duration_s=50.0, fps=10.0,
                      cam_a={"drop_prob": 0.1}, cam_b={"drop_prob": 0.3})
    w = build_world(cfg, np.random.default_rng(1))
    for cam, p in (("cam_a", 0.1), ("cam_b", 0.3)):
        fr = w.frames(cam)
        n_drop = int((~fr.delivered).sum())
        assert abs(n_drop / fr.n_frames - p) < 0.05
        for s in (ground_truth_stream(fr), noisy_stream(fr, 0.0, 0.0, np.random.default_rng(0))):
            assert isinstance(s, PoseStream)
            assert s.n_frames == fr.n_frames == 501
            assert s.n_dropped == n_drop and s.n_used == fr.n_frames - n_drop
            assert s.drop_reasons == {"frame_dropped": n_drop}
            assert np.array_equal(s.frame_index, np.flatnonzero(fr.delivered))
            assert np.array_equal(s.timestamp_s, fr.stamp_s[fr.delivered])
            assert np.allclose(s.T_world_cam, fr.T_world_cam[fr.delivered])
    # drop decisions of the two cameras are independent
    assert not np.array_equal(w.trajectory.cam_a.delivered, w.trajectory.cam_b.delivered)


def test_ground_truth_stream_exact_and_plain_frames_supported():
    w = build_world(WorldConfig(path="linear", duration_s=5.0), np.random.default_rng(0))
    fr = w.trajectory.cam_a
    gt = ground_truth_stream(fr)
    assert gt.source == "ground_truth" and gt.camera == "cam_a" and gt.n_dropped == 0
    assert gt.drop_reasons == {}
    assert np.array_equal(gt.T_world_cam, fr.T_world_cam)
    plain = CameraFrames("cam_a", fr.time_s, fr.T_world_cam, fr.qpos, fr.mocap_pos,
                         fr.mocap_quat_wxyz)
    assert delivered_mask(plain).all()
    gt2 = ground_truth_stream(plain)
    assert np.array_equal(gt2.timestamp_s, fr.time_s)
    with pytest.raises(TypeError, match="frames must be a CameraFrames"):
        ground_truth_stream(fr.T_world_cam)


@pytest.mark.slow
def test_noisy_stream_follows_eq38_statistics():
    w = build_world(WorldConfig(path="rotation", duration_s=200.0, fps=10.0),
                    np.random.default_rng(0))
    fr = w.trajectory.cam_a
    sr, st = np.deg2rad(0.57), 0.01
    s = noisy_stream(fr, sr, st, np.random.default_rng(9))
    assert s.source == "noisy_ground_truth" and s.n_used == fr.n_frames == 2001
    ang = s.info["noise_rotation_rad"]
    # |angle| of N(0, sr^2) is half-normal: RMS = sr
    assert np.sqrt(np.mean(ang ** 2)) == pytest.approx(sr, rel=0.05)
    # translation noise is applied in the camera frame (T ∘ δ), per-axis RMS = st
    d = invert_transform(fr.T_world_cam) @ s.T_world_cam
    assert np.sqrt(np.mean(d[:, :3, 3] ** 2)) == pytest.approx(st, rel=0.05)
    assert np.allclose(s.info["noise_translation_m"],
                       np.linalg.norm(d[:, :3, 3], axis=1), atol=1e-12)
    zero = noisy_stream(fr, 0.0, 0.0, np.random.default_rng(9))
    assert np.allclose(zero.T_world_cam, fr.T_world_cam, atol=1e-15)
    with pytest.raises(ValueError, match="sigma_r must be finite and >= 0"):
        noisy_stream(fr, -1.0, 0.01, np.random.default_rng(0))
    with pytest.raises(TypeError, match="sigma_t_m must be a number"):
        noisy_stream(fr, 0.01, "1cm", np.random.default_rng(0))
    with pytest.raises(TypeError, match="Generator"):
        noisy_stream(fr, 0.01, 0.01, 3)


def test_build_world_input_checks():
    with pytest.raises(TypeError, match="cfg must be a WorldConfig"):
        build_world({"path": "planar"}, np.random.default_rng(0))
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        build_world(WorldConfig(), 0)
    w = build_world(WorldConfig(duration_s=2.0), np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"unknown camera 'cam_c'; valid: \['cam_a', 'cam_b'\]"):
        w.frames("cam_c")
