"""Pose-file formats (simcalib.importers) and convention detection (simcalib.estimation.readings)."""

import json
import os
import re
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import yaml

from simcalib.errors import DataError
from simcalib.estimation.readings import apply_conventions, detect_conventions
from simcalib.geometry import invert_transform, quat_from_matrix
from simcalib.importers import (PoseStreamData, available, detect_format, read_pose_stream,
                                read_pose_streams, stream_from_arrays)
from simcalib.report.results import write_tum
from simcalib.world.stream_sim import rig_streams

ETH = Path(os.environ.get("SIMCALIB_ETH_DIR",
                          Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "eth"))
REAL = Path(os.environ.get("SIMCALIB_REAL_DIR",
                           Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "real"))


@pytest.fixture(scope="module")
def rig():
    return rig_streams(duration_s=12.0, rng=np.random.default_rng(0))


def _rows(t, T, order="xyzw"):
    q = quat_from_matrix(T[:, :3, :3])
    if order == "wxyz":
        q = np.concatenate([q[:, 3:], q[:, :3]], axis=1)
    return np.column_stack([t, T[:, :3, 3], q])


def _same(s: PoseStreamData, t, T):
    assert np.allclose(s.timestamps_s, t) and np.allclose(s.T_world_sensor, T, atol=1e-8)


def test_registry_finds_the_format_modules(monkeypatch):
    from simcalib.importers import FORMATS, register_format
    assert available() and available() == sorted(FORMATS.names())
    for name in available():              # each one found by discovery of the folder
        module = FORMATS.get(name)
        assert module.NAME == name and module.__name__.startswith("simcalib.importers.")
        assert FORMATS.info(name)["two_streams"] is bool(module.TWO_STREAMS)
        assert callable(module.sniff) and callable(module.read)
    assert "rosbag" not in available()    # bags have their own entry point (simcalib.ros.bag)
    monkeypatch.setitem(sys.modules, "simcalib.importers._no_name", types.ModuleType("_no_name"))
    with pytest.raises(TypeError, match="needs NAME.*write"):
        register_format("simcalib.importers._no_name")
    listing = re.escape(", ".join(available()))
    with pytest.raises(ValueError, match=f"did you mean 'eth'.*available: {listing}"):
        read_pose_stream(__file__, format="ethz")


@pytest.mark.parametrize("name", available())
def test_every_format_round_trips_and_is_detected(tmp_path, rig, name):
    """Each registered format writes the rig's streams as a user of that format would hand
    them to us; the file alone is detected as that format and reads back the same poses
    (and stamps, unless the format has none)."""
    from simcalib.importers import FORMATS, write_pose_streams
    n = 12
    a = stream_from_arrays(rig.t_a[:n], rig.T_a[:n], name="a")
    b = stream_from_arrays(rig.t_a[:n] + 0.5, rig.T_a[:n] @ rig.X, name="b")
    two = FORMATS.info(name)["two_streams"]
    files = write_pose_streams(tmp_path / f"poses_{name}.txt", [a, b] if two else [a], name)
    assert files and all(f.is_file() for f in files)
    assert detect_format(files[0])[0] == name
    got = read_pose_streams(files[0])
    assert [s.format for s in got] == [name] * (2 if two else 1)
    for s, want in zip(got, [a, b]):
        assert np.allclose(s.T_world_sensor, want.T_world_sensor, atol=1e-8), name
        if s.synthetic_time:
            assert np.array_equal(s.timestamps_s, np.arange(n))
        else:
            assert np.allclose(s.timestamps_s, want.timestamps_s, atol=1e-9), name


def test_kitti_poses_with_and_without_their_times_file(tmp_path, rig):
    from simcalib.importers import kitti
    T = rig.T_a[:30]
    p = tmp_path / "dataset" / "poses" / "07.txt"
    p.parent.mkdir(parents=True)
    np.savetxt(p, T[:, :3, :].reshape(-1, 12), fmt="%e")       # KITTI's own 6 digits
    s = read_pose_stream(p)
    assert s.format == "kitti" and s.synthetic_time and "line index" in s.detection
    assert np.allclose(s.T_world_sensor, T, atol=2e-5)          # rounded text, made rigid
    R = s.T_world_sensor[:, :3, :3]
    assert np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max() < 1e-12
    seq = tmp_path / "dataset" / "sequences" / "07"
    seq.mkdir(parents=True)
    np.savetxt(seq / "times.txt", rig.t_a[:30], fmt="%e")        # KITTI's layout
    s = read_pose_stream(p)
    assert not s.synthetic_time and "times.txt" in s.detection
    assert np.allclose(s.timestamps_s, rig.t_a[:30], rtol=1e-5)
    assert kitti.times_file(p) == seq / "times.txt"
    np.savetxt(seq / "times.txt", rig.t_a[:29])
    with pytest.raises(ValueError, match="30 poses but .*times.txt holds 29 lines"):
        read_pose_stream(p)
    short = tmp_path / "short.txt"
    np.savetxt(short, rig.t_a[:30])
    assert np.allclose(read_pose_stream(p, times=short).timestamps_s, rig.t_a[:30])
    q = tmp_path / "not_kitti.txt"                   # 12 numbers that are not a rotation
    np.savetxt(q, np.arange(36.0).reshape(3, 12))
    with pytest.raises(ValueError, match="could not detect the format"):
        read_pose_stream(q)


