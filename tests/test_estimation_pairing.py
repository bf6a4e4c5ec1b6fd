"""Pairing: timestamp matching, appendix D.1 pre-filter counts, C X = X H on the pairs."""

import numpy as np
import pytest

from simcalib.pipeline.scenario import PairingConfig
from simcalib.geometry import (invert_transform, matrix_from_rotvec, random_rotation_matrices,
                               transform_from_rotation_translation)
from simcalib.estimation.pairing import make_pairs, match_by_timestamp, pairs_from_motions
from simcalib.streams import PoseStream


def _X():
    return transform_from_rotation_translation(
        matrix_from_rotvec(np.deg2rad([2.35, -0.92, -48.93])), [-0.007, 0.281, -0.001])


def _smooth_path(n, rng, step_t=0.02, step_r_deg=1.0):
    """A random walk of small steps (each ~step_t m, ~step_r_deg deg)."""
    rv = rng.normal(size=(n, 3))
    rv *= np.deg2rad(step_r_deg) / np.linalg.norm(rv, axis=1, keepdims=True)
    dt = rng.normal(size=(n, 3))
    dt *= step_t / np.linalg.norm(dt, axis=1, keepdims=True)
    steps = transform_from_rotation_translation(matrix_from_rotvec(rv), dt)
    T = np.empty((n, 4, 4))
    T[0] = np.eye(4)
    for k in range(1, n):
        T[k] = T[k - 1] @ steps[k]
    return T


def _streams(rng, n=60, offset_b=0.0, fps=10.0):
    T_w_a = _smooth_path(n, rng)
    T_w_b = T_w_a @ _X()  # camera b rigidly attached: T_w_b = T_w_a X
    t = np.arange(n) / fps
    a = PoseStream("cam_a", "ground_truth", np.arange(n), t, T_w_a, n)
    b = PoseStream("cam_b", "ground_truth", np.arange(n), t + offset_b, T_w_b, n)
    return a, b


def test_match_by_timestamp_one_to_one():
    ia, ib = match_by_timestamp([0.0, 0.1, 0.2, 0.3], [0.05, 0.12, 0.31, 0.9])
    # 0.1 and 0.2 both want 0.12: the closer (0.1) keeps it; 0.9 has no partner
    assert ia.tolist() == [0, 1, 3]
    assert ib.tolist() == [0, 1, 2]


def test_half_period_offset_matches_every_frame():
    t = np.arange(50) / 10.0
    ia, ib = match_by_timestamp(t, t + 0.05)  # every pose has two equally near neighbours
    assert ia.size >= 49
    assert np.all(np.diff(ia) > 0) and np.all(np.diff(ib) > 0)
    assert np.allclose(np.abs(t[ia] - (t + 0.05)[ib]), 0.05)


def test_sparse_stream_keeps_closest():
    ia, ib = match_by_timestamp(np.arange(10) / 10.0, [0.31, 0.72])
    assert ia.tolist() == [3, 7] and ib.tolist() == [0, 1]


def test_pairs_satisfy_hand_eye_equation(rng):
    a, b = _streams(rng)
    pairs = make_pairs(a, b, PairingConfig())
    X = _X()
    assert pairs.n == 59
    np.testing.assert_allclose(pairs.C @ X, X @ pairs.H, atol=1e-12)
    assert pairs.counts["used"] == 59 and pairs.counts["dropped_translation"] == 0


def test_step_pairs_k_with_k_plus_step(rng):
    a, b = _streams(rng, n=30)
    pairs = make_pairs(a, b, PairingConfig(step=3, prefilter=False))
    assert pairs.n == 27
    assert np.all(pairs.end - pairs.start == 3)
    T = a.T_world_cam
    np.testing.assert_allclose(pairs.C[5], invert_transform(T[5]) @ T[8], atol=1e-12)


