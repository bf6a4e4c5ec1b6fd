"""simcalib.ros.exports: every export parses back to X (rotation, translation within 1e-9,
quaternions up to sign) for many random X, rpy at and near gimbal lock, 180 deg turns; the
URDF through yourdfpy, the launch file through ast/compile; frame names verbatim; bad
inputs raise ValueError saying what was received."""

from __future__ import annotations

import ast
import io
import math
import shlex

import numpy as np
import pytest
import yaml

from simcalib.errors import ConfigError
from simcalib.ros.exports import (EXPORT_KINDS, ExportFrames, easy_handeye2_calib, kalibr_yaml,
                              launch_file, matrix_from_rpy, parse_easy_handeye2, parse_kalibr,
                              parse_launch_file, parse_static_transform_publisher,
                              parse_urdf_joint, rpy_from_matrix, static_transform_publisher,
                              urdf_joint, urdf_robot, write_exports)
from simcalib.geometry import (invert_transform, matrix_from_quat, matrix_from_rotvec,
                               quat_from_matrix, quat_multiply,
                               random_rotation_matrices, transform_from_rotation_translation)

TOL = 1e-9


def _q(axis, angle):
    return np.array([*(np.sin(angle / 2) * np.asarray(axis, float)), np.cos(angle / 2)])


def _special_rotations(rng) -> list[np.ndarray]:
    """Gimbal lock (pitch exactly and nearly +-90 deg, any roll/yaw), 180 deg turns about
    coordinate and random axes, the identity."""
    out = [np.eye(3)]
    for pitch in (math.pi / 2, -math.pi / 2):
        for d in (0.0, 1e-13, -1e-13, 1e-9, -1e-9, 1e-6, -1e-6):
            roll, yaw = rng.uniform(-math.pi, math.pi, 2)
            out.append(matrix_from_rpy(roll, pitch + d, yaw))
        out.append(matrix_from_rpy(0.0, pitch, 0.0))
        for d in (0.0, 1e-10, -1e-8):     # built from quaternions: R00, R10 ~ rounding noise
            roll, yaw = rng.uniform(-math.pi, math.pi, 2)
            q = quat_multiply(quat_multiply(_q([0, 0, 1], yaw), _q([0, 1, 0], pitch + d)),
                              _q([1, 0, 0], roll))
            out.append(matrix_from_quat(q))
    axes = [np.eye(3)[i] for i in range(3)] + [v / np.linalg.norm(v) for v in
                                              rng.standard_normal((5, 3))]
    out += [matrix_from_rotvec(math.pi * a) for a in axes]
    out += [matrix_from_rpy(math.pi, 0.0, 0.0), matrix_from_rpy(0.0, 0.0, math.pi),
            matrix_from_rpy(math.pi, math.pi / 2, -math.pi)]
    return out


def _cases(seed: int = 2026, n_random: int = 60) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    Rs = list(random_rotation_matrices(rng, n_random)) + _special_rotations(rng)
    ts = rng.uniform(-2.0, 2.0, (len(Rs), 3))
    ts[0] = 0.0
    ts[1] = [1e-12, -3.5e7, 0.0]
    return [transform_from_rotation_translation(R, t) for R, t in zip(Rs, ts)]


CASES = _cases()


def assert_same_pose(got, want, tol=TOL):
    got, want = np.asarray(got), np.asarray(want)
    assert np.abs(got[:3, :3] - want[:3, :3]).max() < tol, "rotation"
    scale = max(1.0, float(np.abs(want[:3, 3]).max()))
    assert np.abs(got[:3, 3] - want[:3, 3]).max() < tol * scale, "translation"
    assert np.array_equal(got[3], [0, 0, 0, 1])
    q1, q2 = quat_from_matrix(got[:3, :3]), quat_from_matrix(want[:3, :3])
    assert min(np.abs(q1 - q2).max(), np.abs(q1 + q2).max()) < tol, "quaternion"