@pytest.mark.slow
@pytest.mark.skipif(not (REAL / "kitti00_orb").is_dir(), reason=f"real data sets not "
                    f"present at {REAL}")
def test_kitti_format_of_the_kitti00_recording_calibrates_like_its_tum_copy(tmp_path):
    """The KITTI 00 ground truth (shipped as TUM in the shared data) written back in KITTI
    form with its stamps: read as kitti, the same stream, and calibrate gives the same X
    against the ORB-SLAM stream as from the TUM copy."""
    from simcalib.estimation.path import calibrate_streams
    from simcalib.importers import write_pose_streams
    tum_a = read_pose_stream(REAL / "kitti00_orb" / "a.txt")
    files = write_pose_streams(tmp_path / "00.txt", [tum_a], "kitti")
    s = read_pose_stream(files[0])
    assert s.format == "kitti" and s.n == tum_a.n
    assert np.allclose(s.T_world_sensor, tum_a.T_world_sensor, atol=1e-9)
    b = REAL / "kitti00_orb" / "b.txt"
    r_kitti = calibrate_streams(files[0], b)
    r_tum = calibrate_streams(REAL / "kitti00_orb" / "a.txt", b)
    assert np.allclose(r_kitti.X, r_tum.X, atol=1e-6)


EUROC_HEADER = ("#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
                "q_RS_y [], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], "
                "b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], "
                "b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]")


def test_euroc_ground_truth_and_position_only_files(tmp_path, rig):
    """state_groundtruth_estimate0/data.csv as EuRoC ships it: nanosecond stamps since the
    epoch, quaternion scalar first, velocity and biases after the pose."""
    t_ns = 1403715273262142976 + np.round(rig.t_a[:20] * 1e9).astype(np.int64)
    R = _rows(rig.t_a[:20], rig.T_a[:20], "wxyz")
    p = tmp_path / "data.csv"
    with p.open("w") as f:
        f.write(EUROC_HEADER + "\n")
        for tn, r in zip(t_ns, R):
            f.write(f"{tn}," + ",".join(f"{v:.9f}" for v in r[1:]) + ",0.1" * 9 + "\n")
    s = read_pose_stream(p)
    assert s.format == "euroc" and s.quat_order == "wxyz" and not s.synthetic_time
    assert np.allclose(s.T_world_sensor, rig.T_a[:20], atol=1e-8)
    np.testing.assert_allclose(np.diff(s.timestamps_s), np.diff(rig.t_a[:20]), atol=1e-6)
    assert abs(s.timestamps_s[0] - 1403715273.262143) < 1e-6
    leica = tmp_path / "leica.csv"          # leica0: a prism's positions, no orientation
    leica.write_text("#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m]\n"
                     "1403715273262142976,1.0,2.0,3.0\n")
    with pytest.raises(ValueError, match=r"missing \['q_RS_x'.*positions alone"):
        read_pose_stream(leica, format="euroc")


@pytest.mark.slow
@pytest.mark.skipif(not (REAL / "euroc_v102").is_dir(), reason=f"real data sets not "
                    f"present at {REAL}")
def test_euroc_form_of_the_v102_ground_truth_reads_like_its_tum_copy(tmp_path):
    """The V1_02 ground truth (shipped as TUM, converted from EuRoC's CSV) written back as
    EuRoC: read as euroc, the same 200 Hz stream to the stamp."""
    from simcalib.importers import write_pose_streams
    tum = read_pose_stream(REAL / "euroc_v102" / "a.txt")
    (f,) = write_pose_streams(tmp_path / "data.csv", [tum], "euroc")
    s = read_pose_stream(f)
    assert s.format == "euroc" and s.n == tum.n and s.rate_hz == pytest.approx(200, rel=0.01)
    assert np.allclose(s.T_world_sensor, tum.T_world_sensor, atol=1e-8)
    assert np.abs(s.timestamps_s - tum.timestamps_s).max() < 1e-6


