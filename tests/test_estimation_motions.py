"""Motion formation (simcalib.estimation.motions): the stations of stop-and-go bursts,
found by rotation and by translation."""

import numpy as np

from simcalib.estimation.motions import (STATION_SPREAD_M, STATION_STEP_M, form_motions,
                                         station_runs)
from simcalib.estimation.sampling import classify_sampling, pair_by_stamp
from simcalib.geometry import transform_from_rotation_translation
from simcalib.importers import stream_from_arrays


def _gantry(stations=6, frames=4, jitter_m=0.0, step_m=0.2, rate_hz=30.0, seed=0):
    """A head that never turns, standing at ``stations`` positions ``step_m`` apart for a
    burst of ``frames`` poses each (positions within ``jitter_m``), 3 s between stations;
    the camera 5 cm off the head. Returns the stamp-paired synchronised poses."""
    rng = np.random.default_rng(seed)
    p = np.cumsum(rng.normal(size=(stations, 3)), axis=0)
    p = step_m * p / np.linalg.norm(np.diff(p, axis=0), axis=1).min()
    p = np.repeat(p, frames, axis=0) + rng.uniform(-jitter_m, jitter_m, (stations * frames, 3))
    T = transform_from_rotation_translation(np.broadcast_to(np.eye(3), (p.shape[0], 3, 3)), p)
    X = transform_from_rotation_translation(np.eye(3), [0.05, 0.0, 0.0])
    t = (1000.0 + 3.0 * np.arange(stations)[:, None]
         + np.arange(frames)[None] / rate_hz).ravel()
    a, b = stream_from_arrays(t, T), stream_from_arrays(t, T @ X)
    return pair_by_stamp(a, b, classify_sampling(a, b))


def test_a_gantry_that_stops_without_turning_stands_still_at_its_stations():
    sp = _gantry(stations=6, frames=4, jitter_m=0.2 * STATION_SPREAD_M)
    runs = station_runs(sp)
    assert runs is not None and runs.tolist() == np.repeat(np.arange(6), 4).tolist()
    ms = form_motions(sp, "auto", paired_by_stamp=True, min_rotation_deg=None)
    assert ms.policy == "bursts" and "6 stations" in ms.reason
    assert np.array_equal(ms.stations, runs)
    assert np.all(runs[ms.i] != runs[ms.j])              # never two poses of one station


def test_translation_stations_need_stillness_and_several_poses_each():
    # a head that drifts beyond STATION_SPREAD_M within a burst does not stand still
    assert station_runs(_gantry(jitter_m=2.0 * STATION_SPREAD_M)) is None
    # steps below STATION_STEP_M do not start a station: one run, no stations
    assert station_runs(_gantry(step_m=0.5 * STATION_STEP_M, frames=4)) is None
    # a track that moves far between every pose (a car at 10 Hz): one pose a "station"
    assert station_runs(_gantry(stations=40, frames=1)) is None


def test_span_pairs_end_does_not_depend_on_the_stamps_jitter():
    """Motions over a step of exactly k periods end k samples later whatever the stamps'
    jitter (below half a period). Joined to the first stamp a hair short of the step
    later, a motion ended k samples later only when that stamp ran late enough, else one
    sample further: the chosen ends ran late on average, and the clock offset read from
    such motions was biased (~0.1 ms with 1 ms of jitter at 30 Hz)."""
    from simcalib.estimation.motions import span_pairs
    rng = np.random.default_rng(3)
    t = 1000.0 + np.arange(600) / 30.0 + rng.normal(0.0, 0.001, 600)
    i, j = span_pairs(t, 1.0)
    assert i.size == 570 and np.array_equal(j, i + 30)
    # a dropped frame: the motions that would end on it end one sample later
    t_drop = np.delete(t, 300)
    i, j = span_pairs(t_drop, 1.0)
    assert set(np.unique(j - i)) == {29, 30}
    assert np.all(t_drop[j] - t_drop[i] >= 1.0 - 0.5 / 30.0)