# ------------------------------------------------------------------------------ rpy
def test_rpy_is_rz_ry_rx():
    r, p, y = 0.3, -0.2, 1.1
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    np.testing.assert_allclose(matrix_from_rpy(r, p, y), Rz @ Ry @ Rx, atol=1e-15)
    np.testing.assert_allclose(rpy_from_matrix(Rz @ Ry @ Rx), (r, p, y), atol=1e-14)


@pytest.mark.parametrize("k", range(len(CASES)))
def test_rpy_rebuilds_the_rotation(k):
    R = CASES[k][:3, :3]
    roll, pitch, yaw = rpy_from_matrix(R)
    assert -math.pi / 2 <= pitch <= math.pi / 2
    assert np.abs(matrix_from_rpy(roll, pitch, yaw) - R).max() < 1e-12


# ------------------------------------------------------------------------ round trips
@pytest.mark.parametrize("k", range(len(CASES)))
def test_every_export_parses_back_to_X(k):
    X = CASES[k]
    assert_same_pose(parse_urdf_joint(urdf_joint(X, "tool0", "camera_link")).X, X)
    assert_same_pose(parse_urdf_joint(urdf_robot(X, "tool0", "camera_link")).X, X)
    assert_same_pose(parse_static_transform_publisher(
        static_transform_publisher(X, "tool0", "camera_link")).X, X)
    assert_same_pose(parse_launch_file(launch_file(X, "tool0", "camera_link")).X, X)
    for in_hand in (True, False):
        assert_same_pose(parse_easy_handeye2(easy_handeye2_calib(
            X, in_hand, "base_link", "tool0", "camera_link", "board")).X, X)
    assert_same_pose(parse_kalibr(kalibr_yaml(X)).X, X)


@pytest.mark.parametrize("k", range(0, len(CASES), 7))
def test_urdf_loads_in_yourdfpy(k, tmp_path):
    yourdfpy = pytest.importorskip("yourdfpy")
    X = CASES[k]
    u = yourdfpy.URDF.load(io.StringIO(urdf_robot(X, "tool0", "camera_link")),
                           load_meshes=False)
    assert u.validate()
    j = u.joint_map["tool0_to_camera_link"]
    assert (j.type, j.parent, j.child) == ("fixed", "tool0", "camera_link")
    assert_same_pose(j.origin, X)
    assert_same_pose(u.get_transform("camera_link", "tool0"), X)   # pose of child in parent


def test_launch_file_compiles_and_names_the_node():
    X = CASES[3]
    text = launch_file(X, "base_link", "camera_color_optical_frame")
    compile(text, "static_transform.launch.py", "exec")
    tree = ast.parse(text)
    fn = [n for n in tree.body if isinstance(n, ast.FunctionDef)]
    assert [f.name for f in fn] == ["generate_launch_description"]
    imports = {(n.module, a.name) for n in tree.body if isinstance(n, ast.ImportFrom)
               for a in n.names}
    assert imports == {("launch", "LaunchDescription"), ("launch_ros.actions", "Node")}
    p = parse_launch_file(text)
    assert (p.parent, p.child) == ("base_link", "camera_color_optical_frame")
    assert p.details["node_name"] == "static_tf_base_link_to_camera_color_optical_frame"


def test_static_tf_command_is_the_ros2_form():
    X = CASES[5]
    argv = shlex.split(static_transform_publisher(X, "tool0", "cam"))
    assert argv[:4] == ["ros2", "run", "tf2_ros", "static_transform_publisher"]
    flags = argv[4::2]
    assert flags == ["--x", "--y", "--z", "--qx", "--qy", "--qz", "--qw", "--frame-id",
                     "--child-frame-id"]
    vals = dict(zip(argv[4::2], argv[5::2]))
    np.testing.assert_array_equal([float(vals[f"--{c}"]) for c in "xyz"], X[:3, 3])
    q = [float(vals[f"--q{c}"]) for c in "xyzw"]
    assert q[3] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-15
    assert (vals["--frame-id"], vals["--child-frame-id"]) == ("tool0", "cam")


