"""simcalib/estimation/scale.py: the scale of stream b's translations against a's, and the
calibrate key ``scale_b`` (auto / estimate / a number) through the estimation path."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from simcalib.errors import ConfigError, DataError
from simcalib.estimation.scale import (CLEAR_SIGMAS, TOLERANCE, ScaleEstimate, decide,
                                       check_scale_b, estimate_scale, scale_covariance,
                                       scaled_motions)
from simcalib.geometry import (invert_transform, matrix_from_rotvec,
                               random_rotation_matrices, transform_from_rotation_translation)
from simcalib.solvers.diagnostics.inputs import pose_error


def _rig(rng, n=30, planar=False):
    """Exact poses of a rigid pair: a's ``T_wa_a``, b's ``T_wb_b = Y^-1 T_wa_a X``."""
    X = transform_from_rotation_translation(random_rotation_matrices(rng),
                                            rng.uniform(-0.2, 0.2, 3))
    Y = transform_from_rotation_translation(random_rotation_matrices(rng),
                                            rng.normal(0.0, 1.0, 3))
    if planar:
        yaw = rng.uniform(-np.pi, np.pi, n)
        R = matrix_from_rotvec(np.column_stack([np.zeros((n, 2)), yaw]))
        p = np.column_stack([rng.uniform(-2, 2, (n, 2)), np.zeros(n)])
    else:
        R = matrix_from_rotvec(rng.normal(0.0, 0.8, (n, 3)))
        p = rng.uniform(-0.5, 0.5, (n, 3))
    A = transform_from_rotation_translation(R, p)
    return A, invert_transform(Y)[None] @ A @ X[None], X


def _pairs(A, B):
    i, j = np.triu_indices(A.shape[0], k=1)
    return invert_transform(A[i]) @ A[j], invert_transform(B[i]) @ B[j], i, j


@pytest.mark.parametrize("s", [0.31, 0.8, 1.0, 1.7, 2.9, 1000.0])
def test_known_scale_recovered_from_exact_motions(s):
    A, B, _ = _rig(np.random.default_rng(3))
    C, H, i, j = _pairs(A, scaled_motions(B, s))
    e = estimate_scale(C, H, i=i, j=j)
    assert e.determined and abs(e.scale / s - 1.0) < 1e-11, e
    assert e.sigma < 1e-9 * s and abs(e.pitch_scale / s - 1.0) < 1e-9
    assert s == 1.0 or e.fit_gain > 1e6


def test_scale_robust_to_outlier_motions():
    rng = np.random.default_rng(4)
    A, B, _ = _rig(rng, n=40)
    C, H, i, j = _pairs(A, scaled_motions(B, 1.4))
    bad = rng.random(C.shape[0]) < 0.15
    H = H.copy()
    H[bad, :3, 3] += rng.normal(0.0, 0.3, (int(bad.sum()), 3))
    e = estimate_scale(C, H, i=i, j=j)
    assert e.determined and abs(e.scale / 1.4 - 1.0) < 2e-3, e


def test_planar_motion_tells_the_scale_where_the_pitch_cannot():
    """A vehicle (rotations about one axis: no pitch) on arcs of many centres: the pitch
    invariant has nothing, the linear fit with X's rotation still has the scale."""
    A, B, _ = _rig(np.random.default_rng(5), planar=True)
    C, H, i, j = _pairs(A, scaled_motions(B, 1.5))
    e = estimate_scale(C, H, i=i, j=j)
    assert e.determined and abs(e.scale / 1.5 - 1.0) < 1e-8, e


def test_undeterminable_scales_are_reported():
    rng = np.random.default_rng(6)
    A, B, _ = _rig(rng, n=12)
    C, H, i, j = _pairs(A, B)
    few = estimate_scale(C[:4], H[:4], i=i[:4], j=j[:4])
    assert not few.determined and "too few" in few.reason
    # pure rotation: every pose at the origin of both worlds (sensors at the rig's centre)
    R = A.copy()
    R[:, :3, 3] = 0.0
    Cr, Hr, ir, jr = _pairs(R, R)
    e = estimate_scale(Cr, Hr, i=ir, j=jr)
    assert not e.determined and "pure rotation" in e.reason
    # arcs about ONE centre (a vehicle circling a fixed point): the scale and X's
    # translation trade off exactly
    yaw = np.linspace(0.0, 2.0, 12)
    P = transform_from_rotation_translation(
        matrix_from_rotvec(np.column_stack([np.zeros((12, 2)), yaw])), np.zeros((12, 3)))
    off = transform_from_rotation_translation(np.eye(3), [1.0, 0.3, 0.2])
    Ca, Hb, ia, ja = _pairs(P @ off, P @ off)
    noisy = Hb.copy()
    noisy[:, :3, 3] += np.random.default_rng(1).normal(0, 1e-4, noisy[:, :3, 3].shape)
    e2 = estimate_scale(Ca, noisy, i=ia, j=ja)
    assert not e2.determined and e2.reason, e2
    with pytest.raises(DataError, match="scale_b=estimate: the data cannot tell"):
        decide("estimate", e2)
    kept = decide("auto", e2)
    assert kept.used == 1.0 and kept.decision == "not_told"


