"""Jumps of a stream's world frame (simcalib.estimation.world_jumps)."""

from dataclasses import replace

import numpy as np

from simcalib.estimation.path import calibrate_streams
from simcalib.estimation.world_jumps import (JUMP_PERSIST, find_jumps, mark_stretches,
                                             station_split)
from simcalib.geometry import (matrix_from_rotvec, rotation_error_rad,
                               transform_from_rotation_translation, translation_error_m)
from simcalib.importers import stream_from_arrays
from simcalib.world.stream_sim import rig_streams

#: a SLAM map reset: b's world moved by 0.8 m and 50 deg
G = transform_from_rotation_translation(matrix_from_rotvec(np.radians(50.0) * np.array(
    [0.6, -0.48, 0.64])), np.array([0.5, -0.4, 0.5]))


def _streams(seed=3, **kw):
    return rig_streams(offset_s=0.04, rng=np.random.default_rng(seed), **kw)


def _reset(T, k):
    T = T.copy()
    T[k:] = G @ T[k:]
    return T


def test_a_reset_world_is_a_jump_and_a_smooth_stream_has_none():
    rs = _streams()
    k = 250
    assert find_jumps(rs.t_b, rs.T_b, rs.t_a, rs.T_a).size == 0
    assert find_jumps(rs.t_a, rs.T_a, rs.t_b, rs.T_b).size == 0
    assert find_jumps(rs.t_b, _reset(rs.T_b, k), rs.t_a, rs.T_a).tolist() == [k]


def test_bad_poses_that_come_back_are_not_jumps():
    rs = _streams()
    for run in (1, JUMP_PERSIST - 1):          # one bad pose, a short run of them
        T = rs.T_b.copy()
        T[300:300 + run] = G @ T[300:300 + run]
        assert find_jumps(rs.t_b, T, rs.t_a, rs.T_a).size == 0, run


def test_a_step_the_other_stream_makes_as_fast_is_taken_for_a_motion():
    """Both sensors of a rigid rig move alike: a step is a jump only where the other stream
    never comes near its speed (here a's is faster still, in both angle and distance)."""
    rs = _streams()
    T_a = rs.T_a.copy()
    T_a[400:] = (G @ G) @ T_a[400:]
    assert find_jumps(rs.t_b, _reset(rs.T_b, 250), rs.t_a, T_a).size == 0


def test_the_path_uses_every_stretch_and_says_so():
    rs = _streams()
    k = 380
    a = stream_from_arrays(rs.t_a, rs.T_a, source="<a>", name="a")
    b = stream_from_arrays(rs.t_b, _reset(rs.T_b, k), source="<b>", name="b")
    sa, sb, notes = mark_stretches(a, b)
    assert sa is a and sb.n == rs.t_b.size and sb.world_jumps_s == (float(rs.t_b[k]),)
    assert sb.repairs["world_jumps"] == 1 and sb.repairs["world_stretches"] == 2
    assert sb.repairs["poses_in_short_stretches_dropped"] == 0
    assert len(notes) == 1 and "each of its 2 stretches is used" in notes[0]
    r = calibrate_streams(a, b)
    assert r.summary["world_jumps"][:1] == notes
    assert r.summary["world_jumps"][1].startswith("2 of 2 stretches")
    w = r.synced.world
    assert np.unique(w).size == 2                            # both stretches' instants
    i, j = r.motion_index
    assert np.all(w[i] == w[j]) and np.unique(w[i]).size == 2  # motions in each, none across
    assert r.motions.counts["dropped_across_world_jump"] > 0
    assert np.degrees(rotation_error_rad(r.X, rs.X)) < 0.1
    assert translation_error_m(r.X, rs.X) < 0.002
    assert abs(r.time_offset.offset_s - 0.04) < 3e-3


def _rot(axis, angle):
    return matrix_from_rotvec(np.asarray(angle)[:, None] * np.asarray(axis, float)[None])