@pytest.mark.parametrize("k", [0, 4, 61, 70])
def test_static_tf_legacy_positional_forms(k):
    X = CASES[k]
    t, q = X[:3, 3], quat_from_matrix(X[:3, :3])
    roll, pitch, yaw = rpy_from_matrix(X[:3, :3])
    quat_cmd = "rosrun tf2_ros static_transform_publisher " + " ".join(
        repr(float(v)) for v in [*t, *q]) + " a b"
    rpy_cmd = "ros2 run tf2_ros static_transform_publisher " + " ".join(
        repr(float(v)) for v in [*t, yaw, pitch, roll]) + " a b"
    old_tf = ("rosrun tf static_transform_publisher " + " ".join(
        repr(float(v)) for v in [*t, yaw, pitch, roll]) + " a b 100")
    for cmd in (quat_cmd, rpy_cmd, old_tf):
        p = parse_static_transform_publisher(cmd)
        assert (p.parent, p.child) == ("a", "b")
        assert_same_pose(p.X, X)
    t = [float(v) for v in t]
    flags = (f"static_transform_publisher --x {t[0]!r} --y {t[1]!r} --z {t[2]!r} "
             f"--roll {roll!r} --pitch {pitch!r} --yaw {yaw!r} --frame-id a "
             "--child-frame-id b")
    assert_same_pose(parse_static_transform_publisher(flags).X, X)


def test_easy_handeye2_layout_and_frames():
    X = CASES[9]
    for in_hand, parent, kind in ((True, "tool0", "eye_in_hand"),
                                  (False, "base_link", "eye_on_base")):
        text = easy_handeye2_calib(X, in_hand, "base_link", "tool0", "camera_link", "board",
                                   name="ur5_eih")
        doc = yaml.safe_load(text)
        assert list(doc) == ["parameters", "transform"]
        assert doc["parameters"] == {
            "name": "ur5_eih", "calibration_type": kind, "robot_base_frame": "base_link",
            "robot_effector_frame": "tool0", "tracking_base_frame": "camera_link",
            "tracking_marker_frame": "board", "freehand_robot_movement": True,
            "move_group_namespace": "/", "move_group": "manipulator"}
        assert list(doc["transform"]["translation"]) == ["x", "y", "z"]
        assert list(doc["transform"]["rotation"]) == ["x", "y", "z", "w"]
        p = parse_easy_handeye2(text)
        assert (p.parent, p.child, p.details["eye_on_hand"]) == (parent, "camera_link",
                                                                in_hand)


def test_easy_handeye2_parses_the_older_layout():
    X = CASES[12]
    t, q = X[:3, 3], quat_from_matrix(X[:3, :3])
    old = yaml.safe_dump({"parameters": {"eye_on_hand": False, "robot_base_frame": "base",
                                         "robot_effector_frame": "ee",
                                         "tracking_base_frame": "cam",
                                         "tracking_marker_frame": "m"},
                          "transformation": {"x": float(t[0]), "y": float(t[1]),
                                             "z": float(t[2]), "qx": float(q[0]),
                                             "qy": float(q[1]), "qz": float(q[2]),
                                             "qw": float(q[3])}})
    p = parse_easy_handeye2(old)
    assert (p.parent, p.child) == ("base", "cam")
    assert_same_pose(p.X, X)


