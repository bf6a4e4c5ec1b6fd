"""The appendix D.2 generator: motions, eq. 37 relation, eq. 38 noise, sampling, bad input."""

import math

import numpy as np
import pytest

from simcalib.geometry import (
    invert_transform,
    rotation_angle_rad,
    rotvec_from_matrix,
)
from simcalib.world.synthetic import (
    MOTIONS,
    SyntheticConfig,
    config_from_dict,
    generate_batch,
    generate_dataset,
    paper_rig_X,
    sample_indices,
    sample_problems,
    scripted_trajectory,
    synthetic_problem,
)

NOISELESS = dict(sigma_r_rad=0.0, sigma_t_m=0.0, jitter_sigma_r_rad=0.0, jitter_sigma_t_m=0.0)


def test_paper_rig_matches_notes():
    X = paper_rig_X()
    np.testing.assert_allclose(X[:3, 3], [-0.007, 0.281, -0.001])
    np.testing.assert_allclose(np.degrees(rotvec_from_matrix(X[:3, :3])),
                               [2.35, -0.92, -48.93], atol=1e-9)
    np.testing.assert_allclose(SyntheticConfig().X, X)


@pytest.mark.parametrize("motion", MOTIONS)
def test_eq37_holds_exactly_before_noise(motion, rng):
    ds = generate_dataset(SyntheticConfig(motion=motion, num_motions=300), rng)
    assert ds.C.shape == ds.H.shape == (300, 4, 4)
    np.testing.assert_allclose(ds.C_true @ ds.X, ds.X @ ds.H_true, atol=1e-12)
    # measurements differ from the truth (noise present) ...
    assert rotation_angle_rad(invert_transform(ds.H_true) @ ds.H).max() > 1e-3


@pytest.mark.parametrize("motion", MOTIONS)
def test_noise_free_measurements_equal_truth(motion, rng):
    ds = generate_dataset(SyntheticConfig(motion=motion, num_motions=50, **NOISELESS), rng)
    np.testing.assert_allclose(ds.C, ds.C_true, atol=1e-15)
    np.testing.assert_allclose(ds.H, ds.H_true, atol=1e-15)
    np.testing.assert_allclose(ds.C @ ds.X, ds.X @ ds.H, atol=1e-12)


def test_line_is_pure_translation_along_x_without_jitter(rng):
    ds = generate_dataset(SyntheticConfig(motion="line", num_motions=200, **NOISELESS), rng)
    np.testing.assert_allclose(ds.H[:, :3, :3], np.broadcast_to(np.eye(3), (200, 3, 3)),
                               atol=1e-15)
    np.testing.assert_allclose(ds.H[:, :3, 3], np.tile([2.0 / 200, 0, 0], (200, 1)), atol=1e-15)
    T = ds.T_world_b
    assert T.shape == (201, 4, 4)
    np.testing.assert_allclose(T[[0, -1], 0, 3], [0.0, 2.0])


def test_circle_is_planar_rotation_about_one_axis_without_jitter(rng):
    M = 360
    ds = generate_dataset(SyntheticConfig(motion="circle", num_motions=M, **NOISELESS), rng)
    rv = rotvec_from_matrix(ds.H[:, :3, :3])
    # every relative rotation is 1 degree about the body z axis
    np.testing.assert_allclose(rv, np.tile([0, 0, 2 * np.pi / M], (M, 1)), atol=1e-12)
    # translations lie in the plane perpendicular to it: the chord of a 2 m circle
    np.testing.assert_allclose(ds.H[:, 2, 3], 0.0, atol=1e-15)
    chord = 2 * 2.0 * math.sin(np.pi / M)
    np.testing.assert_allclose(np.linalg.norm(ds.H[:, :3, 3], axis=1), chord, rtol=1e-12)
    # the absolute path is one revolution of radius 2 with heading along the tangent
    T = ds.T_world_b
    np.testing.assert_allclose(np.linalg.norm(T[:, :2, 3], axis=1), 2.0, rtol=1e-12)
    np.testing.assert_allclose(T[0], T[-1], atol=1e-12)
    tangent = np.diff(T[:, :3, 3], axis=0)
    heading = T[:-1, :3, 0]
    cos = np.sum(tangent * heading, axis=1) / np.linalg.norm(tangent, axis=1)
    assert cos.min() > math.cos(2 * np.pi / M)
    # the other sensor rotates about the image of the axis: R_X z
    rv_c = rotvec_from_matrix(ds.C[:, :3, :3])
    axis_c = rv_c / np.linalg.norm(rv_c, axis=1, keepdims=True)
    np.testing.assert_allclose(axis_c, np.tile(ds.X[:3, 2], (M, 1)), atol=1e-9)


def test_jitter_breaks_symmetry_with_paper_magnitude(rng):
    cfg = SyntheticConfig(motion="line", num_motions=4000, sigma_r_rad=0.0, sigma_t_m=0.0)
    ds = generate_dataset(cfg, rng)
    ang = rotation_angle_rad(ds.H_true[:, :3, :3])
    # |angle| of a N(0, sigma^2) angle: mean sigma*sqrt(2/pi)
    assert abs(ang.mean() / (cfg.jitter_sigma_r_rad * math.sqrt(2 / math.pi)) - 1) < 0.05
    dy = ds.H_true[:, 1, 3]
    assert abs(dy.std() / cfg.jitter_sigma_t_m - 1) < 0.05