def test_simcalib_tum_and_plain_tum(tmp_path, rig):
    p = write_tum(tmp_path / "a.tum", rig.t_a, rig.T_a)
    s = read_pose_stream(p)
    assert s.format == "simcalib_tum" and "detected format 'simcalib_tum'" in s.detection
    _same(s, rig.t_a, rig.T_a)
    q = tmp_path / "b.txt"
    np.savetxt(q, _rows(rig.t_b, rig.T_b), fmt="%.10f")
    s = read_pose_stream(q)
    assert s.format == "tum" and s.repairs == {}
    _same(s, rig.t_b, rig.T_b)


def test_eth_csv(tmp_path, rig):
    p = tmp_path / "hand.csv"
    np.savetxt(p, _rows(rig.t_a, rig.T_a), fmt="%.10f", delimiter=", ")
    s = read_pose_stream(p)
    assert s.format == "eth" and detect_format(p)[0] == "eth"
    _same(s, rig.t_a, rig.T_a)


@pytest.mark.parametrize("header,order", [
    ("qw,qx,qy,qz,x,y,z,timestamp", "wxyz"),
    ("time;position.x;position.y;position.z;orientation.x;orientation.y;orientation.z;"
     "orientation.w", "xyzw"),
])
def test_csv_with_header_any_order(tmp_path, rig, header, order):
    R = _rows(rig.t_a, rig.T_a)   # t, x, y, z, qx, qy, qz, qw
    sep = ";" if ";" in header else ","
    cols = {"t": R[:, 0], "x": R[:, 1], "y": R[:, 2], "z": R[:, 3], "qx": R[:, 4],
            "qy": R[:, 5], "qz": R[:, 6], "qw": R[:, 7]}
    names = header.split(sep)
    key = lambda n: {"timestamp": "t", "time": "t"}.get(n, n.replace("position.", "")  # noqa
                     .replace("orientation.", "q"))
    data = np.column_stack([cols[key(n)] for n in names])
    p = tmp_path / "poses.csv"
    np.savetxt(p, data, fmt="%.10f", delimiter=sep, header=header, comments="")
    s = read_pose_stream(p)
    assert s.format == "csv" and s.quat_order == order
    _same(s, rig.t_a, rig.T_a)


def test_csv_matrix_and_q_index(tmp_path, rig):
    names = ["t"] + [f"m{i}{j}" for i in range(4) for j in range(4)]
    data = np.column_stack([rig.t_a, rig.T_a.reshape(-1, 16)])
    p = tmp_path / "m.csv"
    np.savetxt(p, data, fmt="%.12f", delimiter=",", header=",".join(names), comments="")
    s = read_pose_stream(p)
    assert s.quat_order == "matrix"
    _same(s, rig.t_a, rig.T_a)
    R = _rows(rig.t_a, rig.T_a, "wxyz")
    p = tmp_path / "q.csv"
    np.savetxt(p, R, fmt="%.10f", delimiter=",", header="t,x,y,z,q0,q1,q2,q3", comments="")
    s = read_pose_stream(p)
    assert "scalar-first" in s.detection
    _same(s, rig.t_a, rig.T_a)
    p = tmp_path / "abb.csv"                # ABB's robtarget order: q1 = w, q2..q4 = x..z
    np.savetxt(p, R, fmt="%.10f", delimiter=",", header="t,x,y,z,q1,q2,q3,q4", comments="")
    s = read_pose_stream(p)
    assert "q1..q4 read scalar-first (q1 = w)" in s.detection
    _same(s, rig.t_a, rig.T_a)


def test_repairs_are_counted(tmp_path, rig):
    R = _rows(rig.t_a[:50], rig.T_a[:50])
    R = np.vstack([R, R[10:13]])                 # 3 duplicate rows, out of order
    R[20, 4:] *= 1.01                            # non-unit quaternion
    R[30, 2] = np.nan                            # NaN row
    R[40, 1] = 1e300                             # corrupt position
    p = tmp_path / "bad.csv"
    np.savetxt(p, R, fmt="%.10g", delimiter=",")
    s = read_pose_stream(p)
    assert s.repairs["nan_rows_dropped"] == 1
    assert s.repairs["far_rows_dropped"] == 1
    assert s.repairs["quaternions_renormalised"] == 1
    assert s.repairs["duplicate_rows_dropped"] == 3
    assert s.repairs["out_of_order_rows_sorted"] > 0
    assert s.n == 48 and np.all(np.diff(s.timestamps_s) > 0)
    assert "nan_rows_dropped: 1" in s.describe()