def test_kalibr_direction_maps_points_from_cam0_to_cam1():
    """X = T_a_b (p_a = X p_b); cam0 = a, cam1 = b; T_cn_cnm1 maps p_cam0 to p_cam1."""
    X = CASES[2]
    doc = yaml.safe_load(kalibr_yaml(X, {"camera_model": "pinhole",
                                         "intrinsics": [400.0, 400.0, 320.0, 240.0]},
                                     rostopic_a="/cam0/image_raw",
                                     rostopic_b="/cam1/image_raw"))
    M = np.array(doc["cam1"]["T_cn_cnm1"])
    p_b = np.array([0.3, -0.1, 2.0, 1.0])
    p_a = X @ p_b
    np.testing.assert_allclose(M @ p_a, p_b, atol=1e-12)
    assert "T_cn_cnm1" not in doc["cam0"]
    assert doc["cam0"]["intrinsics"] == [400.0, 400.0, 320.0, 240.0]
    assert (doc["cam0"]["rostopic"], doc["cam1"]["rostopic"]) == ("/cam0/image_raw",
                                                                  "/cam1/image_raw")
    p = parse_kalibr(kalibr_yaml(X))
    assert (p.parent, p.child) == ("cam0", "cam1")
    assert_same_pose(p.X, X)
    assert_same_pose(invert_transform(p.details["T_cn_cnm1"]), X)


# ------------------------------------------------------------------ frame names verbatim
ODD = ("robot1/tool0", "camera_color_optical_frame", "ns:cam-1.link")


def test_frame_names_appear_verbatim():
    X = CASES[4]
    a, b = ODD[0], ODD[2]
    for text, parsed in ((urdf_joint(X, a, b), parse_urdf_joint),
                         (static_transform_publisher(X, a, b), parse_static_transform_publisher),
                         (launch_file(X, a, b), parse_launch_file)):
        assert a in text and b in text
        p = parsed(text)
        assert (p.parent, p.child) == (a, b)
    eh = easy_handeye2_calib(X, True, "base", a, b, ODD[1])
    assert all(f in eh for f in ("base", a, b, ODD[1]))
    assert (parse_easy_handeye2(eh).parent, parse_easy_handeye2(eh).child) == (a, b)
    assert 'link="a&amp;b"' in urdf_joint(X, "a&b", "c")          # XML-escaped, parses back
    assert parse_urdf_joint(urdf_joint(X, "a&b", "c")).parent == "a&b"


# ------------------------------------------------------------------------ bad inputs
NOT_RIGID = [np.diag([2.0, 1.0, 1.0, 1.0]), np.diag([1.0, 1.0, -1.0, 1.0]), np.eye(3),
             np.full((4, 4), np.nan), np.vstack([np.eye(4)[:3], [0.0, 0.0, 1.0, 1.0]])]


@pytest.mark.parametrize("bad", range(len(NOT_RIGID)))
def test_non_rigid_X_is_rejected(bad):
    X = NOT_RIGID[bad]
    makers = [lambda: urdf_joint(X, "a", "b"), lambda: static_transform_publisher(X, "a", "b"),
              lambda: launch_file(X, "a", "b"),
              lambda: easy_handeye2_calib(X, True, "a", "b", "c", "d"),
              lambda: kalibr_yaml(X)]
    for make in makers:
        with pytest.raises(ValueError, match="X") as exc:
            make()
        msg = str(exc.value)
        assert any(w in msg for w in ("received", "det", "NaN", "bottom row")), msg


@pytest.mark.parametrize("name", ["", "   ", None, "has space", "/leading", "tab\there"])
def test_bad_frame_names_are_rejected(name):
    X = np.eye(4)
    for make in (lambda: urdf_joint(X, name, "b"), lambda: urdf_joint(X, "a", name),
                 lambda: static_transform_publisher(X, name, "b"),
                 lambda: launch_file(X, "a", name),
                 lambda: easy_handeye2_calib(X, False, "a", "b", name, "d")):
        with pytest.raises(ValueError) as exc:
            make()
        assert f"received {name!r}" in str(exc.value)
        assert isinstance(exc.value, ConfigError)