def test_prefilter_counts_translation_rotation_and_time(rng):
    a, b = _streams(rng, n=50)
    T_b = b.T_world_cam.copy()
    # a tracking jump of camera b at frame 20 (15 cm) and a rotation glitch at frame 35 (20 deg)
    T_b[20, :3, 3] += [0.15, 0.0, 0.0]
    T_b[35, :3, :3] = T_b[35, :3, :3] @ matrix_from_rotvec(np.deg2rad([0.0, 20.0, 0.0]))
    b2 = PoseStream("cam_b", "visual", b.frame_index, b.timestamp_s, T_b, 50)
    pairs = make_pairs(a, b2, PairingConfig())
    c = pairs.counts
    assert c["matched"] == 50 and c["dropped_time_diff"] == 0
    assert c["dropped_translation"] == 2  # 19->20 and 20->21
    assert c["dropped_rotation"] == 2     # 34->35 and 35->36
    assert c["used"] == c["candidate_pairs"] - 4
    # every surviving pair is an exact motion pair again
    X = _X()
    np.testing.assert_allclose(pairs.C @ X, X @ pairs.H, atol=1e-9)
    # without the pre-filter nothing is dropped
    raw = make_pairs(a, b2, PairingConfig(prefilter=False))
    assert raw.counts["dropped_translation"] == raw.counts["dropped_rotation"] == 0
    assert raw.n > pairs.n


def test_timestamp_difference_filter(rng):
    a, b = _streams(rng, n=50, fps=2.0)
    tb = b.timestamp_s.copy()
    tb[40:45] += 0.2  # camera b late by 0.2 s (> 0.1 s) on frames 40..44
    b2 = PoseStream("cam_b", "visual", b.frame_index, tb, b.T_world_cam, 50)
    inf = float("inf")
    pairs = make_pairs(a, b2, PairingConfig(max_translation_m=inf, max_rotation_deg=inf))
    assert pairs.counts["matched"] == 50
    assert pairs.counts["dropped_time_diff"] == 5
    assert pairs.counts["datapoints"] == 45 and pairs.n == 44
    loose = make_pairs(a, b2, PairingConfig(max_time_diff_s=0.25, max_translation_m=inf,
                                            max_rotation_deg=inf))
    assert loose.counts["dropped_time_diff"] == 0 and loose.n == 49


def test_thresholds_are_configurable():
    a, b = _streams(np.random.default_rng(1), n=40)
    # pure translation of 2 cm per step: both cameras move exactly 2 cm
    T = a.T_world_cam.copy()
    T[:, :3, :3] = np.eye(3)
    T[:, :3, 3] = np.arange(40)[:, None] * np.array([0.02, 0.0, 0.0])
    a = PoseStream("cam_a", "ground_truth", a.frame_index, a.timestamp_s, T, 40)
    b = PoseStream("cam_b", "ground_truth", b.frame_index, b.timestamp_s, T @ _X(), 40)
    with pytest.raises(ValueError, match="only 0 relative motion"):
        make_pairs(a, b, PairingConfig(max_translation_m=0.019))
    ok = make_pairs(a, b, PairingConfig(max_translation_m=0.021))
    assert ok.n == 39


def test_random_mode_is_seeded_and_samples(rng):
    a, b = _streams(rng, n=80)
    cfg = PairingConfig(mode="random", n_pairs=20)
    p1 = make_pairs(a, b, cfg, np.random.default_rng(5))
    p2 = make_pairs(a, b, cfg, np.random.default_rng(5))
    p3 = make_pairs(a, b, cfg, np.random.default_rng(6))
    assert p1.n == 20 and p1.counts["surviving_pairs"] == 79
    assert np.array_equal(p1.start, p2.start)
    assert not np.array_equal(p1.start, p3.start)
    assert len(set(p1.start.tolist())) == 20
    with pytest.raises(TypeError, match="Generator"):
        make_pairs(a, b, cfg, None)


def test_pairs_from_motions_validates(rng):
    R = random_rotation_matrices(rng, (5,))
    C = transform_from_rotation_translation(R, rng.normal(size=(5, 3)))
    p = pairs_from_motions(C, C)
    assert p.n == 5 and p.counts["used"] == 5
    with pytest.raises(ValueError, match="same shape"):
        pairs_from_motions(C, C[:4])
    bad = C.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        pairs_from_motions(bad, C)
