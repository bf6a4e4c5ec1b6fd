"""Motion generators shared by the solver tests (not a test module)."""

from __future__ import annotations

import numpy as np

from simcalib import geometry as g


def random_X(rng):
    return g.transform_from_rotation_translation(g.random_rotation_matrices(rng),
                                                 rng.normal(scale=0.5, size=3))


def motions_from_C(C, X, rng=None, sigma_r=0.0, sigma_t=0.0):
    H = g.invert_transform(X) @ C @ X
    if sigma_r > 0 or sigma_t > 0:
        H = g.perturb_transforms(H, sigma_r, sigma_t, rng)
    return H


def general_case(rng, n=30, sigma_r=0.0, sigma_t=0.0):
    C = g.transform_from_rotation_translation(g.random_rotation_matrices(rng, n),
                                              rng.normal(size=(n, 3)))
    X = random_X(rng)
    return C, motions_from_C(C, X, rng, sigma_r, sigma_t), X


def planar_case(rng, n=30, axis=(0.0, 0.0, 1.0), sigma_r=0.0, sigma_t=0.0):
    """Camera a rotates about one axis only and translates perpendicular to it."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    ang = rng.uniform(-2.0, 2.0, n)
    R = g.matrix_from_rotvec(ang[:, None] * k)
    t = rng.normal(size=(n, 3))
    t -= (t @ k)[:, None] * k
    C = g.transform_from_rotation_translation(R, t)
    X = random_X(rng)
    return C, motions_from_C(C, X, rng, sigma_r, sigma_t), X, k
