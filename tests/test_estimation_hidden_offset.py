"""Shared stamps that hide a clock offset (simcalib.estimation.hidden_offset)."""

import numpy as np
import pytest

from simcalib.estimation.alignment import TimeOffset
from simcalib.estimation.hidden_offset import continuous, motion_stride, stamps_hide_offset
from simcalib.estimation.path import calibrate_streams
from simcalib.estimation.sampling import classify_sampling
from simcalib.geometry import random_rotation_matrices, rotation_error_rad
from simcalib.importers import stream_from_arrays
from simcalib.world.stream_sim import rig_streams


def _grid_streams(offset_s: float, seed: int = 0):
    """A 1 kHz stream and a 10 Hz one whose stamps land on its 1 ms grid at any offset
    that is a whole number of ms; both clocks start at a phase of 12.34567 us, so their
    stamps are fine (not a 1 ms grid that any stamp would hit by chance)."""
    rs = rig_streams(offset_s=offset_s, duration_s=12.0, rate_a_hz=1000.0, rate_b_hz=10.0,
                     rng=np.random.default_rng(seed))
    phase = 1.234567e-5
    return (rs, stream_from_arrays(rs.t_a + phase, rs.T_a, name="a"),
            stream_from_arrays(rs.t_b + phase, rs.T_b, name="b"))


def _shared_offset(sampling) -> TimeOffset:
    return TimeOffset(0.0, 0.0, 0.0, float("nan"), np.zeros(0), np.zeros(0), refined=False,
                      decision="shared_stamps", message=sampling.reason)


def test_continuous_tells_streams_from_stations():
    rs = rig_streams(rng=np.random.default_rng(0))
    assert continuous(rs.t_a, rs.T_a) and continuous(rs.t_a, rs.T_a, "translation")
    rng = np.random.default_rng(1)
    T = np.tile(np.eye(4), (40, 1, 1))
    T[:, :3, :3] = random_rotation_matrices(rng, (40,))
    T[:, :3, 3] = rng.uniform(-0.5, 0.5, (40, 3))
    assert not continuous(np.arange(40.0), T)                    # a new stop every pose
    t = np.sort(rng.uniform(0, 30, rs.t_a.size))                 # irregular stamps
    assert not continuous(t, rs.T_a)
    assert not continuous(rs.t_a[:10], rs.T_a[:10])              # too short to tell


@pytest.mark.parametrize("offset_s", [0.25, -0.04])
def test_an_offset_hidden_by_shared_stamps_is_found(offset_s):
    rs, a, b = _grid_streams(offset_s)
    sampling = classify_sampling(a, b)
    assert sampling.paired_by_stamp and sampling.kind == "shared_stamps"
    smp, off = stamps_hide_offset(a, b, sampling, _shared_offset(sampling))
    assert not smp.paired_by_stamp and smp.kind == "continuous"
    assert off.decision == "estimated" and abs(off.offset_s - offset_s) < 3e-3
    assert "line up at" in smp.reason
    cal = calibrate_streams(a, b)                            # the whole path
    assert not cal.sampling.paired_by_stamp
    assert abs(cal.time_offset.offset_s - offset_s) < 3e-3
    assert np.degrees(rotation_error_rad(cal.X, rs.X)) < 0.1


def test_stamps_that_agree_with_the_motion_stay_paired():
    _, a, b = _grid_streams(0.0)
    sampling = classify_sampling(a, b)
    off0 = _shared_offset(sampling)
    smp, off = stamps_hide_offset(a, b, sampling, off0)
    assert smp.paired_by_stamp and off.offset_s == 0.0 and off.decision == "shared_stamps"
    assert "no offset of their motions beats 0" in off.message and smp.reason == off.message


def test_station_and_index_stamps_are_not_checked():
    rng = np.random.default_rng(3)
    rs = rig_streams(rng=rng)
    idx = np.arange(30.0)
    T = rs.T_a[::20][:30]
    a = stream_from_arrays(idx, T, source="<a>", name="a")
    b = stream_from_arrays(idx, T @ rs.X, source="<b>", name="b")
    sampling = classify_sampling(a, b)
    off0 = _shared_offset(sampling)
    assert stamps_hide_offset(a, b, sampling, off0) == (sampling, off0)