def test_bad_input_errors(tmp_path, rig):
    R = _rows(rig.t_a[:10], rig.T_a[:10])
    R[3, 4:] *= 2.0
    p = tmp_path / "x.csv"
    np.savetxt(p, R, fmt="%.10f", delimiter=",")
    with pytest.raises(ValueError, match="row 3 .*norm 2"):
        read_pose_stream(p)
    np.savetxt(p, _rows(rig.t_a[:2], rig.T_a[:2]), fmt="%.10f", delimiter=",")
    with pytest.raises(ValueError, match="2 usable poses .* at least 3"):
        read_pose_stream(p)
    p.write_text("hello world\nfoo\n")
    with pytest.raises(ValueError, match="could not detect the format .* name it"):
        read_pose_stream(p)
    with pytest.raises(ValueError, match="does not exist"):
        read_pose_stream(tmp_path / "missing.csv")


def _pairs(rig, n=25):
    # synchronous samples: b taken at a's instants (a 30 Hz, every 12th frame)
    k = np.arange(0, rig.t_a.size, 12)[:n]
    return rig.T_a[k], rig.T_a[k] @ rig.X      # world_b = world_a here


@pytest.mark.slow
def test_easy_handeye_and_moveit_two_streams(tmp_path, rig):
    Ta, Tb = _pairs(rig)
    T_cam_target = invert_transform(Tb)          # tracking output: target in the camera

    def tf(T):
        q = quat_from_matrix(T[:3, :3])
        return {"translation": dict(zip("xyz", map(float, T[:3, 3]))),
                "rotation": dict(zip("xyzw", map(float, q)))}
    doc = [{"robot": tf(a), "tracking": tf(b)} for a, b in zip(Ta, T_cam_target)]
    p = tmp_path / "samples.yaml"
    p.write_text(yaml.safe_dump(doc))
    a, b = read_pose_streams(p)
    assert (a.format, a.name, b.name) == ("easy_handeye", "robot", "tracking")
    assert a.synthetic_time and np.allclose(b.T_world_sensor, T_cam_target)
    rep = detect_conventions(a, b)
    assert rep.invert_b and not rep.invert_a and rep.clear, rep.message
    a2, b2 = apply_conventions(a, b, rep)
    assert np.allclose(b2.T_world_sensor, Tb, atol=1e-9)
    doc = [{"effector_wrt_world": A.reshape(-1).tolist(),
            "object_wrt_sensor": B.tolist()} for A, B in zip(Ta, T_cam_target)]
    p = tmp_path / "moveit.yaml"
    p.write_text(yaml.safe_dump(doc))
    a, b = read_pose_streams(p)
    assert a.format == "moveit" and b.name == "object_wrt_sensor"
    assert np.allclose(a.T_world_sensor, Ta) and np.allclose(b.T_world_sensor, T_cam_target)
    with pytest.raises(ValueError, match="pick one"):
        read_pose_stream(p)
    assert read_pose_stream(p, stream="effector_wrt_world").name == "effector_wrt_world"


@pytest.mark.slow
def test_conventions_detect_inverse_and_scalar_first(tmp_path):
    rs = rig_streams(offset_s=0.04, duration_s=20.0, rng=np.random.default_rng(4))
    pa = tmp_path / "a.csv"
    np.savetxt(pa, _rows(rs.t_a, rs.T_a), fmt="%.10f", delimiter=",")
    pb = tmp_path / "b.csv"   # inverse poses, quaternions scalar-first, no header: ETH reader
    np.savetxt(pb, _rows(rs.t_b, invert_transform(rs.T_b), "wxyz"), fmt="%.10f", delimiter=",")
    a, b = read_pose_stream(pa), read_pose_stream(pb)
    rep = detect_conventions(a, b)
    assert (rep.invert_a, rep.invert_b, rep.swap_scalar_a, rep.swap_scalar_b) == \
        (False, True, False, True), rep.message
    assert rep.clear and rep.ratio > 10, rep.message
    assert "b: inverted" in rep.message and "swapped" in rep.message
    a2, b2 = apply_conventions(a, b, rep)
    assert np.allclose(b2.T_world_sensor, rs.T_b, atol=1e-8)
    # forcing a (wrong) reading is honoured and reported, and it fits worse
    rep2 = detect_conventions(a, b, invert_a=False, invert_b=False, scalar_first_b=True)
    assert not rep2.invert_b and rep2.swap_scalar_b
    assert "forced by the caller: invert_a, invert_b, scalar_first_b" in rep2.message
    assert min(rep2.scores.values()) > 10 * min(rep.scores.values())
    # only b's parity relative to a is identifiable: forcing b as written inverts a instead
    rep3 = detect_conventions(a, b, invert_b=False, scalar_first_b=True)
    assert rep3.invert_a and np.isclose(min(rep3.scores.values()), min(rep.scores.values()),
                                        rtol=0.5)


