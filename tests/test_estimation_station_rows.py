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
    smp1 = classify_sampling(odd.stream_a, odd.stream_b)
    assert realign_rows(odd.stream_a, odd.stream_b, smp1) == (odd.stream_a, odd.stream_b,
                                                              smp1, [])


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


def _lost_rows_ab(sa, sb, k_a, k_b):
    """Row ``k_a`` lost from a and ``k_b`` from b, each file renumbered: every row still
    pairs by number, the rows between ``k_b`` and ``k_a`` one off."""
    return _lost_row(sa, k_a), _lost_row(sb, k_b)


@pytest.mark.parametrize("kind, seed, stations", [("stations", 0, None), ("scara", 2, None),
                                                  ("stations", 2, 120)])
def test_a_row_lost_in_each_file_at_different_places_is_paired_by_motion(kind, seed, stations):
    """Both files hold 0..n-2 and pair by number, but the rows between the two lost ones
    are paired one off (120 stations: past FEW_ROWS, found by the neighbours' test)."""
    rec = generate(kind, seed, **({} if stations is None else {"stations": stations}))
    n = rec.stream_a.timestamps_s.size
    sa, sb = _lost_rows_ab(rec.stream_a, rec.stream_b, 2 * n // 3, n // 3)
    smp = classify_sampling(sa, sb)
    assert smp.shared == n - 1                          # every row pairs by number
    out_a, out_b, _, notes = realign_rows(sa, sb, smp)
    assert len(notes) == 1 and "pair by number, but rows numbered" in notes[0]
    assert out_a.repairs["rows_without_a_partner"] == 1
    assert out_b.repairs["rows_without_a_partner"] == 1
    assert out_b.T_world_sensor.shape[0] == n - 2
    r = calibrate_streams(sa, sb)
    assert len(r.summary["station_rows"]) == 1
    assert np.degrees(rotation_error_rad(r.X, rec.X_true)) < 0.3
    up = 2 if kind == "scara" else 3                    # a SCARA's X: z undetermined
    assert np.linalg.norm(r.X[:up, 3] - rec.X_true[:up, 3]) < 5e-3


@pytest.mark.parametrize("kind", ["stations", "stations_short", "scara", "robot_error",
                                  "bursts", "scale_stations"])
def test_files_whose_rows_are_right_are_not_re_paired(kind):
    for seed in range(0, 8, 2):                 # index-stamped in even seeds
        rec = generate(kind, seed)
        sa, sb = rec.stream_a, rec.stream_b
        smp = classify_sampling(sa, sb)
        assert realign_rows(sa, sb, smp) == (sa, sb, smp, [])


def test_the_neighbours_test_sees_a_stretch_paired_one_off_and_not_right_rows():
    from simcalib.estimation.station_rows import _shifted_rows_fit
    rec = generate("stations", 0, stations=120)
    T_a, T_b = np.asarray(rec.stream_a.T_world_sensor), np.asarray(rec.stream_b.T_world_sensor)
    assert not _shifted_rows_fit(T_a, T_b)
    assert _shifted_rows_fit(np.delete(T_a, 80, axis=0), np.delete(T_b, 40, axis=0))


def test_pair_angles_from_quaternions_equal_the_angles_of_every_two_poses():
    """pair_angles_rad (from the quaternions, 7x cheaper at 1000 rows) equals the angles of
    the products of every two rotation matrices to rounding, near 0 and near 180 deg too,
    is exactly 0 for equal poses and symmetric to the bit (rows not quite orthonormal)."""
    from simcalib.estimation.station_rows import pair_angles_rad
    from simcalib.geometry import matrix_from_rotvec, rotation_angle_rad
    rng = np.random.default_rng(1)
    R = random_rotation_matrices(rng, (60,))
    R[10] = R[9] @ matrix_from_rotvec(np.array([1e-7, 0.0, 0.0]))
    R[11] = R[9] @ matrix_from_rotvec(np.array([0.0, np.pi - 1e-6, 0.0]))
    R[12] = R[9]
    R[40:] += 1e-6 * rng.standard_normal((20, 3, 3))
    T = transform_from_rotation_translation(R, rng.normal(size=(60, 3)))
    got = pair_angles_rad(T)
    want = rotation_angle_rad(np.swapaxes(R, 1, 2)[:, None] @ R[None])
    assert np.allclose(got[:40, :40], want[:40, :40], rtol=1e-9, atol=1e-12)
    assert np.allclose(got, want, atol=1e-5)                  # the not-orthonormal rows
    assert abs(got[9, 10] - 1e-7) < 1e-14 and got[9, 12] == 0.0
    assert np.array_equal(got, got.T)


def test_pair_by_lag_pairs_1000_stations_at_their_shift():
    from simcalib.estimation.station_rows import pair_by_lag
    rec = generate("stations_two_clocks", 0, stations=1000)
    smp = classify_sampling(rec.stream_a, rec.stream_b)
    out_a, out_b, paired, notes = pair_by_lag(rec.stream_a, rec.stream_b, smp)
    assert len(notes) == 1 and abs(paired.shift_s - rec.truth_dict()["offset_s"]) < 0.06
    assert out_b.T_world_sensor.shape[0] == 1000


def _scara_raster(seed, n_yaw=8, n_z=4, reps=3):
    """A SCARA's stations on a raster (15 deg yaw steps, 5 cm heights, repeated), a camera
    looking down (b in mm, 0.1 deg / 1 mm noise): ``(T_a, T_b)``."""
    from simcalib.geometry import invert_transform, matrix_from_rotvec
    rng = np.random.default_rng(seed)
    yaw = np.radians(-35.0 + 15.0 * np.arange(n_yaw))
    A = np.array([transform_from_rotation_translation(
        matrix_from_rotvec(np.array([0.0, 0.0, y])),
        np.array([0.4 * np.cos(y / 2), 0.4 * np.sin(y / 2), 0.2 + 0.05 * k]))
        for _ in range(reps) for k in range(n_z) for y in yaw])
    X = transform_from_rotation_translation(matrix_from_rotvec(
        np.array([np.pi, 0.0, 0.0]) + rng.normal(0, 0.1, 3)), rng.normal(0, 0.1, 3))
    Y = transform_from_rotation_translation(matrix_from_rotvec(rng.normal(0, 0.3, 3)),
                                            np.array([0.5, 0.0, 0.0]))
    B = invert_transform(Y) @ A @ X
    R = np.array([matrix_from_rotvec(v) for v in np.radians(rng.normal(0, 0.1, (len(A), 3)))])
    t_mm = 1000.0 * (B[:, :3, 3] + rng.normal(0, 1e-3, (len(A), 3)))
    B = transform_from_rotation_translation(B[:, :3, :3] @ R, t_mm)
    return A, B


def test_a_raster_of_stations_on_two_clocks_is_paired_by_the_screws_pitch():
    """A raster repeats its turns: lags of a row of it keep most angles (the angles alone
    cannot tell the lag); the heights moved along the turns' axes tell it, b in mm."""
    from simcalib.estimation.station_rows import pair_by_lag
    from simcalib.importers import stream_from_arrays
    T_a, T_b = _scara_raster(0)
    t_a = np.arange(len(T_a), dtype=float)
    t_b = t_a + 2.3 + np.random.default_rng(0).uniform(-0.05, 0.05, t_a.size)
    sa = stream_from_arrays(t_a, T_a, source="a", name="a", quat_order="xyzw")
    sb = stream_from_arrays(t_b, T_b, source="b", name="b", quat_order="xyzw")
    out_a, out_b, paired, notes = pair_by_lag(sa, sb, classify_sampling(sa, sb))
    assert len(notes) == 1 and "the screws' pitch" in notes[0]
    assert abs(paired.shift_s - 2.3) < 0.06 and out_b.T_world_sensor.shape[0] == len(T_a)
    assert np.array_equal(out_b.T_world_sensor, T_b)             # each row with its own


@pytest.mark.parametrize("kind", ["stations", "robot_error", "scale_stations"])
def test_stations_seconds_apart_whose_camera_rows_took_the_robots_stamps(kind):
    """Stations stamped in seconds (odd seeds) whose camera file lost a row and was written
    with the robot's stamps (one list zipped with the other): every later pair was wrong
    and X came out 17-71 deg off with only "reading not told" said."""
    rec = generate(kind, 1)
    a, b = rec.stream_a, rec.stream_b
    keep = np.arange(len(b)) != len(b) // 3
    b = replace(b, timestamps_s=a.timestamps_s[:keep.sum()], T_world_sensor=b.T_world_sensor[keep])
    r = calibrate_streams(a, b, seed=0)
    base = calibrate_streams(rec.stream_a, rec.stream_b, seed=0)
    assert np.degrees(rotation_error_rad(r.X, base.X)) < 0.2
    assert r.stream_b.repairs.get("rows_paired_by_motion")