def _counters(rate_hz: float, lag: int, seed: int = 0, duration_s: float = 12.0):
    """Two streams of one continuous motion stamped with sample numbers, each counted from
    its own first pose: b's first pose is a's pose ``lag`` (plus the simulated phase of
    0.37 of a sample), so ``t_b - t_a = -(lag + 0.37)`` samples."""
    rs = rig_streams(duration_s=duration_s, rate_a_hz=rate_hz, rate_b_hz=rate_hz,
                     rng=np.random.default_rng(seed))
    ta = np.round((rs.t_a - rs.t_a[0]) * rate_hz)
    tb = np.round((rs.t_b - rs.t_b[0]) * rate_hz)
    Tb = rs.T_b[lag:]
    a = stream_from_arrays(ta, rs.T_a, name="a")
    b = stream_from_arrays(tb[:tb.size - lag], Tb, name="b")
    return rs, a, b, -(lag + 0.37)


def test_motion_stride_turns_beyond_the_noise():
    rs = rig_streams(duration_s=12.0, rate_a_hz=1000.0, rate_b_hz=30.0,
                     rng=np.random.default_rng(0))
    k, reached = motion_stride(rs.T_a)           # ~30 deg/s: 8 deg over 64 ms
    assert reached and k == 64
    k, reached = motion_stride(rs.T_b)
    assert reached and k in (2, 4)
    rng = np.random.default_rng(1)               # stations: never turns beyond its noise
    T = np.tile(np.eye(4), (200, 1, 1))
    T[:, :3, :3] = random_rotation_matrices(rng, (200,))
    assert not motion_stride(T)[1]


@pytest.mark.parametrize("rate_hz, lag, duration_s", [
    (30.0, 0, 12.0), (30.0, 37, 12.0),
    pytest.param(1000.0, 0, 4.0, marks=pytest.mark.slow),
    pytest.param(1000.0, 37, 4.0, marks=pytest.mark.slow)])
def test_sample_number_counters_of_a_continuous_motion(rate_hz, lag, duration_s):
    """Frame counters (30 Hz) and a 1 kHz stream in whole ms beside another (two counters:
    sample numbers): the motions' stride is chosen from the motion, the lag between the
    counters found in samples (lag 0 is 0.37 of a sample: the simulated phase)."""
    rs, a, b, true_lag = _counters(rate_hz, lag, duration_s=duration_s)
    assert classify_sampling(a, b).kind == "index_stamps"
    cal = calibrate_streams(a, b)
    assert cal.sampling.motion_step >= (64 if rate_hz > 100 else 4)
    assert cal.time_offset.decision == "estimated"
    assert abs(cal.time_offset.offset_s - true_lag) < 0.1       # samples
    assert "samples" in cal.sampling.reason
    assert np.degrees(rotation_error_rad(cal.X, rs.X)) < 0.1
    assert 1e3 * np.linalg.norm(cal.X[:3, 3] - rs.X[:3, 3]) < 2.0


def test_an_offset_the_check_keeps_at_zero_keeps_its_sigma_in_x():
    """Shared stamps whose motions do not tell an offset from 0 stay paired at 0, but the
    stamps do not prove 0: the offset keeps the check's 1-sigma (its sigma and its
    estimate's distance from 0, as for any offset not told from 0), and X's covariance
    carries it through b's velocities (it was 0: reported, and added, as exactly 0)."""
    from simcalib.estimation.alignment import estimate_time_offset
    from simcalib.estimation.path import _consistency
    _, a, b = _grid_streams(0.0)
    sampling = classify_sampling(a, b)
    smp, off = stamps_hide_offset(a, b, sampling, _shared_offset(sampling))
    est = estimate_time_offset(a, b)                    # the check's own estimate
    assert smp.paired_by_stamp and off.decision == "shared_stamps" and off.offset_s == 0.0
    assert est.decision == "zero" and np.isfinite(est.best_s)
    assert off.uncertainty_s == est.uncertainty_s > abs(est.best_s) > 0
    assert off.best_s == est.best_s and off.evidence == est.evidence
    assert "carried into X's sigma" in off.message
    cal = calibrate_streams(a, b)
    given = calibrate_streams(a, b, time_offset=0.0)     # the same pairs, offset given
    assert cal.sampling.paired_by_stamp and given.sampling.paired_by_stamp
    assert cal.time_offset.uncertainty_s == off.uncertainty_s
    np.testing.assert_array_equal(cal.X, given.X)
    _, _, cov, _ = _consistency(given.motions, given.robust, given.synced, method="dqopt",
                                alpha=1.0, prior=None, offset_sigma_s=off.uncertainty_s)
    np.testing.assert_allclose(cal.covariance, cov, rtol=1e-9, atol=0)
    assert not np.allclose(cal.covariance, given.covariance, rtol=1e-6, atol=0)
