"""Robot controllers' pose logs (simcalib.importers.robot_csv): UR, KUKA, Fanuc, roll/pitch/yaw
and rotation-vector columns read to the poses written, the ambiguous rx/ry/rz refused."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simcalib.errors import DataError
from simcalib.importers import detect_format, read_pose_stream, stream_from_arrays
from simcalib.world.stream_sim import rig_streams


@pytest.fixture(scope="module")
def rig():
    return rig_streams(duration_s=12.0, rng=np.random.default_rng(0))


def _write(path, header, columns):
    np.savetxt(path, np.column_stack(columns), fmt="%.12g", delimiter=",",
               header=",".join(header), comments="")
    return path


def _check(path, rig, n, fmt="robot_csv", atol=1e-8):
    assert detect_format(path)[0] == fmt
    s = read_pose_stream(path)
    assert np.allclose(s.T_world_sensor, rig.T_a[:n], atol=atol)
    assert np.allclose(s.timestamps_s, rig.t_a[:n])
    return s


def _rot(rig, n):
    return Rotation.from_matrix(rig.T_a[:n, :3, :3])


def test_ur_rtde_log_is_metres_and_a_rotation_vector(tmp_path, rig):
    n = 40
    cols = ["timestamp"] + [f"actual_TCP_pose_{k}" for k in range(6)]
    f = _write(tmp_path / "ur.csv", cols, [rig.t_a[:n], rig.T_a[:n, :3, 3],
                                          _rot(rig, n).as_rotvec()])
    assert "rotation vector" in _check(f, rig, n).detection


@pytest.mark.parametrize("kind", ["kuka", "fanuc"])
def test_kuka_abc_and_fanuc_wpr_are_mm_and_degrees(tmp_path, rig, kind):
    n = 40
    zyx = _rot(rig, n).as_euler("ZYX", degrees=True)            # about z, y', x''
    if kind == "kuka":
        header, angles = ["time", "X", "Y", "Z", "A", "B", "C"], zyx
    else:                                                        # W, P, R about fixed x, y, z
        header, angles = ["time", "X", "Y", "Z", "W", "P", "R"], zyx[:, ::-1]
    f = _write(tmp_path / f"{kind}.csv", header,
               [rig.t_a[:n], 1e3 * rig.T_a[:n, :3, 3], angles])
    s = _check(f, rig, n)
    assert "mm read as metres" in s.detection and "deg" in s.detection


@pytest.mark.parametrize("names,scale,said", [
    (("roll", "pitch", "yaw"), 1.0, "rad (no value beyond pi"),
    (("roll_deg", "pitch_deg", "yaw_deg"), None, "deg (named)"),
    (("roll", "pitch", "yaw"), None, "deg (a value beyond pi)")])
def test_roll_pitch_yaw_in_radians_or_degrees(tmp_path, rig, names, scale, said):
    n = 60
    xyz = _rot(rig, n).as_euler("xyz")                           # fixed x, y, z (REP 103)
    deg = scale is None
    if deg and "deg" not in names[0]:
        assert np.abs(np.degrees(xyz)).max() > np.pi             # the range tells degrees
    f = _write(tmp_path / "rpy.csv", ["t", "x", "y", "z", *names],
               [rig.t_a[:n], rig.T_a[:n, :3, 3], np.degrees(xyz) if deg else xyz])
    assert said in _check(f, rig, n).detection


def test_rotvec_columns_and_a_nan_row_dropped(tmp_path, rig):
    n = 30
    rv = _rot(rig, n).as_rotvec()
    rv[7] = np.nan
    f = _write(tmp_path / "rv.csv", ["t", "x", "y", "z", "rotvec_x", "rotvec_y", "rotvec_z"],
               [rig.t_a[:n], rig.T_a[:n, :3, 3], rv])
    s = read_pose_stream(f)
    keep = np.arange(n) != 7
    assert s.repairs.get("nan_rows_dropped") == 1 and len(s) == n - 1
    assert np.allclose(s.T_world_sensor, rig.T_a[:n][keep], atol=1e-8)


def test_rx_ry_rz_cannot_be_told_and_say_what_they_may_mean(tmp_path, rig):
    n = 10
    f = _write(tmp_path / "r.csv", ["t", "x", "y", "z", "rx", "ry", "rz"],
               [rig.t_a[:n], rig.T_a[:n, :3, 3], _rot(rig, n).as_rotvec()])
    with pytest.raises(DataError, match="rx, ry, rz are a rotation vector.*Rename them"):
        read_pose_stream(f)


def test_a_file_with_quaternions_too_is_the_csv_readers(tmp_path, rig):
    n = 10
    q = _rot(rig, n).as_quat()
    f = _write(tmp_path / "both.csv", ["t", "x", "y", "z", "qx", "qy", "qz", "qw", "roll",
                                       "pitch", "yaw"],
               [rig.t_a[:n], rig.T_a[:n, :3, 3], q, _rot(rig, n).as_euler("xyz")])
    _check(f, rig, n, fmt="csv")


def test_a_kuka_log_calibrates_like_its_tum_copy(tmp_path, rig):
    from simcalib.estimation.path import calibrate_streams
    b = stream_from_arrays(rig.t_b, rig.T_b, name="b")
    a_tum = stream_from_arrays(rig.t_a, rig.T_a, name="a")
    zyx = Rotation.from_matrix(rig.T_a[:, :3, :3]).as_euler("ZYX", degrees=True)
    f = _write(tmp_path / "kuka.csv", ["time", "X", "Y", "Z", "A", "B", "C"],
               [rig.t_a, 1e3 * rig.T_a[:, :3, 3], zyx])
    want = calibrate_streams(a_tum, b, seed=0).X
    got = calibrate_streams(read_pose_stream(f), b, seed=0).X
    assert np.allclose(got, want, atol=1e-7)