def test_parsers_reject_what_is_not_theirs():
    with pytest.raises(ValueError, match="no Node"):
        parse_launch_file("x = 1\n")
    with pytest.raises(ValueError, match="not Python source"):
        parse_launch_file("def (:\n")
    with pytest.raises(ValueError, match="not a URDF"):
        parse_urdf_joint("<joint")
    with pytest.raises(ValueError, match="expected one <joint>"):
        parse_urdf_joint("<robot name='r'/>")
    with pytest.raises(ValueError, match="origin xyz must be 3 numbers"):
        parse_urdf_joint('<joint name="j" type="fixed"><parent link="a"/><child link="b"/>'
                         '<origin xyz="1 2"/></joint>')
    with pytest.raises(ValueError, match="unknown argument '--bogus'"):
        parse_static_transform_publisher("static_transform_publisher --bogus 1")
    with pytest.raises(ValueError, match="not a unit quaternion"):
        parse_static_transform_publisher("static_transform_publisher 0 0 0 0 0 0 2 a b")
    with pytest.raises(ValueError, match="received"):
        parse_static_transform_publisher("static_transform_publisher 1 2 a b")
    with pytest.raises(ValueError, match="--x must be a number; received 'one'"):
        parse_static_transform_publisher("static_transform_publisher --x one --frame-id a "
                                         "--child-frame-id b")
    with pytest.raises(ValueError, match="no camera 'cam1'"):
        parse_kalibr("cam0: {rostopic: /x}\n")
    with pytest.raises(ValueError, match="not an easy_handeye2"):
        parse_easy_handeye2("a: 1\n")


def test_urdf_joint_defaults_identity_origin():
    p = parse_urdf_joint('<joint name="j" type="fixed"><parent link="a"/><child link="b"/>'
                         '</joint>')
    assert_same_pose(p.X, np.eye(4))


# ---------------------------------------------------------------------- write_exports
def test_write_exports_writes_every_kind(tmp_path):
    X = CASES[7]
    frames = ExportFrames("tool0", "camera_link", eye="in_hand", robot_frame="base_link",
                          marker_frame="board", name="ur5_eih")
    paths = write_exports(tmp_path / "out", X, list(EXPORT_KINDS), frames)
    assert set(paths) == set(EXPORT_KINDS)
    names = {k: p.name for k, p in paths.items()}
    assert names == {"urdf": "calibration.urdf", "static_tf": "static_transform_publisher.sh",
                     "launch": "static_transform.launch.py", "easy_handeye2": "ur5_eih.calib",
                     "kalibr": "camchain.yaml"}
    parsers = {"urdf": parse_urdf_joint, "launch": parse_launch_file,
               "easy_handeye2": parse_easy_handeye2, "kalibr": parse_kalibr,
               "static_tf": lambda t: parse_static_transform_publisher(t.splitlines()[-1])}
    for k, p in paths.items():
        parsed = parsers[k](p.read_text())
        assert_same_pose(parsed.X, X)
        if k != "kalibr":
            assert (parsed.parent, parsed.child) == ("tool0", "camera_link"), k
    assert paths["static_tf"].stat().st_mode & 0o111
    eh = parse_easy_handeye2(paths["easy_handeye2"].read_text())
    assert eh.details["parameters"]["robot_base_frame"] == "base_link"


def test_write_exports_eye_on_base_frames(tmp_path):
    X = CASES[8]
    frames = ExportFrames("base_link", "camera_link", eye="on_base", robot_frame="tool0")
    p = write_exports(tmp_path, X, "easy_handeye2", frames)["easy_handeye2"]
    parsed = parse_easy_handeye2(p.read_text())
    assert parsed.details["parameters"]["calibration_type"] == "eye_on_base"
    assert parsed.details["parameters"]["robot_effector_frame"] == "tool0"
    assert (parsed.parent, parsed.child) == ("base_link", "camera_link")