def _two_axis_rig(n=800, rate=50.0, seed=5):
    """a turns about its z axis only in the first half and about its x axis only in the
    second (each half alone leaves X's translation along its axis undetermined); b = a
    through X, in b's world, with small noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    h = n // 2
    th1 = 0.8 * np.sin(2 * np.pi * 0.25 * np.minimum(t, t[h]))
    th2 = 0.8 * np.sin(2 * np.pi * 0.25 * np.maximum(t - t[h], 0.0))
    T_a = np.tile(np.eye(4), (n, 1, 1))
    T_a[:, :3, :3] = _rot([0, 0, 1], th1) @ _rot([1, 0, 0], th2)
    T_a[:, :3, 3] = 0.3 * np.stack([np.sin(0.5 * t), np.cos(0.4 * t), np.sin(0.3 * t)], 1)
    X = transform_from_rotation_translation(matrix_from_rotvec([0.3, -0.2, 0.5]),
                                            np.array([0.10, -0.05, 0.20]))
    Y = transform_from_rotation_translation(matrix_from_rotvec([0.1, 0.2, -0.3]),
                                            np.array([1.0, 0.5, -0.2]))
    T_b = np.linalg.inv(Y)[None] @ T_a @ X[None]
    noise = transform_from_rotation_translation(
        matrix_from_rotvec(rng.normal(0, 2e-4, (n, 3))), rng.normal(0, 2e-4, (n, 3)))
    return t, T_a, T_b @ noise, X


def test_a_reset_between_motions_about_two_axes_uses_both_to_determine_x():
    """Only both stretches together determine X well (each turns about one axis): the
    longest stretch alone left X's translation along its axis 10x less certain."""
    t, T_a, T_b, X = _two_axis_rig()
    k = t.size // 2
    a = stream_from_arrays(t, T_a, source="<a>", name="a")
    b = stream_from_arrays(t, _reset(T_b, k), source="<b>", name="b")
    assert find_jumps(t, b.T_world_sensor, t, T_a).tolist() == [k]
    r = calibrate_streams(a, b, time_offset=0.0)
    sigma_m = np.sqrt(np.diag(r.covariance)[3:])
    assert np.all(sigma_m < 1e-4)               # one stretch alone: 0.2 mm along its axis
    assert np.degrees(rotation_error_rad(r.X, X)) < 0.01
    assert translation_error_m(r.X, X) < 2e-4   # one stretch alone: 0.63 mm
    i, j = r.motion_index
    assert np.all(r.synced.world[i] == r.synced.world[j])


def _station_streams(seed=4):
    from simcalib.estimation.stamp_units import stamps_to_seconds
    from simcalib.studies.experiments.recording_kinds import generate
    rec = generate("stations", seed)
    return rec, *stamps_to_seconds(rec.stream_a, rec.stream_b, "auto", "auto")


def test_a_bumped_target_splits_station_data_and_one_bad_station_does_not():
    _, sa, sb = _station_streams()
    T_a, T_b = np.asarray(sa.T_world_sensor), np.asarray(sb.T_world_sensor)
    n = T_a.shape[0]
    assert station_split(T_a, T_b) is None
    k = n // 2 + 1
    split = station_split(T_a, _reset(T_b, k))
    assert split is not None and split[0] == k and split[1] > 10
    T_bad = T_b.copy()
    T_bad[k] = G @ T_bad[k]                    # one station's pose wrong: an outlier
    assert station_split(T_a, T_bad) is None