def test_stream_from_arrays(rig):
    s = stream_from_arrays(rig.t_a, rig.T_a, name="a")
    assert s.n == rig.t_a.size and s.format == "arrays"
    with pytest.raises(ValueError, match=r"shape \(N, 4, 4\)"):
        stream_from_arrays(rig.t_a, rig.T_a[:, :3])


@pytest.mark.skipif(not ETH.is_dir(), reason=f"ETH data sets not present at {ETH} "
                    "(set SIMCALIB_ETH_DIR)")
@pytest.mark.slow
def test_eth_data_conventions_and_calibration():
    from simcalib.estimation.path import calibrate_streams
    from simcalib.studies.experiments.streams import eth_files
    files = eth_files(ETH)
    assert set(files) == {"robot_arm_w_color_camera_sim", "prime_sense_1"}
    for name, (fa, fb) in files.items():
        r = calibrate_streams(fa, fb)
        c = r.conventions
        assert c.clear and not c.invert_b and not c.swap_scalar_a and not c.swap_scalar_b, \
            (name, c.message)
        assert r.stream_a.format == "eth" and r.robust.n_inliers >= 0.8 * r.C.shape[0]
        s = r.summary
        assert s["residuals_inliers"]["rot_median_deg"] < 2.0
        assert (s["residuals_inliers"]["trans_median_mm"]
                <= s["residuals_plain"]["trans_median_mm"] + 0.05)


@pytest.mark.slow
def test_simulation_round_trip_through_files(tmp_path):
    """Export a rig's streams with a clock offset, outlier poses and b written inverted and
    scalar-first; read them back and calibrate: the truth is recovered."""
    from simcalib.estimation.path import calibrate_streams
    from simcalib.geometry import rotation_error_rad, translation_error_m
    rs = rig_streams(offset_s=0.037, duration_s=30.0, outlier_fraction=0.03,
                     rng=np.random.default_rng(11))
    pa = write_tum(tmp_path / "a.tum", rs.t_a, rs.T_a)
    pb = tmp_path / "b.csv"
    np.savetxt(pb, _rows(rs.t_b, invert_transform(rs.T_b), "wxyz"), fmt="%.10f", delimiter=",",
               header="t,x,y,z,q0,q1,q2,q3", comments="")   # q0..q3 read scalar-first: right
    r = calibrate_streams(pa, pb)
    c = r.conventions
    assert c.invert_b and not c.swap_scalar_b and not c.invert_a and c.clear, c.message
    assert abs(r.time_offset.offset_s - 0.037) < 3e-3, r.time_offset.message
    assert np.degrees(rotation_error_rad(r.X, rs.X)) < 0.1
    assert translation_error_m(r.X, rs.X) < 2e-3
    assert r.robust.n_inliers < r.C.shape[0]            # the outlier motions were rejected
    assert translation_error_m(r.X, rs.X) < translation_error_m(r.X_plain, rs.X)


def test_standard_tum_header_alone_is_plain_tum_not_simcalib_output(tmp_path, rig):
    # numpy (or any tool, or simcalib before its signature line) writing the standard
    # TUM header is not simcalib's output: read as plain TUM, never labelled simcalib
    p = tmp_path / "numpy.tum"
    np.savetxt(p, _rows(rig.t_a, rig.T_a), fmt="%.10f",
               header="timestamp tx ty tz qx qy qz qw")
    assert p.read_text().startswith("# timestamp tx ty tz qx qy qz qw\n")
    s = read_pose_stream(p)
    assert s.format == "tum" and "simcalib" not in s.detection
    _same(s, rig.t_a, rig.T_a)


def test_empty_and_comment_only_files_say_so(tmp_path):
    empty, comments = tmp_path / "empty.txt", tmp_path / "comments.txt"
    empty.write_text("\n\n")
    comments.write_text("# timestamp tx ty tz qx qy qz qw\n\n# nothing recorded\n")
    with pytest.raises(ValueError, match="is empty"):
        read_pose_stream(empty)
    with pytest.raises(ValueError, match="holds no pose rows: its 3 lines"):
        read_pose_stream(comments)


