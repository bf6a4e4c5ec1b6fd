"""simcalib.estimation.signals against the scipy functions it stands in for."""

import numpy as np
import pytest
from scipy.ndimage import median_filter
from scipy.signal import correlate, correlation_lags, fftconvolve

from simcalib.estimation.signals import (_medians, correlate_full, correlation_lags_full,
                                        despike, DESPIKE_FILTERS, fft_convolve, running_median)


@pytest.mark.parametrize("nx, ny", [(1, 1), (7, 3), (100, 173), (1000, 999), (2, 50)])
def test_correlation_matches_scipy(nx, ny):
    rng = np.random.default_rng(nx * 1000 + ny)
    x, y = rng.standard_normal(nx), rng.standard_normal(ny)
    np.testing.assert_allclose(correlate_full(x, y), correlate(x, y, mode="full"),
                               rtol=1e-10, atol=1e-10)
    np.testing.assert_array_equal(correlation_lags_full(nx, ny),
                                  correlation_lags(nx, ny, mode="full"))


@pytest.mark.parametrize("shape, half", [((50,), 3), ((37, 6, 6), 10), ((5, 2), 0)])
def test_convolution_matches_scipy_along_the_first_axis(shape, half):
    rng = np.random.default_rng(len(shape) + half)
    a = rng.standard_normal(shape)
    k = np.exp(-0.5 * (np.arange(-half, half + 1) / 2.5) ** 2)
    ref = fftconvolve(a, k.reshape((-1,) + (1,) * (a.ndim - 1)), mode="full", axes=0)
    np.testing.assert_allclose(fft_convolve(a, k, axis=0), ref, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("n, size", [(1, 3), (2, 9), (20, 3), (101, 9), (64, 5)])
def test_running_median_matches_scipy(n, size):
    w = np.random.default_rng(n + size).standard_normal(n)
    w[::7] = 50.0                                   # spikes
    np.testing.assert_array_equal(running_median(w, size),
                                  median_filter(w, size=size, mode="nearest"))


@pytest.mark.parametrize("size", [0, 4, 2.5])
def test_running_median_refuses_an_even_or_broken_window(size):
    with pytest.raises(ValueError, match="odd window size"):
        running_median(np.arange(5.0), size)


def test_despiking_takes_an_outlier_pose_at_an_end_and_a_cluster_of_them():
    t = np.arange(600) / 30.0
    clean = 0.3 + 0.1 * np.sin(t)
    w = clean.copy()
    w[-2:] = [5.5, 5.9]                     # an outlier pose next to the end: two spikes
    w[100:105] = 16.0                        # outlier poses close together
    w[101] = 0.3
    out = despike(w)
    assert out.max() < 0.5 and np.abs(out - clean)[20:-20].max() < 0.05
    assert np.array_equal(despike(clean), despike(clean))
    smooth = 0.3 + 0.2 * np.sin(t)          # a motion keeps the first filter
    assert np.array_equal(despike(smooth), _medians(smooth, *DESPIKE_FILTERS[0]))



def test_despike_takes_the_first_filter_early_only_where_the_full_rule_would():
    """The shortcut (the first filter's peak within twice the floor under every later
    filter's peak) picks what comparing every filter picks, on smooth and spiky speeds."""
    def every_filter(w):
        outs = [_medians(w, size, mode) for size, mode in DESPIKE_FILTERS]
        peaks = np.array([np.max(o) for o in outs])
        for k, out in enumerate(outs[:-1]):
            if not peaks[k] > 2.0 * np.min(peaks[k + 1:]):
                return out
        return outs[-1]
    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(5, 800))
        w = np.abs(rng.standard_normal(n)) * rng.uniform(0.1, 1) + np.sin(
            np.arange(n) / rng.uniform(3, 80))
        spikes = rng.random(n) < rng.uniform(0, 0.4)
        w[spikes] += rng.uniform(0, 30, spikes.sum())
        assert np.array_equal(despike(w), every_filter(w))