def test_decision_auto_keeps_one_within_tolerance_or_sigma():
    def est(s, sig, gain=30.0):
        return ScaleEstimate(s, sig, s, True, 100, 50, fit_gain=gain)
    assert decide("auto", est(1.0 + 0.5 * TOLERANCE, 1e-6)).used == 1.0        # tolerance
    assert decide("auto", est(1.2, 0.2 / (CLEAR_SIGMAS - 1))).used == 1.0       # sigma
    little = decide("auto", est(1.2, 0.001, gain=1.5))     # other errors, not a scale
    assert little.used == 1.0 and "explains little" in little.message
    d = decide("auto", est(1.2, 0.001))
    assert d.used == 1.2 and d.decision == "rescaled" and d.sigma_used == 0.001
    assert "monocular SLAM" in d.message and "target" in d.message
    assert decide("estimate", est(1.01, 0.001)).used == 1.01
    g = decide(2.0, None)
    assert g.used == 2.0 and g.decision == "given" and g.sigma_used == 0.0


def test_scale_covariance_is_the_jacobian_times_sigma():
    A, B, X = _rig(np.random.default_rng(7))
    C, H, _, _ = _pairs(A, B)
    w = np.ones(C.shape[0])
    S = scale_covariance(C, H, w, 0.01)
    # X's translation moves with the scale (here: rotations of 0.8 rad, a lever of ~0.3 m)
    assert np.all(np.linalg.eigvalsh(S) >= -1e-18) and np.trace(S[3:, 3:]) > 1e-8
    from simcalib.solvers.batch_solve import solve_batch
    X2 = solve_batch(C[None], scaled_motions(H, 1.0 / 1.01)[None], method="dqopt").X[0]
    d = pose_error(X2, X)
    assert np.allclose(np.sqrt(np.diag(S)), np.abs(d), rtol=0.05, atol=1e-9)


# ------------------------------------------------------------------- the config key
@pytest.mark.parametrize("value", ["-1", "0", "inf", "nan", "abc", "[1,2]"])
def test_bad_scale_b_is_a_one_line_config_error(value, tmp_path):
    from simcalib.pipeline.calibrate import parse_options
    with pytest.raises(ConfigError) as e:
        parse_options([f"a={tmp_path}/a.txt", f"b={tmp_path}/b.txt",
                       f"output={tmp_path}/o", f"scale_b={value}"])
    msg = str(e.value)
    assert "\n" not in msg and "scale_b" in msg and "received" in msg
    assert "auto" in msg and "estimate" in msg


@pytest.mark.parametrize("value", [-1, 0, float("nan"), True, "x", None])
def test_bad_scale_b_is_refused_by_the_library_too(value):
    """calibrate_streams checks the key where it enters, as the command does."""
    from simcalib.estimation.path import calibrate_streams
    with pytest.raises(ConfigError, match="scale_b must be auto, estimate or a finite"):
        calibrate_streams("never-read-a.txt", "never-read-b.txt", scale_b=value)


def test_good_scale_b_values_parse(tmp_path):
    from simcalib.pipeline.calibrate import parse_options
    base = [f"a={tmp_path}/a.txt", f"b={tmp_path}/b.txt", f"output={tmp_path}/o"]
    assert parse_options(base).scale_b == "auto"
    assert parse_options(base + ["scale_b=estimate"]).scale_b == "estimate"
    assert parse_options(base + ["scale_b=0.001"]).scale_b == 0.001


# ------------------------------------------------------------------ through the path
def _calibrate(rec, **kw):
    from simcalib.estimation.path import calibrate_streams
    return calibrate_streams(rec.stream_a, rec.stream_b, **kw)


def _scaled(rec, s):
    T = np.array(rec.stream_b.T_world_sensor)
    T[:, :3, 3] *= s
    return dataclasses.replace(rec, stream_b=dataclasses.replace(rec.stream_b,
                                                                 T_world_sensor=T))


@pytest.mark.slow
@pytest.mark.parametrize("kind, seed", [("scale", 0), ("scale", 1), ("scale_stations", 2),
                                        ("scale_stations", 3)])