@pytest.mark.parametrize("unit,factor", [("ms", 1e3), ("us", 1e6), ("ns", 1e9)])
def test_unix_stamps_in_ms_us_ns_are_rescaled_to_seconds_and_counted(tmp_path, rig, unit,
                                                                      factor):
    t = 1.7e9 + rig.t_a[:60]
    p = tmp_path / f"{unit}.txt"
    np.savetxt(p, _rows(np.round(t * factor), rig.T_a[:60]), fmt="%.17g")
    s = read_pose_stream(p, format="tum")
    assert np.allclose(s.timestamps_s, t, atol=1 / factor + 1e-6, rtol=0)
    assert s.repairs == {f"stamps_{unit}_to_s": 60}
    assert f"unix time in {unit}" in s.detection and f"stamps_{unit}_to_s: 60" in s.describe()


def test_seconds_index_and_relative_stamps_stay_seconds_and_unknown_units_are_refused(
        tmp_path, rig):
    p = tmp_path / "s.txt"
    for t in (1.7e9 + rig.t_a[:40], rig.t_a[:40], np.arange(40.0), 600.0 * np.arange(40)):
        np.savetxt(p, _rows(t, rig.T_a[:40]), fmt="%.17g")
        s = read_pose_stream(p, format="tum")
        assert np.allclose(s.timestamps_s, t) and not s.repairs
    # relative stamps in ns (30 Hz): 3.3e7 a pose - neither seconds nor told apart from us
    np.savetxt(p, _rows(np.round(1e9 * rig.t_a[:40]), rig.T_a[:40]), fmt="%.17g")
    with pytest.raises(DataError, match=r"step by 3\.333e\+07 .*unit cannot be told.*allowed: "
                                        r"stamps in seconds, or unix time in s, ms, us or ns"):
        read_pose_stream(p, format="tum")


def test_nine_columns_named_tum_is_a_data_error_naming_the_line(tmp_path, rig):
    p = tmp_path / "nine.txt"
    R = np.column_stack([_rows(rig.t_a[:10], rig.T_a[:10]), np.ones(10)])
    p.write_text("# header\n\n" + "\n".join(" ".join(f"{v:.9g}" for v in r) for r in R))
    for fmt, sep in (("tum", " "), ("eth", ", ")):
        p.write_text("# header\n\n" + "\n".join(sep.join(f"{v:.9g}" for v in r) for r in R))
        with pytest.raises(DataError, match=r"line 3: 9 values a row; .* rows have 8"):
            read_pose_stream(p, format=fmt)


def test_a_byte_order_mark_is_ignored(tmp_path, rig):
    p = tmp_path / "bom.txt"
    R = _rows(rig.t_a[:20], rig.T_a[:20])
    text = "\n".join(" ".join(f"{v:.12g}" for v in r) for r in R) + "\n"
    p.write_bytes(b"\xef\xbb\xbf" + text.encode())
    for fmt in (None, "tum"):
        s = read_pose_stream(p, format=fmt)
        assert s.format == "tum" and s.n == 20
        _same(s, rig.t_a[:20], rig.T_a[:20])


def test_repeated_stamps_keep_the_row_consistent_with_the_neighbours(rig):
    t, T = rig.t_a[:80], rig.T_a[:80]
    k = np.arange(5, 75, 7)
    # a stale pose (the previous frame's) re-published at the stamp, before the right one
    s = stream_from_arrays(np.concatenate([t[k], t]), np.concatenate([T[k - 1], T]))
    _same(s, t, T)
    assert s.repairs == {"out_of_order_rows_sorted": s.repairs["out_of_order_rows_sorted"],
                         "duplicate_timestamps_kept_consistent": k.size}
    # the next frame's pose stamped early, after the right one
    s = stream_from_arrays(np.concatenate([t, t[k]]), np.concatenate([T, T[k + 1]]))
    _same(s, t, T)
    # a different pose that repeats no neighbour: the one nearest the neighbours' path
    s = stream_from_arrays(np.concatenate([t[k], t]), np.concatenate([T[k + 3], T]))
    _same(s, t, T)
    # identical repeats stay one row
    s = stream_from_arrays(np.concatenate([t, t[k]]), np.concatenate([T, T[k]]))
    _same(s, t, T)
    assert s.repairs["duplicate_rows_dropped"] == k.size


def _tum(t, T, path):
    np.savetxt(path, _rows(t, T), fmt="%.9f")
    return path