def test_eq38_noise_statistics(rng):
    cfg = SyntheticConfig(motion="random", num_motions=20000,
                          sigma_r_rad=math.radians(2.0), sigma_t_m=0.05)
    ds = generate_dataset(cfg, rng)
    for meas, true in ((ds.H, ds.H_true), (ds.C, ds.C_true)):
        d = invert_transform(true) @ meas
        ang = rotation_angle_rad(d[:, :3, :3])
        assert abs(np.sqrt(np.mean(ang ** 2)) / cfg.sigma_r_rad - 1) < 0.03
        dt = d[:, :3, 3]
        np.testing.assert_allclose(dt.std(axis=0), cfg.sigma_t_m, rtol=0.03)
        assert np.abs(dt.mean(axis=0)).max() < 0.003
    # the two streams get independent noise
    assert not np.allclose(invert_transform(ds.H_true) @ ds.H, invert_transform(ds.C_true) @ ds.C)


def test_random_motion_distribution(rng):
    ds = generate_dataset(SyntheticConfig(motion="random", num_motions=20000, **NOISELESS), rng)
    ang = rotation_angle_rad(ds.H[:, :3, :3])
    # uniform on SO(3): mean angle pi/2 + 2/pi
    assert abs(ang.mean() - (np.pi / 2 + 2 / np.pi)) < 0.02
    t = ds.H[:, :3, 3]
    assert t.min() >= 0.0 and t.max() <= 1.0
    np.testing.assert_allclose(t.mean(axis=0), 0.5, atol=0.01)


def test_deterministic_given_seed():
    a = generate_dataset(SyntheticConfig(motion="circle", num_motions=100),
                         np.random.default_rng(7))
    b = generate_dataset(SyntheticConfig(motion="circle", num_motions=100),
                         np.random.default_rng(7))
    c = generate_dataset(SyntheticConfig(motion="circle", num_motions=100),
                         np.random.default_rng(8))
    np.testing.assert_array_equal(a.C, b.C)
    np.testing.assert_array_equal(a.H, b.H)
    assert not np.allclose(a.C, c.C)


def test_sampling_distinct_within_sample_and_varied_between(rng):
    idx = sample_indices(1000, 500, 100, rng)
    assert idx.shape == (500, 100)
    assert idx.min() >= 0 and idx.max() < 1000
    assert all(len(set(row)) == 100 for row in idx)
    # roughly uniform use of the whole trajectory (not consecutive blocks)
    counts = np.bincount(idx.ravel(), minlength=1000)
    assert counts.min() > 20 and counts.max() < 90
    assert np.mean(np.abs(np.diff(np.sort(idx, axis=1), axis=1)) == 1) < 0.3
    assert len({tuple(np.sort(r)) for r in idx}) == 500
    full = sample_indices(100, 3, 100, rng)
    assert all(sorted(r) == list(range(100)) for r in full)


def test_sample_problems_and_batch_shapes(rng):
    ds = generate_dataset(SyntheticConfig(motion="line", num_motions=300), rng)
    C, H, idx = sample_problems(ds, 7, 100, rng)
    assert C.shape == H.shape == (7, 100, 4, 4)
    np.testing.assert_array_equal(C[3], ds.C[idx[3]])
    np.testing.assert_array_equal(H[6], ds.H[idx[6]])
    C2, H2, X = generate_batch(SyntheticConfig(motion="random", num_motions=200), 5, 50, rng)
    assert C2.shape == (5, 50, 4, 4) and X.shape == (4, 4)


@pytest.mark.parametrize("motion", MOTIONS)
def test_single_problem_for_pipeline(motion):
    prob = synthetic_problem(motion, n=100, rng=np.random.default_rng(3))
    assert prob.C.shape == prob.H.shape == (100, 4, 4)
    np.testing.assert_allclose(prob.X, paper_rig_X())
    np.testing.assert_array_equal(prob.C, prob.dataset.C[prob.indices])
    again = synthetic_problem(SyntheticConfig(motion=motion), n=100, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(prob.C, again.C)


def test_scripted_trajectory_rejects_random():
    with pytest.raises(ValueError, match="line' or 'circle"):
        scripted_trajectory(SyntheticConfig(motion="random"))


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(motion="circel"), ValueError, "did you mean 'circle'"),
    (dict(motion=3), ValueError, "motion must be one of 'random', 'line', 'circle'"),
    (dict(num_motions=1), ValueError, "num_motions must be an integer >= 2; received 1"),
    (dict(num_motions=10.5), ValueError, "num_motions"),
    (dict(sigma_r_rad=-0.1), ValueError, "sigma_r_rad must be finite and >= 0; received -0.1"),
    (dict(sigma_t_m=float("nan")), ValueError, "sigma_t_m"),
    (dict(sigma_t_m="0.01"), TypeError, "sigma_t_m must be a number"),
    (dict(circle_radius_m=0.0), ValueError, "circle_radius_m must be finite and > 0"),
    (dict(X_translation_m=(1, 2)), ValueError, "X_translation_m must be 3 finite numbers"),
])
def test_bad_config_rejected(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        SyntheticConfig(**kwargs)


def test_bad_calls_rejected(rng):
    with pytest.raises(ValueError, match="did you mean 'sigma_r_rad'"):
        config_from_dict({"sigma_r": 0.1})
    with pytest.raises(TypeError, match="numpy.random.Generator"):
        generate_dataset(SyntheticConfig(), 0)
    with pytest.raises(TypeError, match="rng is required"):
        synthetic_problem("line")
    with pytest.raises(ValueError, match="cannot draw n=200 distinct motions from a data set of 100"):
        sample_indices(100, 5, 200, rng)
    with pytest.raises(ValueError, match="num_samples must be an integer >= 1"):
        sample_indices(100, 0, 10, rng)
    with pytest.raises(TypeError, match="SyntheticConfig"):
        generate_dataset({"motion": "line"}, rng)
    cfg = SyntheticConfig().replace(motion="line", num_motions=10)
    assert cfg.motion == "line" and cfg.num_motions == 10