def test_noisy_recording_of_each_side_is_rescaled(kind, seed):
    from simcalib.studies.experiments.recording_kinds import generate
    rec = generate(kind, seed)
    assert (rec.scale_b < 1.0) == (seed % 2 == 0) and 0.3 <= rec.scale_b <= 3.0
    r = _calibrate(rec)
    sc = r.scale
    assert sc.decision == "rescaled" and sc.mode == "auto"
    e = sc.estimate
    assert abs(e.scale - rec.scale_b) < max(4.0 * e.sigma, 1e-3 * rec.scale_b), (e, rec.scale_b)
    err = pose_error(rec.X_true, r.X)
    assert np.degrees(np.linalg.norm(err[:3])) < 0.2 and np.linalg.norm(err[3:]) < 3e-3
    assert abs(sc.check.scale - 1.0) < 5.0 * sc.check.sigma + 1e-9
    # the scale's sigma is in X's covariance: above the same data's at the given scale
    g = _calibrate(rec, scale_b=sc.used)
    np.testing.assert_allclose(g.X, r.X, atol=1e-12)
    assert np.trace(r.covariance_determined) > np.trace(g.covariance_determined)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["continuous", "stations"])
def test_auto_leaves_metric_data_alone_bit_for_bit(kind):
    from simcalib.studies.experiments.recording_kinds import generate
    rec = generate(kind, 1)
    auto, one = _calibrate(rec), _calibrate(rec, scale_b=1.0)
    assert auto.scale.decision == "kept" and auto.scale.estimate.determined
    assert abs(auto.scale.estimate.scale - 1.0) < 0.01
    np.testing.assert_array_equal(auto.X, one.X)
    np.testing.assert_array_equal(auto.covariance, one.covariance)


@pytest.mark.slow
def test_units_far_apart_refused_in_auto_and_estimated_on_request():
    from simcalib.studies.experiments.recording_kinds import generate
    rec = _scaled(generate("stations", 1), 1000.0)         # b in mm, a in m
    with pytest.raises(DataError, match="different units.*scale_b=estimate"):
        _calibrate(rec)
    r = _calibrate(rec, scale_b="estimate")
    assert abs(r.scale.used / 1000.0 - 1.0) < 0.01
    err = pose_error(generate("stations", 1).X_true, r.X)
    assert np.linalg.norm(err[3:]) < 3e-3
    given = _calibrate(rec, scale_b=1000.0)
    assert given.scale.decision == "given" and abs(given.scale.check.scale - 1.0) < 0.01
    assert math.isfinite(given.scale.check.sigma)


def test_the_messages_give_the_number_that_divides_b_the_right_way():
    """scale_b divides b's translations: b in mm against a in m is 1000 (the messages once
    said 0.001, which would have multiplied the error by 1e6)."""
    from simcalib.estimation.path import UNITS_HINT
    assert "1000 for b in mm against a in m" in UNITS_HINT and "0.001" not in UNITS_HINT
    with pytest.raises(ConfigError, match="1000 for b in mm against a in m"):
        check_scale_b(-1)


@pytest.mark.parametrize("batch_motions", [None, 1])
def test_jackknife_blocks_solved_together_give_each_block_s_own_numbers(batch_motions,
                                                                       monkeypatch):
    """The jackknife's blocks go through one batch of solves per iteration (or several
    batches when the motions exceed BATCH_MOTIONS): each block's scale is bit for bit
    what its own alternation gives, a block without a positive scale is NaN and the
    1-sigma is the one of the block-by-block estimates."""
    import simcalib.estimation.scale as sc
    if batch_motions is not None:
        monkeypatch.setattr(sc, "BATCH_MOTIONS", batch_motions)
    rng = np.random.default_rng(11)
    A, B, _ = _rig(rng, n=25)
    B = B.copy()
    B[:, :3, 3] += rng.normal(0.0, 2e-3, (B.shape[0], 3))    # noise: the blocks differ
    C, H, i, j = _pairs(A, scaled_motions(B, 1.3))
    H[:3, :3, 3] *= -1.0     # a block of these alone has no positive scale
    w = rng.uniform(0.5, 1.0, C.shape[0])
    s0 = sc._alternate(C, H, w, 1.0, 1.0)[0]
    blocks = [np.where(keep, w, 0.0) for keep in sc._blocks(25, i, j)]
    one_by_one = np.array([sc._alternate(C, H, wk, s0, 1.0, robust=False, iterations=20)[0]
                           for wk in blocks])
    assert np.isfinite(one_by_one).all() and np.unique(one_by_one).size == len(blocks)
    g = one_by_one.size
    sigma = math.sqrt((g - 1) / g * np.sum((one_by_one - one_by_one.mean()) ** 2))
    assert sc._jackknife_sigma(C, H, w, s0, 1.0, i, j, 25) == sigma
    few = np.zeros_like(w)
    few[:3] = 1.0            # the flipped motions: NaN, as one by one
    W = np.stack(blocks + [few])
    got = np.concatenate([sc._alternate_blocks(C, H, W[b:b + 4], s0, 1.0, 20)
                          for b in range(0, W.shape[0], 4)])
    assert np.array_equal(got[:-1], one_by_one)
    assert math.isnan(got[-1]) and math.isnan(
        sc._alternate(C, H, few, s0, 1.0, robust=False, iterations=20)[0])
