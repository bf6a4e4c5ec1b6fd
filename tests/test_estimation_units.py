"""simcalib/estimation/units.py: streams in different length units are refused, with the
scale, before any solve; streams that cannot tell are left alone."""

from __future__ import annotations

import numpy as np
import pytest

from simcalib import geometry as g
from simcalib.errors import DataError
from simcalib.estimation.units import MIN_MOTIONS, check_translation_units, pitch_scale


def _motions(rng, n, planar=False):
    X = g.transform_from_rotation_translation(g.matrix_from_rotvec([0.3, -0.2, 0.5]),
                                              [0.08, -0.03, 0.12])
    if planar:
        rv = np.zeros((n, 3))
        rv[:, 2] = rng.uniform(0.2, 1.0, n) * rng.choice([-1, 1], n)
        t = np.column_stack([rng.normal(size=(n, 2)), np.zeros(n)])
        X = g.transform_from_rotation_translation(np.eye(3), [0.1, 0.2, 0.3])
    else:
        rv = rng.normal(scale=0.6, size=(n, 3))
        t = rng.normal(size=(n, 3))
    C = g.transform_from_rotation_translation(g.matrix_from_rotvec(rv), t)
    H = g.invert_transform(X) @ C @ X
    return C, H


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_equal_units_pass_and_give_a_scale_of_one(seed):
    C, H = _motions(np.random.default_rng(seed), 40)
    H = g.perturb_transforms(H, 0.005, 0.002, np.random.default_rng(seed + 10))
    s = check_translation_units(C, H)
    assert abs(s - 1.0) < 0.05, s


@pytest.mark.parametrize("factor", [1000.0, 100.0, 1 / 1000.0, 39.37, 3.2808])
def test_other_units_are_refused_with_the_scale(factor):
    C, H = _motions(np.random.default_rng(3), 40)
    H = H.copy()
    H[:, :3, 3] *= factor
    with pytest.raises(DataError, match="different units") as e:
        check_translation_units(C, H)
    assert f"{factor:.3g} times" in str(e.value)


def test_a_factor_within_the_ratio_and_outlier_motions_are_not_refused():
    rng = np.random.default_rng(4)
    C, H = _motions(rng, 40)
    H2 = H.copy()
    H2[:, :3, 3] *= 2.0                       # no pair of length units is 2 apart
    assert abs(check_translation_units(C, H2) - 2.0) < 1e-9
    H3 = H.copy()
    bad = rng.random(40) < 0.3                 # 30 % outlier motions
    H3[bad, :3, 3] += rng.normal(scale=5.0, size=(int(bad.sum()), 3))
    assert abs(check_translation_units(C, H3) - 1.0) < 0.05


def test_motions_that_cannot_tell_are_left_alone():
    C, H = _motions(np.random.default_rng(5), 40, planar=True)   # no pitch at all
    H = H.copy()
    H[:, :3, 3] *= 1000.0
    check_translation_units(C, H)
    C, H = _motions(np.random.default_rng(6), MIN_MOTIONS - 1)
    H = H.copy()
    H[:, :3, 3] *= 1000.0
    check_translation_units(C, H)
    s, r1, rs, n = pitch_scale(C[:0], H[:0])
    assert np.isnan(s) and n == 0


def test_pure_translation_compares_the_translation_norms():
    """Motions that do not turn carry no rotation axis, but |t_C| = |t_H| for them
    (t_C = R_X t_H): equal units give 1, millimetres against metres are refused."""
    rng = np.random.default_rng(5)
    X = g.transform_from_rotation_translation(g.matrix_from_rotvec([0.3, -0.2, 0.5]),
                                              [0.08, -0.03, 0.12])
    H = g.transform_from_rotation_translation(np.broadcast_to(np.eye(3), (40, 3, 3)),
                                              rng.normal(scale=0.2, size=(40, 3)))
    C = X @ H @ g.invert_transform(X)
    C = g.perturb_transforms(C, np.radians(0.05), 0.001, rng)
    assert abs(check_translation_units(C, H) - 1.0) < 0.05
    H_mm = H.copy()
    H_mm[:, :3, 3] *= 1000.0
    with pytest.raises(DataError, match=r"stream b moves (999|1e\+03) times as far"):
        check_translation_units(C, H_mm)
