"""The linear model's noise null test (simcalib.solvers.diagnostics.linear_model)."""

import numpy as np

from simcalib.solvers.diagnostics.linear_model import _gram_moments


def test_gram_moments_match_the_stacked_gram_matrices():
    """One direction at a time gives the sums of the (6, N, 6, 6) stack of b_i b_i^T."""
    rng = np.random.default_rng(7)
    n = 300
    Bf = rng.normal(size=(n * 36, 6)) * rng.uniform(0.1, 10.0, size=(n * 36, 1))
    G = rng.normal(size=(6, 6))
    b = np.moveaxis((Bf @ G).reshape(n, 6, 6, 6), 3, 0)         # (6 dirs, N, 6, 6)
    gram = b @ np.swapaxes(b, -1, -2)
    mean, square = _gram_moments(Bf, G, n)
    np.testing.assert_allclose(mean, np.trace(gram, axis1=2, axis2=3).sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(square, np.sum(gram * gram, axis=(1, 2, 3)), rtol=1e-12)
