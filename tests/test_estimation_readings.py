"""The reading of two pose files (simcalib/estimation/readings.py) where the rig only
translates: what the data can tell (an inverted stream, from translations in 3-D) and what
they cannot (in a plane; the quaternion order), and how clearly."""

from __future__ import annotations

import dataclasses

import pytest

from simcalib.estimation.readings import detect_conventions
from simcalib.studies.experiments.recording_kinds import generate, true_streams


def _b_inverted(seed):
    rec = generate("translation", seed)
    a, b = true_streams(rec)
    return a, b.with_inverse(), rec.offset_s


def test_an_inverted_stream_of_a_stage_translating_in_3d_is_told_clearly():
    a, b, off = _b_inverted(0)                     # even seeds: 3-D
    rep = detect_conventions(a, b, offset=off)
    assert rep.invert_b and not rep.invert_a, rep.message
    # the inversion is told clearly (every reading of b as written fits > 3x worse); the
    # quaternion orders are not (no rotation): the files' own order is kept, and said so
    best = min(rep.scores.values())
    assert all(v > 3 * best for k, v in rep.scores.items() if "b: as written" in k)
    assert not rep.swap_scalar_a and not rep.swap_scalar_b and not rep.clear
    assert "closest to the files as written" in rep.message


def test_a_cart_translating_in_a_plane_cannot_tell_an_inverted_stream():
    """In a plane -t is t turned by 180 deg about the normal: both readings fit alike, so
    the reading is not clear (and the files are taken as written, said so)."""
    a, b, off = _b_inverted(1)                     # odd seeds: a plane
    rep = detect_conventions(a, b, offset=off)
    assert not rep.clear and rep.ratio < 1.5, rep.message
    assert "taken as written" in rep.message


def test_the_quaternion_order_is_not_told_without_rotation():
    rec = generate("translation", 0)
    a, b = true_streams(rec)
    a = dataclasses.replace(a, quat_order="xyzw")
    rep = detect_conventions(a, b, offset=rec.offset_s)
    assert not rep.clear and not rep.swap_scalar_a, rep.message


# ------------------------------------------------------------- a mirrored (left-handed) b
def _mirrored_file(stream):
    """``stream`` as a left-handed tool writes it: z negated, quaternions (-x, -y, z, w)."""
    from simcalib.tools.mirror_margin import mirrored_file
    return mirrored_file(stream)


def test_mirrored_negates_z_and_the_quaternions_x_and_y_and_is_its_own_inverse():
    import numpy as np
    from simcalib.estimation.readings import mirrored
    from simcalib.geometry import matrix_from_quat, quat_from_matrix
    rec = generate("continuous", 0)
    b = rec.stream_b
    m = mirrored(b)
    assert np.allclose(m.T_world_sensor, _mirrored_file(b).T_world_sensor, atol=1e-12)
    q = quat_from_matrix(b.T_world_sensor[:, :3, :3]) * np.array([-1.0, -1.0, 1.0, 1.0])
    assert np.allclose(m.T_world_sensor[:, :3, :3], matrix_from_quat(q), atol=1e-12)
    assert np.array_equal(m.T_world_sensor[:, 2, 3], -b.T_world_sensor[:, 2, 3])
    assert np.allclose(np.linalg.det(m.T_world_sensor[:, :3, :3]), 1.0)
    assert np.array_equal(mirrored(m).T_world_sensor, b.T_world_sensor)


def _calibrated_error(rec, b, **kw):
    import math
    from simcalib.estimation.path import calibrate_streams
    from simcalib.geometry import rotation_error_rad
    import numpy as np
    r = calibrate_streams(rec.stream_a, b, **kw)
    return (r, math.degrees(float(rotation_error_rad(r.X, rec.X_true))),
            1e3 * float(np.linalg.norm(r.X[:3, 3] - rec.X_true[:3, 3])))


def test_a_mirrored_b_is_told_and_read_mirrored_so_x_is_right():
    """Stations (6-DoF): b written left-handed fits no proper X as written (X ~180 deg off
    before); read mirrored, X is the true one, and the reading says so."""
    from simcalib.estimation.readings import MIRROR_RATIO
    rec = generate("stations", 0)
    r, rot_deg, trans_mm = _calibrated_error(rec, _mirrored_file(rec.stream_b))
    conv = r.conventions
    assert conv.mirror_b and conv.mirror_ratio > MIRROR_RATIO, conv.message
    assert "MIRRORED" in conv.message and "mirror_b=false" in conv.message
    assert rot_deg < 0.5 and trans_mm < 5.0, (rot_deg, trans_mm)


def test_a_mirrored_b_forced_as_written_is_not_checked():
    rec = generate("stations", 0)
    r, rot_deg, _ = _calibrated_error(rec, _mirrored_file(rec.stream_b), mirror_b=False)
    assert not r.conventions.mirror_b and "MIRRORED" not in r.conventions.message
    assert rot_deg > 90.0           # no proper X fits the mirrored file as written


