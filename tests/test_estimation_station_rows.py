"""Station rows paired by the equal-angle rule where a file lost a row and the rest were
renumbered (simcalib.estimation.station_rows)."""

from dataclasses import replace

import numpy as np
import pytest

from simcalib.estimation.path import calibrate_streams
from simcalib.estimation.sampling import classify_sampling
from simcalib.estimation.station_rows import align_rows, realign_rows
from simcalib.geometry import (random_rotation_matrices, rotation_error_rad,
                               transform_from_rotation_translation)
from simcalib.studies.experiments.recording_kinds import generate


def _lost_row(stream, k):
    """``stream`` without row ``k``, the later rows renumbered (stamps of the first rows)."""
    t = np.asarray(stream.timestamps_s)
    T = np.delete(np.asarray(stream.T_world_sensor), k, axis=0)
    return replace(stream, timestamps_s=t[:T.shape[0]], T_world_sensor=T)


def test_align_rows_finds_the_lost_row():
    rng = np.random.default_rng(0)
    n = 20
    T_a = transform_from_rotation_translation(random_rotation_matrices(rng, (n,)),
                                              rng.normal(size=(n, 3)))
    X = T_a[0] @ np.linalg.inv(T_a[1])
    T_b = np.delete(T_a @ X, 7, axis=0)          # b lost row 7
    ia, ib = align_rows(T_a, T_b)
    assert np.array_equal(ia, np.delete(np.arange(n), 7))
    assert np.array_equal(ib, np.arange(n - 1))


@pytest.mark.parametrize("seed", [0, 2])        # stations stamped by index (even seeds)
def test_a_lost_and_renumbered_row_is_paired_by_motion(seed):
    rec = generate("stations", seed)
    k = rec.stream_b.timestamps_s.size // 3
    base = calibrate_streams(rec.stream_a, rec.stream_b)
    lost = calibrate_streams(rec.stream_a, _lost_row(rec.stream_b, k))
    assert base.summary["station_rows"] == []
    assert len(lost.summary["station_rows"]) == 1
    assert "do not pair by number" in lost.summary["station_rows"][0]
    assert lost.stream_a.repairs["rows_without_a_partner"] == 1
    assert lost.stream_b.repairs["rows_paired_by_motion"] == k + (rec.stream_b.timestamps_s.size
                                                                  - k - 1)
    assert np.degrees(rotation_error_rad(lost.X, rec.X_true)) < 0.2
    assert np.linalg.norm(lost.X[:3, 3] - rec.X_true[:3, 3]) < 3e-3


def test_paired_streams_and_streams_stamped_in_time_are_left_as_they_are():
    rec = generate("stations", 0)
    sa, sb = rec.stream_a, rec.stream_b
    smp = classify_sampling(sa, sb)
    assert realign_rows(sa, sb, smp) == (sa, sb, smp, [])
    odd = generate("stations", 1)                 # stamps seconds apart, not numbers
    sb1 = _lost_row(odd.stream_b, 3)
    smp1 = classify_sampling(odd.stream_a, sb1)
    assert realign_rows(odd.stream_a, sb1, smp1)[3] == []


@pytest.mark.parametrize("kind, seed, shift_s", [("stations", 1, 1.7), ("stations", 3, -7.3),
                                                 ("stations_short", 1, 2.1)])
def test_stations_on_two_clocks_are_paired_at_their_shift(kind, seed, shift_s):
    """The robot's and the camera's computers stamp each stop on their own clocks (b
    ``shift_s`` late, 50 ms of trigger jitter): no stamp is shared, and the streams were
    taken for continuous ones, interpolated between stops seconds apart (X 6-17 deg off,
    offset 0, no warning)."""
    rec = generate(kind, seed)
    tb = np.asarray(rec.stream_b.timestamps_s)
    jitter = np.random.default_rng(seed).uniform(-0.05, 0.05, tb.size)
    sb = replace(rec.stream_b, timestamps_s=tb + shift_s + jitter)
    r = calibrate_streams(rec.stream_a, sb)
    assert r.sampling.paired_by_stamp and abs(r.time_offset.offset_s - shift_s) < 0.05
    assert len(r.summary["station_rows"]) == 1 and "carry two clocks" in r.summary[
        "station_rows"][0]
    assert np.degrees(rotation_error_rad(r.X, rec.X_true)) < 0.3
    assert np.linalg.norm(r.X[:3, 3] - rec.X_true[:3, 3]) < 0.01


@pytest.mark.parametrize("kind", ["continuous", "low_rate_camera", "stop_and_go"])
def test_streams_that_sample_a_motion_are_not_paired_by_lag(kind):
    rec = generate(kind, 0)
    smp = classify_sampling(rec.stream_a, rec.stream_b)
    assert realign_rows(rec.stream_a, rec.stream_b, smp)[3] == []


def test_world_jump_marks_move_with_the_rows_new_stamps():
    """Re-paired rows take new stamps; a stream's world-jump marks (the first pose of each
    later stretch) follow the rows they mark."""
    from simcalib.estimation.station_rows import moved_marks
    rec = generate("stations", 0)
    sb = replace(rec.stream_b, world_jumps_s=(4.0, 9.0, 99.0))
    old = np.array([0.0, 1.0, 2.0, 3.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0])   # row 4 lost
    new = np.arange(old.size, dtype=float) + 0.5
    assert moved_marks(sb, old, new) == (4.5, 8.5)
    k = rec.stream_b.timestamps_s.size // 3
    lost = _lost_row(replace(rec.stream_b, world_jumps_s=(float(k + 2),)), k)
    out_b = realign_rows(rec.stream_a, lost, classify_sampling(rec.stream_a, lost))[1]
    j = int(np.searchsorted(lost.timestamps_s, k + 2))      # the marked row, renumbered
    assert out_b.world_jumps_s == (float(out_b.timestamps_s[j]),)


def test_pair_angles_are_computed_once_per_pair(monkeypatch):
    from simcalib.estimation import station_rows
    from simcalib.geometry import random_rotation_matrices, rotation_angle_rad
    rng = np.random.default_rng(3)
    T = np.tile(np.eye(4), (40, 1, 1))
    T[:, :3, :3] = random_rotation_matrices(rng, (40,))
    T[20:, :3, :3] += 1e-6 * rng.standard_normal((20, 3, 3))   # not quite orthonormal
    R = T[:, :3, :3]
    every = rotation_angle_rad(np.swapaxes(R, 1, 2)[:, None] @ R[None])
    seen = []

    def counted(M):
        seen.append(M.shape[0])
        return rotation_angle_rad(M)
    monkeypatch.setattr(station_rows, "rotation_angle_rad", counted)
    got = station_rows.pair_angles_rad(T)
    assert seen == [40 * 41 // 2]
    assert got.shape == (40, 40) and got.tobytes() == every.tobytes()
