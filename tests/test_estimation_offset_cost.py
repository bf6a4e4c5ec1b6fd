"""The offset cost and how far the data vouch for its offset
(simcalib.estimation.offset_cost): the motions' sharing of poses in the offset's sigma."""

import math

import numpy as np
import pytest

from simcalib.estimation import offset_cost as oc
from simcalib.estimation.alignment import estimate_time_offset
from simcalib.geometry import (matrix_from_rotvec, perturb_transforms,
                               transform_from_rotation_translation)
from simcalib.studies.experiments.recording_kinds import generate, true_streams


def _rig(freq_hz, seed=0, duration_s=20.0):
    """a at 100 Hz, b at 30 Hz on one rig moving as sinusoids of ``freq_hz`` (translation
    ~0.2 m, rotation ~30 deg), the paper's pose noise (a 0.02 deg / 0.2 mm, b 0.1 deg /
    1 mm), no offset."""
    rng = np.random.default_rng(seed)

    def poses(t):
        w = 2 * np.pi * freq_hz * t
        p = 0.2 * np.stack([np.sin(w), np.cos(1.3 * w), np.sin(0.7 * w + 1.0)], 1)
        rv = np.stack([0.5 * np.sin(w + 0.3), 0.4 * np.sin(1.1 * w + 1.0),
                       0.3 * np.cos(0.9 * w)], 1)
        return transform_from_rotation_translation(matrix_from_rotvec(rv), p)
    X = transform_from_rotation_translation(matrix_from_rotvec(np.array([0.2, -0.1, 0.3])),
                                            np.array([0.05, 0.02, -0.03]))
    ta, tb = np.arange(0.0, duration_s, 0.01), np.arange(0.003, duration_s, 1.0 / 30.0)
    A = perturb_transforms(poses(ta), math.radians(0.02), 2e-4, rng)
    B = perturb_transforms(poses(tb) @ X, math.radians(0.1), 1e-3, rng)
    return ta, A, tb, B


def test_the_sharing_of_poses_follows_the_path():
    """Each reference pose ends one motion of the cost and starts the next, so its noise
    enters both. Along a path smooth over a step it enters them with opposite signs and
    cancels in the cost's slope: no more than independent motions' noise (THIN_MIN). On a
    path that reverses every step (period 2 s, motions of 1 s) it adds up: close to
    twice (THIN_MAX, the factor once assumed for every recording, which made the offset's
    sigma 1.4x too wide on average on the generated stages that translate without
    turning, up to 2.6x on a slow one, and hid a 4 ms offset behind 0)."""
    kw = dict(step_s=1.0, alpha=1.0, smooth_s=0.01)
    smooth = oc.OffsetCost(*_rig(0.1), (-0.07, 0.07), **kw)
    reversing = oc.OffsetCost(*_rig(0.5), (-0.07, 0.07), **kw)
    assert smooth.thin_at(0.0) == oc.THIN_MIN == 1.0
    assert 1.7 < reversing.thin_at(0.0) <= oc.THIN_MAX == 2.0
    # the sigma follows: same curvature formula, the sharing's factor inside
    r = oc._Refined(0.0, *oc._refine(reversing, 0.0, 0.07), reversing)
    _, sigma = oc._offset_and_sigma(r)
    _, worst = oc._offset_and_sigma(r, worst_case=True)
    assert sigma == pytest.approx(worst * math.sqrt(reversing.thin_at(r.best) / 2.0))


@pytest.mark.parametrize("seed, offset_s", [(13, None), (9, -0.004)])
def test_a_slow_stage_that_does_not_turn_tells_a_few_ms_offset(seed, offset_s):
    """A cart translating slowly without turning: only the translation speeds tell the
    offset. The refined offset was within 0.9 ms of the truth, but with every reference
    pose's noise counted twice its sigma was 1.5 / 1.2 ms, 0 was not worse beyond 3 sigma
    and was used: 3.9 / 4 ms off (translation seed 13's miss in docs/recordings.md).
    Counted as the path shares the poses, the offset is told."""
    kw = {} if offset_s is None else {"offset_s": offset_s}
    rec = generate("translation", seed, **kw)
    est = estimate_time_offset(*true_streams(rec))
    assert est.signal == "translation" and est.decision == "estimated", est.message
    assert abs(est.offset_s - rec.offset_s) < 1e-3, est.message
    assert abs(est.offset_s - rec.offset_s) < 3.0 * est.uncertainty_s