def test_two_recordings_in_one_file_keep_the_longest(rig, tmp_path):
    """A logger restarted: the second recording's stamps go back into the first's time.
    Sorting would interleave two recordings; the longest is kept and the rest counted."""
    t, T = rig.t_a[:300], rig.T_a[:300]
    t2 = np.concatenate([t[:120], t[120:] - 3.0 + 0.013])     # back 3 s, off the first's grid
    s = stream_from_arrays(t2, T)
    assert s.repairs == {"stamps_restarted": 1, "rows_of_other_recordings_dropped": 120,
                         "recordings_in_file": 2, "recording_kept": 2}
    _same(s, t2[120:], T[120:])
    f = _tum(t2, T, tmp_path / "two.txt")
    _same(read_pose_stream(f, recording=1), t2[:120], T[:120])    # the one asked for
    with pytest.raises(DataError, match="recording 3 asked of a file holding 2 recordings"):
        read_pose_stream(f, recording=3)
    # a station logger numbering its rows from 0 again: the same stamps, other poses
    idx = np.concatenate([np.arange(12.0), np.arange(15.0)])
    s = stream_from_arrays(idx, T[:27])
    assert s.repairs["recordings_in_file"] == 2 and s.n == 15
    _same(s, np.arange(15.0), T[12:27])
    # shuffled rows, or rows re-published at their own stamps, are sorted as before
    order = np.random.default_rng(0).permutation(300)
    assert "stamps_restarted" not in stream_from_arrays(t[order], T[order]).repairs
    k = np.arange(5, 75, 7)
    s = stream_from_arrays(np.concatenate([t[k], t]), np.concatenate([T[k], T]))
    assert "stamps_restarted" not in s.repairs and s.n == 300


def test_stamps_that_all_repeat_cannot_be_told_and_are_dropped(rig):
    t, T = np.floor(rig.t_a[:90]), rig.T_a[:90]          # 1 s stamps for 30 Hz poses
    with pytest.raises(DataError, match="0 usable poses .*dropped_ambiguous: 90.*too coarsely"):
        stream_from_arrays(t, T)


def test_stamps_unit_given_or_left_for_the_pair(tmp_path, rig):
    p = tmp_path / "rel_ns.txt"
    np.savetxt(p, _rows(np.round(1e9 * rig.t_a[:40]), rig.T_a[:40]), fmt="%.17g")
    s = read_pose_stream(p, format="tum", stamps_unit="ns")
    assert np.allclose(s.timestamps_s, rig.t_a[:40], atol=1e-9) and s.stamps_unit == "ns"
    assert not s.repairs and "stamps in ns (given)" in s.detection
    s = read_pose_stream(p, format="tum", stamps_unit="pair")     # the pair will judge
    assert np.array_equal(s.timestamps_s, np.round(1e9 * rig.t_a[:40])) and not s.stamps_unit
    with pytest.raises(ValueError, match="stamps_unit must be one of auto, pair, s, ms"):
        read_pose_stream(p, format="tum", stamps_unit="min")


def test_a_zero_quaternion_row_is_dropped_as_a_repair(tmp_path, rig):
    rows = _rows(rig.t_a[:40], rig.T_a[:40])
    rows[17, 4:] = 0.0                               # a tracker's "no pose" row
    np.savetxt(tmp_path / "z.tum", rows, fmt="%.9f")
    s = read_pose_stream(tmp_path / "z.tum")
    assert s.n == 39 and s.repairs == {"zero_quaternion_rows_dropped": 1}
    _same(s, np.delete(rig.t_a[:40], 17), np.delete(rig.T_a[:40], 17, axis=0))
    rows[:, 4:] = 0.0
    np.savetxt(tmp_path / "z.tum", rows, fmt="%.9f")
    with pytest.raises(DataError, match=r"every row's quaternion is \(0, 0, 0, 0\)"):
        read_pose_stream(tmp_path / "z.tum")
    rows[:, 4:] = [0.0, 0.0, 0.0, 0.5]               # not zero, not unit: still an error
    np.savetxt(tmp_path / "z.tum", rows, fmt="%.9f")
    with pytest.raises(DataError, match="row 0 has quaternion .* of norm 0.5"):
        read_pose_stream(tmp_path / "z.tum")


