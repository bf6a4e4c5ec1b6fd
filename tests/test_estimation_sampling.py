"""How two streams were sampled, from their stamps (simcalib.estimation.sampling): shared
stamps must beat chance, stamps shared up to a constant shift are paired after it."""

import numpy as np
import pytest

from simcalib.estimation.path import calibrate_streams
from simcalib.estimation.sampling import classify_sampling, pair_by_stamp, resolution
from simcalib.geometry import rotation_error_rad, translation_error_m
from simcalib.importers import stream_from_arrays
from simcalib.world.stream_sim import rig_path, rig_streams


def _streams(t_a, t_b, path_t_a=None, path_t_b=None):
    """Streams of the rig stamped ``t_a`` / ``t_b``, posed at ``path_t_*`` (default: the
    stamps; other clocks' stamps of the same instants)."""
    X = rig_streams(duration_s=30.0, rng=np.random.default_rng(0)).X
    ta = t_a if path_t_a is None else path_t_a
    tb = t_b if path_t_b is None else path_t_b
    return (stream_from_arrays(t_a, rig_path(ta)), stream_from_arrays(t_b, rig_path(tb) @ X), X)


def test_resolution_of_written_stamps():
    rng = np.random.default_rng(0)
    t = 1000.0 + np.cumsum(rng.uniform(0.03, 0.04, 200))
    assert resolution(np.round(t, 2)) == pytest.approx(0.01)
    assert resolution(np.round(t, 3)) == pytest.approx(0.001)
    assert resolution(np.arange(50.0)) == 1.0
    assert resolution(t) < 1e-9                  # full precision: the floats' spacing


def test_stamps_written_at_10_ms_do_not_share_by_chance():
    # a 30 Hz and a 100 Hz clock 150 ms apart, both written with %.2f: a 30 Hz stamp lands
    # on the 100 Hz stream's 10 ms grid by chance, not because the stamps are shared
    rng = np.random.default_rng(1)
    t_a = np.round(5.0 + np.arange(0, 20, 1 / 30) + rng.normal(0, 1e-3, 600), 2)
    t_b = np.round(5.0 + np.arange(0, 20, 1 / 100) + 0.15, 2)
    a, b, _ = _streams(t_a, t_b)
    s = classify_sampling(a, b)
    assert s.kind == "continuous" and not s.paired_by_stamp
    assert s.shared >= 0.8 * t_a.size and "by chance" in s.reason
    assert s.resolution_s == pytest.approx(0.01)


def test_shared_stamps_of_every_kind_stay_shared():
    t_gt = 1.4e9 + np.arange(0, 30, 1 / 200) + np.random.default_rng(2).normal(0, 2e-4, 6000)
    a, b, _ = _streams(np.sort(t_gt), np.sort(t_gt)[::20])       # SLAM at GT frames' stamps
    assert classify_sampling(a, b).kind == "shared_stamps"
    t = np.arange(0.0, 120.0, 4.0)                                 # stations, whole seconds
    a, b, _ = _streams(t + 7.0, t + 7.0)
    s = classify_sampling(a, b)
    assert s.kind == "shared_stamps" and s.shared == t.size and s.shift_s == 0.0
    a, b, _ = _streams(np.arange(20.0), np.arange(20.0))           # sample numbers
    assert classify_sampling(a, b).kind == "index_stamps"


def _stations(seed=3, n=25):
    rng = np.random.default_rng(seed)
    return 2.0 + np.cumsum(rng.uniform(1.5, 6.0, n))              # irregular stops


def test_stamps_shared_up_to_a_constant_shift_are_paired_after_it():
    t = _stations()
    shift = 1.7e9 + 12.345
    for t_a, t_b, want in ((t, t + shift, shift), (t + shift, t, -shift)):
        a, b, _ = _streams(t_a, t_b[:-2], path_t_a=t, path_t_b=t[:-2])   # b lacks 2 poses
        s = classify_sampling(a, b)
        assert s.kind == "shared_stamps" and s.paired_by_stamp
        assert s.shift_s == pytest.approx(want, abs=1e-6) and "constant shift" in s.reason
        sp = pair_by_stamp(a, b, s, s.shift_s)
        assert sp.n == t.size - 2
        assert np.allclose(sp.T_b, np.asarray(b.T_world_sensor))


def test_regular_stamps_with_a_shift_are_two_clocks_not_one_shifted():
    # equal periods without jitter pair at every shift of a whole period: no shift is told
    a, b, _ = _streams(np.arange(0, 20, 0.05), np.arange(0, 20, 0.05) + 100.0123)
    s = classify_sampling(a, b)
    assert s.kind == "continuous" and s.shift_s == 0.0


def test_calibrate_reports_the_shift_as_the_offset():
    t = _stations(seed=5, n=30)
    a, b, X = _streams(t - t[0], t + 1.7e9, path_t_a=t, path_t_b=t)
    r = calibrate_streams(a, b)
    assert r.sampling.kind == "shared_stamps"
    assert r.time_offset.decision == "shared_stamps"
    assert r.time_offset.offset_s == pytest.approx(1.7e9 + t[0], abs=1e-6)
    assert np.degrees(rotation_error_rad(r.X, X)) < 1e-4 and translation_error_m(r.X, X) < 1e-6