def test_files_as_written_fit_far_better_than_b_mirrored_and_skip_the_check():
    """b's pitches follow a's (the cheap look): the scoring of the mirrored readings is
    skipped (``mirror_ratio`` NaN); it would have found b mirrored far worse."""
    import math
    from simcalib.estimation.path import first_reading
    from simcalib.estimation.readings import (MIRROR_RATIO, PITCH_AGREEMENT, mirror_ratio,
                                              pitch_agreement)
    from simcalib.estimation.sampling import classify_sampling
    rec = generate("stations", 0)
    r, rot_deg, _ = _calibrated_error(rec, rec.stream_b)
    conv = r.conventions
    assert not conv.mirror_b and math.isnan(conv.mirror_ratio) and rot_deg < 0.5
    assert "MIRRORED" not in conv.message
    smp = classify_sampling(rec.stream_a, rec.stream_b)
    first, off = first_reading(rec.stream_a, rec.stream_b, smp)
    at = dict(offset=off, sampling=smp)
    assert pitch_agreement(rec.stream_a, rec.stream_b, first, **at) > PITCH_AGREEMENT
    assert mirror_ratio(rec.stream_a, rec.stream_b, first, **at) < 1.0 / MIRROR_RATIO
    b = _mirrored_file(rec.stream_b)
    first, off = first_reading(rec.stream_a, b, smp)
    assert pitch_agreement(rec.stream_a, b, first, offset=off, sampling=smp) < 1.0


@pytest.mark.slow
def test_planar_motion_cannot_tell_a_mirrored_b_and_says_so():
    """Rotations about one axis with no translation along it: mirroring leaves them
    unchanged, so both readings fit alike; b stays as written, the reading (its clarity,
    its scores) the one without the check, and its message says the handedness is not
    told, with the mirrored reading's X (here the true one: the file is left-handed)."""
    import math
    from simcalib.estimation.path import align_and_read
    import numpy as np
    from simcalib.estimation.readings import MIRROR_RATIO, mirror_untold_sentence
    from simcalib.estimation.sampling import classify_sampling
    from simcalib.geometry import rotation_error_rad
    rec = generate("planar", 0)
    a, b = rec.stream_a, _mirrored_file(rec.stream_b)
    smp = classify_sampling(a, b)
    kw = dict(time_offset=rec.offset_s, seed=0)
    *_, conv, _, _ = align_and_read(a, b, smp, **kw)
    *_, forced, _, _ = align_and_read(a, b, smp, forced={"mirror_b": False}, **kw)
    assert not conv.mirror_b and 1.0 / MIRROR_RATIO < conv.mirror_ratio < MIRROR_RATIO
    assert math.isnan(forced.mirror_ratio) and forced.mirror_told and forced.mirror_X is None
    assert (conv.ratio, conv.clear, conv.scores) == (forced.ratio, forced.clear, forced.scores)
    assert not conv.mirror_told
    assert conv.message == f"{forced.message}; {mirror_untold_sentence(conv.mirror_ratio)}"
    # b's file is the left-handed one: read mirrored, it is the true b and X the true X
    # (its translation along the vertical undetermined on planar motion)
    assert math.degrees(float(rotation_error_rad(conv.mirror_X, rec.X_true))) < 0.5
    assert np.linalg.norm(conv.mirror_X[:2, 3] - rec.X_true[:2, 3]) < 5e-3


def test_a_mirrored_a_is_told_as_b_mirrored_against_it_and_m_x_m_is_x():
    """Only the relative handedness shows: with a's file left-handed, b is read mirrored
    and ``M X M`` (``M = diag(1, 1, -1)``) is the true X, as the message says."""
    import math
    import numpy as np
    from simcalib.estimation.path import calibrate_streams
    from simcalib.estimation.readings import mirrored
    from simcalib.geometry import rotation_error_rad
    rec = generate("stations", 1)
    r = calibrate_streams(mirrored(rec.stream_a), rec.stream_b)
    M = np.diag([1.0, 1.0, -1.0, 1.0])
    Y = M @ r.X @ M
    assert r.conventions.mirror_b and "M X M" in r.conventions.message
    assert math.degrees(float(rotation_error_rad(Y, rec.X_true))) < 0.5
    assert np.linalg.norm(Y[:3, 3] - rec.X_true[:3, 3]) < 5e-3


@pytest.mark.slow
def test_a_mirrored_scalar_first_b_is_told_with_its_quaternion_order():
    """A left-handed tool writing scalar-first quaternions: the mirror is of the poses,
    after the quaternion order (read in the other order, then z negated)."""
    from simcalib.tools.mirror_margin import mirrored_file
    rec = generate("scalar_first", 0)              # even seeds: b scalar-first
    assert rec.scalar_first_b
    r, rot_deg, trans_mm = _calibrated_error(rec, mirrored_file(rec.stream_b, True))
    conv = r.conventions
    assert conv.mirror_b and conv.swap_scalar_b and not conv.swap_scalar_a, conv.message
    assert rot_deg < 0.5 and trans_mm < 5.0, (rot_deg, trans_mm)


def test_a_readings_score_takes_ransacs_residuals_to_the_bit(monkeypatch):
    import numpy as np

    from simcalib.estimation import readings
    from simcalib.solvers import robust
    from simcalib.world.synthetic import synthetic_problem
    p = synthetic_problem("random", 60, np.random.default_rng(2))
    C, H = p.C, p.H
    rob = robust.ransac(C, H, alpha=1.0, rng=np.random.default_rng(0), max_iterations=256)
    want = float(np.median(robust.screw_residuals(C, H, rob.X, alpha=1.0)))

    def refused(*a, **k):
        raise AssertionError("the residuals of RANSAC's X computed again")
    monkeypatch.setattr(robust, "screw_residuals", refused)
    score, X = readings._reading_score(C, H, 1.0, 0)
    assert score == want and X.tobytes() == rob.X.tobytes()