def test_the_path_uses_both_groups_of_stations_and_says_so():
    rec, sa, sb = _station_streams()
    n = sa.n
    k = n // 3
    b = replace(sb, T_world_sensor=_reset(np.asarray(sb.T_world_sensor), k))
    r = calibrate_streams(sa, b)
    assert r.stream_a.n == n and r.stream_b.n == n            # no pose dropped
    assert r.stream_b.repairs["world_stretches"] == 2
    assert len(r.summary["world_jumps"]) == 2
    assert r.summary["world_jumps"][1].startswith("2 of 2 stretches")
    assert "bumped target" in r.summary["world_jumps"][0]
    assert "both groups" in r.summary["world_jumps"][0]
    w = r.synced.world
    i, j = r.motion_index
    assert np.all(w[i] == w[j]) and np.unique(w[i]).size == 2  # pairs within each group
    assert np.degrees(rotation_error_rad(r.X, rec.X_true)) < 0.3
    assert translation_error_m(r.X, rec.X_true) < 0.005


def test_instants_interpolated_across_a_jump_are_dropped_and_labelled():
    """b (faster) interpolated at a's stamps: an instant of a between b's last pose before
    the jump and its first after mixes two worlds."""
    from simcalib.estimation.alignment import synchronise
    t_b = np.arange(0.0, 10.0, 0.01)
    t_a = 0.045 + 0.05 * np.arange(199)           # 4.995 lies in b's step across
    T_b = np.tile(np.eye(4), (t_b.size, 1, 1))
    T_a = np.tile(np.eye(4), (t_a.size, 1, 1))
    a = stream_from_arrays(t_a, T_a, source="<a>", name="a")
    b = replace(stream_from_arrays(t_b, T_b, source="<b>", name="b"),
                world_jumps_s=(float(t_b[500]),))
    sp = synchronise(a, b, 0.0)
    assert sp.counts["across_a_world_jump"] == 1
    assert np.all((sp.time_s <= t_b[499]) | (sp.time_s >= t_b[500]))
    assert np.array_equal(sp.world, (sp.time_s >= t_b[500]).astype(int))
    assert synchronise(a, replace(b, world_jumps_s=()), 0.0).world is None


def test_pose_residuals_fit_one_world_transform_per_stretch():
    from simcalib.estimation import pose_errors as pe
    rs = _streams()
    n = rs.t_a.size
    T_a = rs.T_a[:n]
    X = rs.X
    Y = transform_from_rotation_translation(matrix_from_rotvec([0.1, 0.2, 0.3]),
                                            np.array([0.3, 0.1, -0.2]))
    T_b = np.linalg.inv(Y)[None] @ T_a @ X[None]
    T_b = _reset(T_b, n // 2)
    world = (np.arange(n) >= n // 2).astype(int)
    r, Ys = pe.pose_residuals(T_a, T_b, X, world=world)
    assert np.abs(r).max() < 1e-9 and Ys.shape == (n, 4, 4)
    assert np.abs(pe.pose_residuals(T_a, T_b, X)[0]).max() > 0.1     # one world: wrong
    v = pe.body_velocities(T_b, rs.t_a[:n], world)
    assert np.abs(v).max() < 10 * np.median(np.abs(v)) + 5.0          # no jump's spike
    assert np.abs(pe.body_velocities(T_b, rs.t_a[:n])).max() > 10.0


def test_motions_are_never_formed_across_a_jump():
    from simcalib.estimation.alignment import SyncedPoses
    from simcalib.estimation.motions import form_motions
    rs = _streams()
    n = 200
    world = (np.arange(n) >= 120).astype(np.int64)
    sp = SyncedPoses(rs.t_a[:n], rs.T_a[:n], rs.T_a[:n] @ rs.X, "a", {}, world)
    ms = form_motions(sp, "spans", step_s=1.0, min_rotation_deg=None)
    assert ms.n > 0 and np.all(world[ms.i] == world[ms.j])
    assert ms.counts["dropped_across_world_jump"] > 0
    plain = form_motions(SyncedPoses(sp.time_s, sp.T_a, sp.T_b, "a", {}), "spans",
                         step_s=1.0, min_rotation_deg=None)
    assert plain.counts["formed"] == ms.counts["formed"]
    assert plain.n == ms.n + ms.counts["dropped_across_world_jump"]