@pytest.mark.parametrize("fmt", ["tum", "csv"])
def test_a_last_row_cut_off_mid_write_is_dropped_as_a_repair(tmp_path, rig, fmt):
    rows = _rows(rig.t_a[:40], rig.T_a[:40])
    path = tmp_path / f"cut.{'txt' if fmt == 'tum' else 'csv'}"
    if fmt == "tum":
        np.savetxt(path, rows, fmt="%.9f")
    else:
        np.savetxt(path, rows, fmt="%.9f", delimiter=",", header="t,x,y,z,qx,qy,qz,qw",
                   comments="")
    text = path.read_text().rstrip("\n")
    for cut in (text[:text.rfind(" " if fmt == "tum" else ",")],     # a value short
                text[:text.rfind(" " if fmt == "tum" else ",") - 4] + "1.2e"):  # mid-number
        path.write_text(cut)
        s = read_pose_stream(path)
        assert s.n == 39 and s.repairs == {"truncated_last_row_dropped": 1}, cut[-40:]
        _same(s, rig.t_a[:39], rig.T_a[:39])
    # a short row before the last one is no truncation: an error naming the file and line
    lines = text.splitlines()
    lines[5] = lines[5][:lines[5].rfind(" " if fmt == "tum" else ",")]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=rf"{re.escape(str(path))}.*line 6: 7 values"):
        read_pose_stream(path)


def test_windows_line_endings_read_alike(tmp_path, rig):
    rows = _rows(rig.t_a[:40], rig.T_a[:40])
    np.savetxt(tmp_path / "w.txt", rows, fmt="%.9f", newline="\r\n",
               header="timestamp tx ty tz qx qy qz qw")
    s = read_pose_stream(tmp_path / "w.txt")
    assert s.format == "tum" and s.repairs == {}
    _same(s, rig.t_a[:40], rig.T_a[:40])


@pytest.mark.parametrize("names", [("sec", "nsec"), ("header.stamp.secs",
                                                    "header.stamp.nsecs")])
def test_ros_stamps_in_two_columns_secs_and_nsecs_are_added(tmp_path, rig, names):
    t = 1701234567.0 + rig.t_a[:40]
    sec = np.floor(t)
    nsec = np.round((t - sec) * 1e9)
    rows = np.column_stack([sec, nsec, _rows(t, rig.T_a[:40])[:, 1:]])
    np.savetxt(tmp_path / "ros.csv", rows, fmt="%.9f", delimiter=",", comments="",
               header=",".join(names) + ",x,y,z,qx,qy,qz,qw")
    s = read_pose_stream(tmp_path / "ros.csv")
    assert not s.synthetic_time and "ROS secs + nsecs" in s.detection
    np.testing.assert_allclose(s.timestamps_s, t, atol=2e-6)


def test_csv_pair_holds_both_streams_under_their_prefixes(tmp_path, rig):
    """A script's log of the robot and the camera side by side: one time column, each
    stream under its prefix, the camera's columns empty where it did not see the target;
    ``calibrate`` takes the file alone."""
    from simcalib.cli import main
    n = 300
    G = np.linalg.inv(rig.T_a[7])                           # the camera's own world
    Tb = G @ rig.T_a[:n] @ rig.X
    ra, rb = _rows(rig.t_a[:n], rig.T_a[:n]), _rows(rig.t_a[:n], Tb)
    cells = [[f"{v:.12f}" for v in row] for row in np.column_stack([ra, rb[:, 1:]])]
    for k in (5, 17):
        cells[k][8:] = [""] * 7                              # the camera saw nothing
    head = ("time,robot_x,robot_y,robot_z,robot_qx,robot_qy,robot_qz,robot_qw,"
            "cam.position.x,cam.position.y,cam.position.z,cam.orientation.w,"
            "cam.orientation.x,cam.orientation.y,cam.orientation.z")
    order = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 14, 11, 12, 13]   # the camera's w first
    p = tmp_path / "log.csv"
    p.write_text(head + "\n" + "\n".join(",".join(c[i] for i in order) for c in cells) + "\n")
    assert detect_format(p)[0] == "csv_pair"
    a, b = read_pose_streams(p)
    assert (a.name, b.name, a.n, b.n) == ("robot", "cam", n, n - 2)
    assert b.repairs["rows_without_this_stream_dropped"] == 2 and b.quat_order == "wxyz"
    keep = np.setdiff1d(np.arange(n), [5, 17])
    _same(a, rig.t_a[:n], rig.T_a[:n])
    _same(b, rig.t_a[:n][keep], Tb[keep])
    assert main(["calibrate", f"a={p}", f"output={tmp_path / 'out'}", "recording=false"]) == 0
    X = np.asarray(json.loads((tmp_path / "out" / "calibration.json").read_text())["X"]["T_a_b"])
    assert np.allclose(X, rig.X, atol=1e-6)