def test_write_exports_checks_before_writing(tmp_path):
    frames = ExportFrames("tool0", "camera_link")
    with pytest.raises(ConfigError, match="unknown export kind 'urfd'.*did you mean 'urdf'"):
        write_exports(tmp_path / "a", np.eye(4), ["urdf", "urfd"], frames)
    with pytest.raises(ConfigError, match="eye.*in_hand or on_base.*received None"):
        write_exports(tmp_path / "b", np.eye(4), ["urdf", "easy_handeye2"], frames)
    with pytest.raises(ConfigError, match="frame_b must be a non-empty frame name"):
        write_exports(tmp_path / "c", np.eye(4), ["urdf"], ExportFrames("tool0", ""))
    with pytest.raises(ConfigError, match="one or more of"):
        write_exports(tmp_path / "d", np.eye(4), [], frames)
    assert not any((tmp_path / d).exists() for d in "abcd")


# ------------------------------------------------------- the command without a bag
@pytest.fixture(scope="module")
def pose_files(tmp_path_factory):
    """Two TUM files of a simulated rigid pair (X = T_a_b), no bag."""
    from simcalib.report.results import write_tum
    from simcalib.world.stream_sim import rig_streams
    d = tmp_path_factory.mktemp("files")
    rs = rig_streams(duration_s=8.0, rng=np.random.default_rng(2))
    return (write_tum(d / "a.tum", rs.t_a, rs.T_a), write_tum(d / "b.tum", rs.t_b, rs.T_b))


@pytest.mark.parametrize("eye, base, effector", [("in_hand", "base_link", "tool0"),
                                                 ("on_base", "base_link", "tool0")])
def test_command_writes_easy_handeye2_without_a_bag(pose_files, tmp_path, capsys, eye, base,
                                                    effector):
    """export=[easy_handeye2] from pose files: frame_a / frame_b / eye and the robot's
    other frame (robot_frame: the base in hand, the effector on base) as keys."""
    import json

    from simcalib.cli import main
    frame_a, robot = (effector, base) if eye == "in_hand" else (base, effector)
    out = tmp_path / "calib"
    code = main(["calibrate", f"a={pose_files[0]}", f"b={pose_files[1]}", f"output={out}",
                 "recording=false", f"eye={eye}", f"frame_a={frame_a}", "frame_b=camera",
                 f"robot_frame={robot}", "marker_frame=board", "export=[easy_handeye2]",
                 "time_offset=0"])
    capsys.readouterr()
    assert code in (0, 6)
    rep = json.loads((out / "calibration.json").read_text())
    eh = parse_easy_handeye2((out / rep["files"]["exports"]["easy_handeye2"]).read_text())
    p = eh.details["parameters"]
    assert (p["robot_base_frame"], p["robot_effector_frame"]) == (base, effector)
    assert (p["tracking_base_frame"], p["tracking_marker_frame"]) == ("camera", "board")
    assert (eh.parent, eh.child) == (frame_a, "camera")
    assert np.abs(eh.X - np.asarray(rep["X"]["T_a_b"])).max() < 1e-9


@pytest.mark.parametrize("drop, needle", [
    ("robot_frame", "give robot_frame=NAME, the robot base frame with eye=in_hand"),
    ("frame_b", "frame_b must be given for export= without bag="),
])
def test_command_names_the_missing_export_key(pose_files, tmp_path, capsys, drop, needle):
    """Without bag= the frames come from keys only: a missing one is named before any work
    (exit 2, no output written)."""
    from simcalib.cli import main
    keys = {"eye": "in_hand", "frame_a": "tool0", "frame_b": "camera",
            "robot_frame": "base_link"}
    del keys[drop]
    out = tmp_path / "calib"
    code = main(["calibrate", f"a={pose_files[0]}", f"b={pose_files[1]}", f"output={out}",
                 "recording=false", "export=[easy_handeye2]",
                 *(f"{k}={v}" for k, v in keys.items())])
    assert code == 2 and needle in capsys.readouterr().err
    assert not (out / "calibration.json").exists()
