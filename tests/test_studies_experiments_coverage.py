"""The determined-direction error of the alpha comparison
(``python -m simcalib.studies.experiments.coverage``)."""

import numpy as np
import pytest

from simcalib.studies.experiments.coverage import alpha_compare, determined_error
from simcalib.geometry import invert_transform, matrix_from_rotvec
from simcalib.geometry import transform_from_rotation_translation as tf
from simcalib.solvers.diagnostics import uncertainty as U
from simcalib.world.synthetic import SyntheticConfig, generate_dataset


def _screw(axis, point, angle, slide=0.0):
    """Rotation by ``angle`` about the line through ``point`` along unit ``axis``, plus a
    translation ``slide`` along it."""
    R = matrix_from_rotvec(np.asarray(axis) * angle)
    return tf(R, (np.eye(3) - R) @ point + slide * np.asarray(axis))


def _one_screw_line(n=30, seed=0):
    """Noise-free motions that are all rotations about one line (a cart turning in place):
    X G fits them for G any screw about that line (in frame b)."""
    rng = np.random.default_rng(seed)
    X = tf(matrix_from_rotvec(np.array([0.4, -0.3, 0.2])), np.array([0.1, 0.25, -0.05]))
    ax, p = np.array([0.0, 0.0, 1.0]), np.array([0.3, -0.2, 0.0])
    H = np.stack([_screw(ax, p, a) for a in rng.uniform(-1.0, 1.0, n)])
    C = X @ H @ invert_transform(X)
    return C, H, X, ax, p


def test_determined_error_ignores_the_undetermined_family():
    C, H, X, ax, p = _one_screw_line()
    # determined basis: range of the noise-free information in tolerance units (as
    # covariance() builds it), independent of the verdict's threshold
    dsc = np.array([np.radians(1.0)] * 3 + [0.01] * 3)
    K = U.linear_model(C, H, X)[1] * dsc
    lam, V = np.linalg.eigh(np.einsum("nki,nkj->ij", K, K))
    basis = V[:, lam > 1e-9 * lam[-1]] * dsc[:, None]
    assert basis.shape[1] == 4                             # rotation about + slide along
    for ang, slide in ((0.05, 0.0), (0.6, 0.3), (2.5, -1.0)):
        Y = X @ _screw(ax, p, ang, slide)                  # fits the data exactly
        assert np.abs(U.linear_model(C, H, Y)[0]).max() < 1e-9
        rot, tr = determined_error(X, Y, basis)
        assert rot < 1e-6 and tr < 1e-8
        assert np.degrees(np.linalg.norm(U.pose_error(X, Y)[:3])) > 1.0
    # a determined perturbation keeps its size (to first order), on top of the family
    Z = X @ _screw(ax, p, 0.7, 0.2)
    Zp = Z.copy()
    Zp[:3, :3] = matrix_from_rotvec(np.array([1e-3, 0.0, 0.0])) @ Z[:3, :3]
    rot, _ = determined_error(X, Zp, basis)
    assert 0.3 * np.degrees(1e-3) < rot < 1.5 * np.degrees(1e-3)
    # all determined: the plain error
    full = np.linalg.qr(np.eye(6))[0]
    rot, tr = determined_error(X, Zp, full)
    e = U.pose_error(X, Zp)
    assert rot == pytest.approx(np.degrees(np.linalg.norm(e[:3])))
    assert tr == pytest.approx(np.linalg.norm(e[3:]))


@pytest.mark.slow
def test_alpha_compare_small():
    cfg = SyntheticConfig(motion="random", num_motions=30)
    ds = [generate_dataset(cfg, r) for r in np.random.default_rng(3).spawn(3)]
    r = alpha_compare("random", [(d.C, d.H, d.X, 0, None, None) for d in ds], np.logspace(-2, 1.7, 5))
    assert r["dof_median"] == 6 and r["det_rot_deg"] == pytest.approx(r["rot_deg"])
    assert r["oracle_rot_deg"] <= r["rot_deg"] * 1.5 and 0.01 <= r["oracle_alpha"] <= 50.2
    assert 0.01 <= r["mpe_alpha_median"] <= 50.2
