"""The few signal operations the estimation path needs, in numpy alone.

``scipy.signal`` would give them too, but importing it costs ~0.7 s per process (it pulls
in ``scipy.stats`` and parses their docstrings), which is a third of ``calibrate``'s
wall time on a small recording. Each function here matches its ``scipy.signal`` /
``scipy.ndimage`` counterpart to rounding (``tests/test_estimation_signals.py``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["fft_convolve", "correlate_full", "correlation_lags_full", "running_median", "despike",
           "DESPIKE_FILTERS"]


def _fft_length(n: int) -> int:
    """A length >= ``n`` whose FFT is fast (a product of 2, 3 and 5)."""
    best = 1 << max(0, int(n - 1).bit_length())
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


def fft_convolve(a: np.ndarray, kernel: np.ndarray, axis: int = 0) -> np.ndarray:
    """The full linear convolution of ``a`` with the 1-D ``kernel`` along ``axis`` (length
    ``a.shape[axis] + kernel.size - 1``), by real FFT."""
    a = np.asarray(a, np.float64)
    kernel = np.asarray(kernel, np.float64).ravel()
    n_out = a.shape[axis] + kernel.size - 1
    n = _fft_length(n_out)
    shape = [1] * a.ndim
    shape[axis] = -1
    spec = np.fft.rfft(a, n, axis=axis) * np.fft.rfft(kernel, n).reshape(shape)
    out = np.fft.irfft(spec, n, axis=axis)
    return np.take(out, np.arange(n_out), axis=axis)


def correlate_full(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``scipy.signal.correlate(x, y, mode="full")`` for real 1-D arrays: entry k is
    ``sum_i x[i + k - (y.size - 1)] * y[i]``."""
    return fft_convolve(np.asarray(x, np.float64), np.asarray(y, np.float64)[::-1])


def correlation_lags_full(x_size: int, y_size: int) -> np.ndarray:
    """``scipy.signal.correlation_lags(x_size, y_size, mode="full")``: the lag of each entry
    of :func:`correlate_full`."""
    return np.arange(-int(y_size) + 1, int(x_size))


def running_median(w: np.ndarray, size: int, mode: str = "edge") -> np.ndarray:
    """``scipy.ndimage.median_filter(w, size=size, mode="nearest")`` of a 1-D array: the
    median over ``size`` (odd) samples centred on each (the ends repeated outward;
    ``mode="symmetric"``: the samples next to an end mirrored outward, ``np.pad``'s
    modes)."""
    if int(size) != size or size < 1 or size % 2 == 0:
        raise ValueError(f"running_median needs an odd window size >= 1; received {size!r}")
    w = np.asarray(w, np.float64)
    if w.size == 0 or size == 1:
        return w.copy()
    half = int(size) // 2
    padded = np.pad(w, (half, half), mode=mode)
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, int(size)), axis=1)


#: running-median windows (samples) and their padding at the ends, tried in turn to
#: despike a speed signal (:func:`despike`)
DESPIKE_FILTERS = ((9, "edge"), (9, "symmetric"), (15, "symmetric"), (21, "symmetric"),
                   (27, "symmetric"))


def despike(w: np.ndarray) -> np.ndarray:
    """Speeds with outlier poses' spikes removed: a running median over 9 samples (two
    passes), which ignores spikes below half of a window (an outlier pose makes two
    adjacent spikes), then a short median over 3. Where spikes survive, the next filter of
    :data:`DESPIKE_FILTERS` whose peak is at most twice every later filter's is taken (a
    motion keeps its peak through a wider median, spikes do not): an
    outlier pose next to an end (the end's value repeated outward kept its two spikes: 6
    rad/s on a motion of 0.3), or outlier poses close enough together to fill half a window
    (10 % of a 30 Hz camera's poses, some in pairs: spikes of 17 rad/s survived and the
    correlation with the clean speeds fell to 0.18)."""
    first = _medians(w, *DESPIKE_FILTERS[0])
    if not first.size or np.max(first) <= 2.0 * _peak_floor(w):
        return first                        # no later filter's peak can fall below half
    outs = [first] + [_medians(w, size, mode) for size, mode in DESPIKE_FILTERS[1:]]
    peaks = np.array([np.max(o) for o in outs])
    for k, out in enumerate(outs[:-1]):
        if not peaks[k] > 2.0 * np.min(peaks[k + 1:]):
            return out
    return outs[-1]


def _peak_floor(w: np.ndarray) -> float:
    """A floor under the peak of every later filter of :data:`DESPIKE_FILTERS`: the highest
    level that ``2 (size - 1) + 3`` consecutive samples all reach (the widest size's),
    which each of its running medians keeps at the run's middle. Where the first filter's
    peak is at most twice it, :func:`despike` takes the first filter without running the
    others (on smooth speeds: 10x less work; the same choice)."""
    span = max(2 * (size - 1) + 3 for size, _ in DESPIKE_FILTERS[1:])
    w = np.asarray(w, np.float64)
    if w.size < span:
        return -np.inf
    return float(np.max(np.min(np.lib.stride_tricks.sliding_window_view(w, span), axis=1)))


def _medians(w: np.ndarray, size: int, mode: str) -> np.ndarray:
    for _ in range(2):
        w = running_median(w, size, mode)
    return running_median(w, 3, mode)
