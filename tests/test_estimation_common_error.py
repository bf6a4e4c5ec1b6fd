"""A stated error common to every pose (simcalib.estimation.common_error): its map to X,
its place in the estimation path's covariance and in the calibrate command's outputs."""

import json

import numpy as np
import pytest

from simcalib.errors import ConfigError
from simcalib.estimation.common_error import CommonError
from simcalib.estimation.path import calibrate_streams
from simcalib.geometry import (matrix_from_rotvec, skew_matrix,
                               transform_from_rotation_translation)
from simcalib.importers import stream_from_arrays
from simcalib.solvers.diagnostics.inputs import pose_error
from simcalib.studies.experiments.recording_kinds import generate


def _exp(xi):
    return transform_from_rotation_translation(matrix_from_rotvec(xi[:3]), xi[3:])


def _jacobians(X):
    """Columns: pose_error(X', X) per unit of each error coordinate (a's, then b's)."""
    cov = {}
    for side, keys in (("a", ("rotation_a_deg", "translation_a_m")),
                       ("b", ("rotation_b_deg", "translation_b_m"))):
        cov[side] = CommonError(**{keys[0]: np.degrees(np.sqrt(3.0)), keys[1]: np.sqrt(3.0)}
                                ).covariance(X)          # unit variance per axis
    return cov


def test_a_constant_error_of_every_pose_moves_x_by_the_stated_map():
    """The error E on every pose of a (right, in a's frame) returns exactly E^-1 X, and F on
    b's returns X F: noise-free stations through the whole path; the covariance of a
    stated rms is J S J^T with those first-order maps."""
    rec = generate("stations", 1, noise=False)
    a, b = rec.stream_a, rec.stream_b
    rng = np.random.default_rng(3)
    for side in ("a", "b"):
        eps = np.concatenate([rng.normal(0, 1e-5, 3), rng.normal(0, 1e-5, 3)])
        E = _exp(eps)
        s = a if side == "a" else b
        moved = stream_from_arrays(s.timestamps_s, s.T_world_sensor @ E)
        r = calibrate_streams(moved, b, invert_a=False, invert_b=False) if side == "a" \
            else calibrate_streams(a, moved, invert_a=False, invert_b=False)
        X0 = calibrate_streams(a, b, invert_a=False, invert_b=False).X
        expected = np.linalg.inv(E) @ X0 if side == "a" else X0 @ E
        np.testing.assert_allclose(r.X, expected, atol=1e-9)
        # the first-order map: Cov = J J^T for unit variance per axis, so J is a square root
        J = {"a": np.block([[-np.eye(3), np.zeros((3, 3))],
                            [skew_matrix(X0[:3, 3]), -np.eye(3)]]),
             "b": np.kron(np.eye(2), X0[:3, :3])}[side]
        np.testing.assert_allclose(pose_error(r.X, X0), J @ eps, atol=1e-9)   # 2nd order: ~3e-10
        np.testing.assert_allclose(_jacobians(X0)[side], J @ J.T, atol=1e-12)


def test_the_path_adds_it_on_the_determined_directions_only():
    rec = generate("planar", 0)
    plain = calibrate_streams(rec.stream_a, rec.stream_b)
    ce = CommonError(rotation_a_deg=0.2, translation_a_m=0.003)
    stated = calibrate_streams(rec.stream_a, rec.stream_b, common_error=ce)
    assert stated.common_error == ce and plain.common_error is None
    np.testing.assert_array_equal(stated.X, plain.X)
    inf = ~np.isfinite(np.diag(plain.covariance))
    assert inf.any()                                   # planar: the vertical is free
    np.testing.assert_array_equal(~np.isfinite(np.diag(stated.covariance)), inf)
    B = plain.consistency.basis
    P = B @ B.T
    np.testing.assert_allclose(stated.covariance_determined,
                               plain.covariance_determined + P @ ce.covariance(plain.X) @ P,
                               rtol=1e-9, atol=1e-15)


def test_nothing_stated_changes_nothing():
    rec = generate("stations", 2)
    a = calibrate_streams(rec.stream_a, rec.stream_b)
    b = calibrate_streams(rec.stream_a, rec.stream_b, common_error=CommonError())
    np.testing.assert_array_equal(a.covariance, b.covariance)
    assert b.common_error is None


@pytest.mark.parametrize("value", [-0.1, float("nan"), float("inf"), "1", True])
def test_a_bad_value_is_refused_naming_it(value):
    with pytest.raises(ConfigError, match="rotation_a_deg"):
        CommonError(rotation_a_deg=value)


def test_the_command_reports_what_sigma_includes(tmp_path):
    from simcalib.cli import main
    from simcalib.studies.experiments.recording_kinds import write_tum
    rec = generate("stations", 3)
    files = write_tum(rec, tmp_path / "rec")
    out = tmp_path / "out"
    code = main(["calibrate", f"a={files['a']}", f"b={files['b']}", f"output={out}",
                 "recording=false", "common_error.rotation_a_deg=0.1",
                 "common_error.translation_a_m=0.002"])
    assert code in (0, 6)
    u = json.loads((out / "calibration.json").read_text())["uncertainty"]
    assert u["common_error_included"]["rotation_a_deg"] == 0.1
    assert "beyond the stated" in u["not_included"]
