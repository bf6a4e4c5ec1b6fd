"""The benchmark recordings of issue 28 (simcalib/studies/experiments/recordings.py): the generator
itself, and the acceptance of the ``calibrate`` defaults on every kind: no worse than
OpenCV Park given the true offset and reading, the offset and the reading found, bad input
refused, undetermined directions flagged (seeds 0-2 here; docs/recordings.md has seeds
0-19 from its command)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from simcalib.studies.experiments import recording_kinds as RK
from simcalib.studies.experiments import recordings as R
from simcalib.geometry import (invert_transform, matrix_from_rotvec, rotation_angle_rad,
                               rotation_error_rad, transform_from_rotation_translation)
from simcalib.importers import read_pose_stream

KINDS = list(RK.KINDS)
#: seeds of the acceptance tests (offset: seed 1 has drift, seed 2 an offset of tens of s)
SEEDS = (0, 1, 2)
ROT_FLOOR_DEG, TRANS_FLOOR_MM, OFFSET_TOL_MS = R.ROT_FLOOR_DEG, R.TRANS_FLOOR_MM, R.OFFSET_TOL_MS


def _arrays(rec):
    return (rec.stream_a.timestamps_s, rec.stream_a.T_world_sensor,
            rec.stream_b.timestamps_s, rec.stream_b.T_world_sensor, rec.X_true,
            rec.outliers_a, rec.outliers_b)


def _constraint_errors(Ta, Tb, X, step):
    """Rotation (rad) and translation (m) errors of C X = X H over motions i -> i+step."""
    i = np.arange(Ta.shape[0] - step)
    C = invert_transform(Ta[i]) @ Ta[i + step]
    H = invert_transform(Tb[i]) @ Tb[i + step]
    D = invert_transform(C @ X) @ (X @ H)
    return rotation_angle_rad(D[:, :3, :3]), np.linalg.norm(D[:, :3, 3], axis=1)


def _consistency(rec, X=None):
    """Max C X = X H errors on the true-reading, synchronised, outlier-free poses."""
    Ta, Tb, clean = R.synchronised_truth(rec)
    Ta, Tb = Ta[clean], Tb[clean]
    k = rec.change_row or 0                  # a bumped camera: X_true from its row on
    Ta, Tb = Ta[k:], Tb[k:]
    step = 1 if not rec.offset_determined else 200     # stations: consecutive; else ~2 s
    rot, trans = _constraint_errors(Ta, Tb, rec.X_true if X is None else X, step)
    return float(np.degrees(rot.max())), float(1e3 * trans.max())


# ---------------------------------------------------------------------- the generator
def test_registry_describes_every_kind_and_rejects_unknown_ones():
    assert KINDS
    for name, kind in RK.KINDS.items():
        assert kind.description and "\n" not in kind.description, name
        assert kind.expect in ("determined", "degenerate", "data_error"), name
    with pytest.raises(ValueError, match="valid kinds: " + ", ".join(KINDS)):
        RK.generate("stationz", 0)
    with pytest.raises(ValueError, match="unknown override.*colour.*valid: noise"):
        RK.generate("stations", 0, colour=1)
    with pytest.raises(ValueError, match="seed"):
        RK.generate("stations", -1)
    with pytest.raises(ValueError, match="'stations' does not use duration_s; its settings"):
        RK.generate("stations", 0, duration_s=10.0)
    with pytest.raises(ValueError, match="'continuous' does not use offset_s"):
        RK.generate("continuous", 0, offset_s=1.0)
    assert RK.generate("offset", 0, offset_s=0.5, drift_ppm=0.0).offset_s == 0.5


@pytest.mark.parametrize("kind", KINDS)
def test_same_seed_same_arrays_other_seed_other_arrays(kind):
    a, b, c = RK.generate(kind, 4), RK.generate(kind, 4), RK.generate(kind, 5)
    for x, y in zip(_arrays(a), _arrays(b)):
        np.testing.assert_array_equal(x, y)
    assert a.description == b.description and a.offset_s == b.offset_s
    assert not np.array_equal(a.stream_b.T_world_sensor[:3], c.stream_b.T_world_sensor[:3])
    assert not a.stream_a.T_world_sensor.flags.writeable and not a.X_true.flags.writeable


@pytest.mark.parametrize("kind", [k for k in KINDS if RK.KINDS[k].expect != "data_error"])
def test_x_true_satisfies_cx_eq_xh_on_noise_free_output(kind):
    # b at 200 Hz without dropped frames: interpolating b at a's stamps is then exact to
    # ~1e-3 deg / 0.05 mm (at the default 30 Hz SLERP alone errs by up to ~0.03 deg / 1.6 mm)
    fast = dict(rate_b_hz=200.0, drop_fraction=0.0) if RK.KINDS[kind].offset_determined else {}
    rec = RK.generate(kind, 1, noise=False, **fast)
    rot_deg, trans_mm = _consistency(rec)
    if not rec.offset_determined:           # same stamps: exact
        assert rot_deg < 1e-9 and trans_mm < 1e-9, (rot_deg, trans_mm)
    else:
        assert rot_deg < 0.005 and trans_mm < 0.1, (rot_deg, trans_mm)
    # the check discriminates: X rotated by 1 deg, or shifted by 2 cm, fails it
    dX = transform_from_rotation_translation(matrix_from_rotvec(np.radians([0.6, 0.6, 0.6])),
                                             [0.0, 0.0, 0.0])
    shift = transform_from_rotation_translation(np.eye(3), [0.02, 0.0, 0.0])
    from simcalib.estimation.stillness import rotation_extent_deg
    if rotation_extent_deg(rec.stream_a) >= 10.0:
        assert _consistency(rec, rec.X_true @ dX)[0] > 0.3
        assert _consistency(rec, rec.X_true @ shift)[1] > 2.0
    else:       # (nearly) nothing turns: a wrong rotation shows in the translations
        # (t_C = R_X t_H)
        assert _consistency(rec, rec.X_true @ dX)[1] > 2.0


def test_bumped_camera_changes_x_at_its_row():
    rec = RK.generate("bumped_camera", 2, noise=False)
    k = rec.change_row
    Ta, Tb, _ = R.synchronised_truth(rec)
    assert 8 <= k <= Ta.shape[0] - 8
    before = _constraint_errors(Ta[:k], Tb[:k], rec.X_before_change, 1)
    assert before[0].max() < 1e-9 and before[1].max() < 1e-9
    assert np.degrees(_constraint_errors(Ta[:k], Tb[:k], rec.X_true, 1)[0].max()) > 1.0
    deg = np.degrees(rotation_error_rad(rec.X_before_change, rec.X_true))
    assert 2.0 <= deg <= 6.0
    assert rec.truth_dict()["change_row"] == k


def test_bad_input_kind_is_really_inconsistent():
    for name, kind in RK.KINDS.items():
        if kind.expect == "data_error":
            rot_deg, _ = _consistency(RK.generate(name, 1, noise=False))
            assert rot_deg > 5.0, name          # b does not move while a turns


@pytest.mark.parametrize("kind", [k for k in KINDS
                                  if any(getattr(RK.generate(k, 0), f) or
                                         getattr(RK.generate(k, 1), f)
                                         for f in ("invert_a", "invert_b", "scalar_first_a",
                                                   "scalar_first_b"))])
def test_file_form_differs_from_the_true_reading(kind):
    """Kinds with an inverted / scalar-first file: read as written, no X fits."""
    for seed in (0, 1):
        rec = RK.generate(kind, seed, noise=False)
        as_written = dataclasses.replace(rec, invert_a=False, invert_b=False,
                                         scalar_first_a=False, scalar_first_b=False)
        if (rec.invert_a, rec.invert_b, rec.scalar_first_a, rec.scalar_first_b) != (
                False, False, False, False):
            assert _consistency(as_written)[0] > 1.0


def test_outlier_masks_mark_exactly_the_jumped_poses():
    for seed in (0, 1):
        bad = RK.generate("outliers", seed, noise=False)
        good = RK.generate("outliers", seed, noise=False, outlier_fraction=0.0)
        m = bad.outliers_b
        assert 0.03 <= m.mean() <= 0.23, m.mean()      # 5..20 % drawn, then per pose
        assert not good.outliers_b.any()
        Tb, Tg = bad.stream_b.T_world_sensor, good.stream_b.T_world_sensor
        np.testing.assert_array_equal(Tb[~m], Tg[~m])
        jump = invert_transform(Tg[m]) @ Tb[m]
        assert (np.degrees(rotation_angle_rad(jump[:, :3, :3])) >= 10 - 1e-9).all()
        assert (np.linalg.norm(jump[:, :3, 3], axis=1) >= 0.2 - 1e-9).all()


def test_offset_kind_offsets_drift_and_station_stamps():
    offs = [RK.generate("offset", s) for s in range(6)]
    assert all(abs(r.offset_s) <= 0.2 for r in offs if r.seed % 3 != 2)
    assert all(10 <= abs(r.offset_s) <= 40 for r in offs if r.seed % 3 == 2)
    assert all((r.drift != 0) == (r.seed % 3 == 1) for r in offs)
    for r in offs:          # b's stamps really are ahead by the offset model
        sa, sb = RK.true_streams(r)
        assert sb.timestamps_s[0] - sa.timestamps_s[0] == pytest.approx(
            r.offset_at(sa.timestamps_s[0]), abs=0.05)
    st = RK.generate("stations", 0)
    np.testing.assert_array_equal(st.stream_a.timestamps_s, st.stream_b.timestamps_s)
    assert 10 <= st.stream_a.n <= 40 and 3 <= RK.generate("stations_short", 0).stream_a.n <= 5


def test_gaps_kind_has_gaps_of_1_to_3_s():
    for seed in (0, 1, 2):
        rec = RK.generate("gaps", seed)
        dts = [np.diff(s.timestamps_s).max() for s in (rec.stream_a, rec.stream_b)]
        gapped = int(np.argmax(dts))
        assert "ab"[gapped] == ("b" if seed % 2 == 0 else "a")
        assert 0.9 <= dts[gapped] <= 3.2 and dts[1 - gapped] < 0.5, dts


def test_robot_error_is_systematic_and_camera_error_grows_with_distance():
    for seed in (0, 1, 2):
        bad, clean = RK.generate("robot_error", seed), RK.generate("robot_error", seed,
                                                                  noise=False)
        dA = invert_transform(clean.stream_a.T_world_sensor) @ bad.stream_a.T_world_sensor
        rms_deg = np.degrees(np.sqrt(np.mean(rotation_angle_rad(dA[:, :3, :3]) ** 2)))
        rms_mm = 1e3 * np.sqrt(np.mean(np.sum(dA[:, :3, 3] ** 2, axis=1)))
        # (the white robot noise alone is ~0.035 deg / 0.35 mm rms)
        assert 0.05 <= rms_deg <= 0.8 and 0.5 <= rms_mm <= 4.5, (rms_deg, rms_mm)
        # the camera's distance error is biased (too far) and larger for far views
        Tb, Tc = bad.stream_b.T_world_sensor, clean.stream_b.T_world_sensor
        d = np.linalg.norm(Tc[:, :3, 3], axis=1)
        err = np.linalg.norm(Tb[:, :3, 3], axis=1) - d
        assert err.mean() > 3 * err.std() / np.sqrt(err.size), err
        far = d > np.median(d)
        assert np.abs(err[far]).mean() > np.abs(err[~far]).mean(), (d, err)


def test_workspace_x_takes_up_a_constant_hand_error_exactly():
    """A hand error that is the same at every pose, E0, moves X to E0^-1 X with no
    residual: the dense solve returns exactly that."""
    rng = np.random.default_rng(3)
    X = transform_from_rotation_translation(matrix_from_rotvec([0.2, -0.1, 0.4]),
                                            [0.05, -0.02, 0.08])
    Y = transform_from_rotation_translation(matrix_from_rotvec([0.0, 0.0, 1.0]),
                                            [0.5, 0.0, 0.0])
    E0 = transform_from_rotation_translation(matrix_from_rotvec([0.004, -0.003, 0.002]),
                                             [0.002, 0.001, -0.003])
    X_ws = RK.workspace_X(rng, X, Y, lambda A: np.broadcast_to(E0, A.shape), 0.0,
                          stations=50)
    np.testing.assert_allclose(X_ws, invert_transform(E0) @ X, atol=1e-12)


def test_workspace_x_only_where_the_errors_are_systematic():
    for seed in (0, 1):
        rec = RK.generate("robot_error", seed)
        D = invert_transform(rec.X_true) @ rec.X_workspace
        deg, mm = np.degrees(rotation_angle_rad(D[:3, :3])), 1e3 * np.linalg.norm(D[:3, 3])
        assert 0.0 < deg < 1.0 and 0.0 < mm < 6.0, (deg, mm)
        assert rec.truth_dict()["X_workspace"] == rec.X_workspace.tolist()
    assert RK.generate("robot_error", 0, noise=False).X_workspace is None
    assert all(RK.generate(k, 0).X_workspace is None for k in KINDS if k != "robot_error")


def test_planar_and_scara_rotate_about_one_axis_only():
    for kind in ("planar", "scara"):
        rec = RK.generate(kind, 0, noise=False)
        Ta, _, _ = R.synchronised_truth(rec)
        C = invert_transform(Ta[:-1]) @ Ta[1:]
        from simcalib.geometry import rotvec_from_matrix
        w = rotvec_from_matrix(C[:, :3, :3])
        big = np.linalg.norm(w, axis=1) > 1e-6
        axes = w[big] / np.linalg.norm(w[big], axis=1, keepdims=True)
        assert np.abs(axes @ rec.undetermined_a[0]).min() > 1 - 1e-9, kind


def test_translation_kind_translates_without_rotating_in_3d_or_a_plane():
    from simcalib.geometry import rotvec_from_matrix
    for seed in (0, 1):
        rec = RK.generate("translation", seed, noise=False)
        Ta, Tb, _ = R.synchronised_truth(rec)
        assert np.abs(rotvec_from_matrix(Ta[:, :3, :3]) - rotvec_from_matrix(Ta[0, :3, :3])
                      ).max() < 1e-12
        dims = np.linalg.matrix_rank(Ta[:, :3, 3] - Ta[0, :3, 3], tol=1e-6)
        assert dims == (3 if seed % 2 == 0 else 2), (seed, dims)
        assert rec.undetermined_a.shape == (3, 3) and rec.expect == "degenerate"
        # the classic answer (Kabsch on the translations: Park has no rotation to use) is
        # exact without noise; no translation of X is determined, so its error is n/a
        X = R.park_baseline(rec)        # (b interpolated at a's stamps: ~1e-4 deg)
        assert np.degrees(rotation_angle_rad(X[:3, :3].T @ rec.X_true[:3, :3])) < 0.002
        assert math.isnan(R.translation_error_determined(X, rec))
    assert R.undetermined_covered([(1, 0, 0), (0, 1, 0), (0, 0, 1)], np.eye(3))
    assert not R.undetermined_covered([(1, 0, 0), (0, 1, 0)], np.eye(3))
    assert R.no_worse(math.nan, math.nan, 0.5) and not R.no_worse(1.0, math.nan, 0.5)


@pytest.mark.parametrize("kind", KINDS)
def test_tum_round_trip(kind, tmp_path):
    rec = RK.generate(kind, 2)
    paths = RK.write_tum(rec, tmp_path)
    for key, s in (("a", rec.stream_a), ("b", rec.stream_b)):
        back = read_pose_stream(paths[key])
        assert back.format == "tum"
        np.testing.assert_array_equal(back.timestamps_s, s.timestamps_s)
        np.testing.assert_allclose(back.T_world_sensor, s.T_world_sensor, atol=1e-12)
    truth = RK.read_truth(tmp_path)
    np.testing.assert_allclose(truth["X_true"], rec.X_true, atol=0)
    assert truth["offset_s"] == rec.offset_s and truth["kind"] == kind
    assert truth["outliers_b"] == np.flatnonzero(rec.outliers_b).tolist()


def test_park_baseline_is_exact_on_noise_free_stations():
    rec = RK.generate("stations", 3, noise=False)
    X = R.park_baseline(rec)
    assert np.degrees(rotation_angle_rad(X[:3, :3].T @ rec.X_true[:3, :3])) < 1e-6
    assert np.linalg.norm(X[:3, 3] - rec.X_true[:3, 3]) < 1e-6


def test_motion_outliers_maps_motions_to_outlier_poses():
    rec = RK.generate("outliers", 0, noise=False)
    t = rec.stream_b.timestamps_s - rec.offset_s          # synced on b's stamps (clock a)
    bad_pose = rec.outliers_b
    k = np.flatnonzero(bad_pose[1:-1])[0] + 1
    assert R.motion_outliers(rec, t, np.array([k - 1, k]), np.array([k, k + 1]),
                             rec.offset_s).all()
    i = np.flatnonzero(~bad_pose[:-1] & ~bad_pose[1:])
    assert not R.motion_outliers(rec, t, i, i + 1, rec.offset_s).any()
    # synced on a's stamps (b interpolated): an instant bracketed by an outlier is bad
    ta = rec.stream_a.timestamps_s
    tb_k = rec.stream_b.timestamps_s[k]
    j = int(np.searchsorted(ta + rec.offset_s, tb_k))      # first a instant after pose k
    assert R.motion_outliers(rec, ta, np.array([j]), np.array([j]), rec.offset_s)[0]


def test_experiment_config_is_registered_and_checked():
    from simcalib.errors import ConfigError
    from simcalib.studies.experiments import config_class
    cls = config_class("recordings")
    assert cls().kinds == tuple(KINDS)
    with pytest.raises(ConfigError):
        cls(kinds=("stationz",))
    assert R.main(["--kinds", "nope"]) == 2


# ----------------------------------------------------------------------- acceptance
@pytest.fixture(scope="module")
def outcome(tmp_path_factory):
    """``(Recording, Outcome)`` of kind x seed, calibrated once for all the checks."""
    cache = {}

    def get(kind, seed):
        if (kind, seed) not in cache:
            rec = RK.generate(kind, seed)
            cache[kind, seed] = (rec, R.evaluate(rec, tmp_path_factory.mktemp(
                f"{kind}_{seed}")))
        return cache[kind, seed]
    return get


#: cases the estimation path does not meet yet, ``(test, kind, seed) -> why``: strict xfail,
#: so a case that starts passing fails the suite until it is removed from here
#: (docs/recordings.md, seeds 0-19, lists every miss)
KNOWN_LIMITS: dict = {
    ("park", "low_rate_camera", 2): "Park's rotation error here (0.054 deg) is its best draw "
    "on seeds 0-4 (the others 0.18-0.28 deg); calibrate's 0.128 deg is within its sigma "
    "(NEES 6.5 on 6 dof) and its translation error is below Park's (2.1 vs 3.7 mm)",
}


def _cases(pred=lambda k: True, test=None):
    """(kind, seed) params; the checks of one case share an xdist group (``--dist
    loadgroup``, pyproject): its recording is calibrated once, on one worker."""
    out = []
    for k in KINDS:
        if not pred(RK.KINDS[k]):
            continue
        for s in SEEDS:
            why = KNOWN_LIMITS.get((test, k, s))
            marks = [pytest.mark.xdist_group(f"recording-{k}-{s}")]
            if why:
                marks.append(pytest.mark.xfail(strict=True, reason=why))
            out.append(pytest.param(k, s, marks=marks))
    return out


def _values(case):
    """(kind, seed) of a case, plain or wrapped in pytest.param."""
    return tuple(getattr(case, "values", case))


def _estimate(o):
    assert o.exit_code in (0, 6) and math.isfinite(o.rot_error_deg), (
        f"no estimate: exit {o.exit_code}: {o.message}")


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases())
def test_exit_code(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    if rec.expect == "data_error":
        assert o.exit_code == 3, f"exit {o.exit_code} (expected a DataError, exit 3)"
        msg = o.message.lower()
        assert "b" in msg.split() or "stream b" in msg or "b.txt" in msg, o.message
        assert any(w in msg for w in ("move", "motion", "static", "rotat")), o.message
    elif rec.expect == "degenerate":
        assert o.exit_code == 6, f"exit {o.exit_code}: {o.message}"
    else:
        assert o.exit_code in (0, 6), f"exit {o.exit_code}: {o.message}"


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases(lambda k: k.expect != "data_error", test="park"))
def test_no_worse_than_park_given_the_truth(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    _estimate(o)
    assert math.isfinite(o.park_rot_error_deg), "the Park baseline failed"
    rot_bar = max(R.PARK_FACTOR * o.park_rot_error_deg, ROT_FLOOR_DEG)
    trans_bar = max(R.PARK_FACTOR * o.park_trans_error_mm, TRANS_FLOOR_MM)
    assert (R.no_worse(o.rot_error_deg, o.park_rot_error_deg, ROT_FLOOR_DEG)
            and R.no_worse(o.trans_error_mm, o.park_trans_error_mm, TRANS_FLOOR_MM)), (
        f"rotation {o.rot_error_deg:.4g} deg (bar {rot_bar:.4g}), translation "
        f"{o.trans_error_mm:.4g} mm (bar {trans_bar:.4g}); Park {o.park_rot_error_deg:.4g} "
        f"deg / {o.park_trans_error_mm:.4g} mm")


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", [c for c in _cases(lambda k: k.expect != "data_error",
                                                         test="park_inliers")
                                       if RK.generate(*_values(c)).outliers_b.any()
                                       or RK.generate(*_values(c)).outliers_a.any()])
def test_no_worse_than_park_on_the_inlier_poses(kind, seed, outcome):
    """Park without rejection is wrecked by outlier poses, so that bar is empty there: the
    outlier kinds are also held to Park on the outlier-free instants (true masks)."""
    rec, o = outcome(kind, seed)
    _estimate(o)
    assert math.isfinite(o.park_oracle_rot_error_deg), "the Park baseline failed"
    rot_bar = max(R.PARK_FACTOR * o.park_oracle_rot_error_deg, ROT_FLOOR_DEG)
    trans_bar = max(R.PARK_FACTOR * o.park_oracle_trans_error_mm, TRANS_FLOOR_MM)
    assert o.rot_error_deg <= rot_bar and o.trans_error_mm <= trans_bar, (
        f"rotation {o.rot_error_deg:.4g} deg (bar {rot_bar:.4g}), translation "
        f"{o.trans_error_mm:.4g} mm (bar {trans_bar:.4g}); Park on the inlier poses "
        f"{o.park_oracle_rot_error_deg:.4g} deg / {o.park_oracle_trans_error_mm:.4g} mm")


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases(lambda k: R.offset_checked(k)
                                             and k.expect != "data_error", test="offset"))
def test_offset_found(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    _estimate(o)
    tol = RK.KINDS[kind].offset_tol_ms or OFFSET_TOL_MS
    assert abs(o.offset_error_ms) <= tol, (
        f"offset error {o.offset_error_ms:.2f} ms (true offset {1e3 * rec.offset_s:.1f} ms"
        f"{f', drift {1e6 * rec.drift:.0f} ppm' if rec.drift else ''})")


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases(lambda k: k.expect != "data_error"))
def test_right_reading(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    _estimate(o)
    assert o.reading_ok, (f"wrong reading; truth invert a/b {rec.invert_a}/{rec.invert_b}, "
                          f"scalar first a/b {rec.scalar_first_a}/{rec.scalar_first_b}")


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases(lambda k: k.expect == "degenerate"))
def test_undetermined_translation_direction_flagged(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    _estimate(o)
    assert R.undetermined_covered(o.undetermined_dirs_a, rec.undetermined_a), (
        f"reported translation directions "
                                      f"{o.undetermined_dirs_a}; truth {rec.undetermined_a}")


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases(lambda k: "outlier_fraction" in k.extra))
def test_outlier_motions_rejected(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    _estimate(o)
    assert o.precision >= R.MIN_PRECISION and o.recall >= R.MIN_RECALL, (o.precision,
                                                                          o.recall)


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases(lambda k: k.expect != "data_error", test="mount"))
def test_mount_change_told_where_and_only_where_x_changes(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    _estimate(o)
    assert not R.mount_failures(o), (f"told {o.mount_change_s}, true change "
                                     f"{o.true_change_s or 'none'}")


@pytest.mark.slow
@pytest.mark.parametrize("kind,seed", _cases(lambda k: k.expect != "data_error", test="step"))
def test_clock_step_told_where_and_only_where_b_steps(kind, seed, outcome):
    rec, o = outcome(kind, seed)
    _estimate(o)
    assert not R.step_failures(o), f"told {o.steps}, true step {o.true_step or 'none'}"


def test_clock_step_kind_steps_b_forward_once():
    rec = RK.generate("clock_step", 3)
    t = np.asarray(rec.stream_b.timestamps_s)
    k = int(np.argmax(t - rec.offset_s - rec.step_s >= rec.step_at_s - 1e-9))
    assert 0.3 <= rec.step_s <= 2.0 and np.all(np.diff(t) > 0)
    assert t[k] - t[k - 1] > rec.step_s                     # the jump in b's stamps
    assert rec.offset_at(rec.step_at_s) - rec.offset_at(rec.step_at_s - 1e-3) == rec.step_s
    Ta, Tb, _ = R.synchronised_truth(rec)                   # the truth pairs across it
    rot, trans = _constraint_errors(Ta, Tb, rec.X_true, 200)
    assert np.degrees(rot.max()) < 0.5 and trans.max() < 0.01


@pytest.mark.slow
def test_main_writes_the_table(tmp_path, capsys):
    out = tmp_path / "rec.md"
    assert R.main(["--kinds", "stations", "--seeds", "1", "--output", str(out)]) == 0
    text = out.read_text()
    assert "| stations | 1 |" in text and "Park" in text and text in capsys.readouterr().out


def test_stamp_units_kind_writes_each_file_in_its_unit_and_keeps_the_truth_in_seconds():
    seen = set()
    for seed in range(6):
        rec = RK.generate("stamp_units", seed)
        units = (rec.stamps_unit_a, rec.stamps_unit_b)
        seen.add(units)
        sa, sb = RK.true_streams(rec)
        for s, true, u in ((rec.stream_a, sa, units[0]), (rec.stream_b, sb, units[1])):
            if u != "s":            # relative to the file's first pose, in its unit
                assert s.timestamps_s[0] == 0.0 and not s.repairs
                f = {"ms": 1e3, "us": 1e6, "ns": 1e9}[u]
                np.testing.assert_allclose(true.timestamps_s, s.timestamps_s / f)
        # the truth is in seconds: b's true stamps follow a's through the offset model
        assert np.median(np.diff(sa.timestamps_s)) == pytest.approx(0.01, rel=0.05)
        assert np.median(np.diff(sb.timestamps_s)) == pytest.approx(1 / 30, rel=0.05)
        assert abs(rec.drift) > 0 if seed % 2 else rec.drift == 0.0
    assert {("ms", "s"), ("s", "ms"), ("ms", "ms"), ("us", "s"), ("s", "ns")} <= seen


def test_stamp_units_kind_stamps_one_file_in_unix_time():
    """Seeds 6 and 7: one file in seconds since the Unix epoch, the other on the recording's
    clock; the true offset carries the epoch."""
    for seed, unix in ((6, "a"), (7, "b")):
        rec = RK.generate("stamp_units", seed)
        ta, tb = rec.stream_a.timestamps_s, rec.stream_b.timestamps_s
        assert (rec.stamps_unit_a, rec.stamps_unit_b) == ("s", "s")
        assert (ta[0] > 1e9) == (unix == "a") and (tb[0] > 1e9) == (unix == "b")
        assert abs(abs(rec.offset_s) - RK.UNIX_EPOCH_S) < 1.0
