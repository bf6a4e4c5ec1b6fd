"""The calibration result in the formats robot software loads, and parsers back.

``X = T_a_b`` is the pose of frame b in frame a (``p_a = X p_b``). Every export states it as
the transform from a *parent* frame (a) to a *child* frame (b), the way tf, URDF and
easy_handeye2 mean it: the child's pose in the parent.

=================  =========================================================================
kind               what is written (file name in :func:`write_exports`)
=================  =========================================================================
``urdf``           a fixed joint ``<joint type="fixed"><parent/><child/><origin xyz rpy/>``
                   inside a two-link ``<robot>`` (``calibration.urdf``): copy the joint into
                   your URDF / xacro. ``rpy``: ROS's fixed-axis roll, pitch, yaw,
                   ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
``static_tf``      the ROS 2 command ``ros2 run tf2_ros static_transform_publisher --x .. --y
                   .. --z .. --qx .. --qy .. --qz .. --qw .. --frame-id a --child-frame-id b``
                   (``static_transform_publisher.sh``).
``launch``         a ROS 2 Python launch file with that node (``static_transform.launch.py``).
``easy_handeye2``  an easy_handeye2 ``.calib`` YAML (``<name>.calib``), see
                   :func:`easy_handeye2_calib`.
``kalibr``         a Kalibr camchain (``camchain.yaml``): cam0 = a, cam1 = b and cam1's
                   ``T_cn_cnm1 = T_cam1_cam0 = X^-1`` (it maps points from cam0 to cam1).
=================  =========================================================================

Numbers are written with Python's shortest round-trip repr, so parsing back gives X to the
last bit of the representation (rotation through rpy: to ~1e-15). Bad inputs raise
``ValueError`` (a non-rigid X) or :class:`simcalib.errors.ConfigError` (empty or invalid frame
names, unknown kinds; also a ``ValueError``) saying what was received.
"""

from __future__ import annotations

import ast
import math
import re
import shlex
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from simcalib.errors import ConfigError, unknown_choice
from simcalib.geometry import (check_transforms, invert_transform, matrix_from_quat,
                               quat_from_matrix, transform_from_rotation_translation)

__all__ = ["EXPORT_KINDS", "EXPORT_FILES", "ExportFrames", "ParsedTransform",
           "rpy_from_matrix", "matrix_from_rpy", "urdf_joint", "urdf_robot",
           "static_transform_publisher", "launch_file", "easy_handeye2_calib", "kalibr_yaml",
           "write_exports", "parse_urdf_joint", "parse_static_transform_publisher",
           "parse_launch_file", "parse_easy_handeye2", "parse_kalibr"]

EXPORT_KINDS = ("urdf", "static_tf", "launch", "easy_handeye2", "kalibr")
EXPORT_FILES = {"urdf": "calibration.urdf", "static_tf": "static_transform_publisher.sh",
                "launch": "static_transform.launch.py", "easy_handeye2": "{name}.calib",
                "kalibr": "camchain.yaml"}
STP_PREFIX = ["ros2", "run", "tf2_ros", "static_transform_publisher"]
EYES = ("in_hand", "on_base")


# ------------------------------------------------------------------------ results
@dataclass(frozen=True)
class ParsedTransform:
    """What a parser read back: ``X`` (4x4, ``T_parent_child``), the frames, the export's
    ``kind`` and anything else it holds (``details``: the joint name, easy_handeye2's
    parameters, Kalibr's camera blocks)."""
    kind: str
    X: np.ndarray
    parent: str
    child: str
    details: dict = field(default_factory=dict)


@dataclass(frozen=True)
class ExportFrames:
    """Frame names for :func:`write_exports`.

    ``frame_a`` / ``frame_b``: the parent and child of ``X = T_a_b``. easy_handeye2 also
    needs ``eye`` (``in_hand``: frame_a is the robot effector; ``on_base``: frame_a is the
    robot base; frame_b is the tracking base frame, i.e. the camera), ``robot_frame`` (the
    other robot frame: the base when the eye is in hand, the effector when on base) and
    ``marker_frame`` (the tracking marker frame). ``name`` names the calibration (the
    ``.calib`` file); ``rostopic_a`` / ``_b`` go into Kalibr's camera blocks."""
    frame_a: str
    frame_b: str
    eye: str | None = None
    robot_frame: str | None = None
    marker_frame: str | None = None
    name: str = "simcalib"
    rostopic_a: str | None = None
    rostopic_b: str | None = None


# ------------------------------------------------------------------------- checks
def _check_X(X) -> np.ndarray:
    arr = np.asarray(X)
    if arr.shape != (4, 4):
        raise ValueError(f"X must be one 4x4 rigid transform; received shape {arr.shape}")
    return check_transforms(arr, "X")


_FRAME_BAD = re.compile(r"[\s\x00-\x1f\x7f]")


def _check_frame(value, key: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(key=key, value=value, allowed="a non-empty frame name")
    if _FRAME_BAD.search(value):
        raise ConfigError(key=key, value=value,
                          allowed="a frame name without whitespace or control characters")
    if value.startswith("/"):
        raise ConfigError(key=key, value=value,
                          allowed="a frame name without a leading '/' (tf2 rejects it)")
    return value


def _num(v) -> str:
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(f"cannot export the non-finite number {x!r}")
    return repr(x + 0.0)            # -0.0 -> 0.0


# ------------------------------------------------------------------------------- rpy
def matrix_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` (ROS / URDF fixed-axis roll-pitch-yaw)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def rpy_from_matrix(R) -> tuple[float, float, float]:
    """``(roll, pitch, yaw)`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)``, pitch in
    [-pi/2, pi/2]. Stable at gimbal lock (pitch = +-90 deg): pitch from ``atan2`` of the
    first column, yaw from it (0 when the column is exactly along z), and roll from the
    remainder ``Ry(pitch)^T Rz(yaw)^T R`` so the three angles rebuild R to rounding."""
    R = np.asarray(R, dtype=np.float64)
    c = math.hypot(R[0, 0], R[1, 0])
    pitch = math.atan2(-R[2, 0], c)
    yaw = math.atan2(R[1, 0], R[0, 0]) if c > 1e-12 else 0.0
    rest = (matrix_from_rpy(0.0, pitch, yaw)).T @ R
    roll = math.atan2(rest[2, 1] - rest[1, 2], rest[1, 1] + rest[2, 2])
    return roll, pitch, yaw


def _qxyzw(X) -> np.ndarray:
    return quat_from_matrix(X[:3, :3])


def _from_tq(t, q) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    n = np.linalg.norm(q)
    if not (np.isfinite(n) and abs(n - 1.0) < 1e-6):
        raise ValueError(f"quaternion {q.tolist()} is not a unit quaternion (norm {n:.6g})")
    return transform_from_rotation_translation(matrix_from_quat(q), np.asarray(t, float))


# ------------------------------------------------------------------------------ URDF
def urdf_joint(X, parent: str, child: str, name: str | None = None) -> str:
    """A URDF fixed joint placing ``child`` at ``X = T_parent_child`` (the joint origin is
    the child's pose in the parent link's frame)."""
    X = _check_X(X)
    parent, child = _check_frame(parent, "parent"), _check_frame(child, "child")
    name = _check_frame(name, "name") if name is not None else f"{parent}_to_{child}"
    xyz = " ".join(_num(v) for v in X[:3, 3])
    rpy = " ".join(_num(v) for v in rpy_from_matrix(X[:3, :3]))
    return (f"<joint name={quoteattr(name)} type=\"fixed\">\n"
            f"  <parent link={quoteattr(parent)}/>\n"
            f"  <child link={quoteattr(child)}/>\n"
            f"  <origin xyz=\"{xyz}\" rpy=\"{rpy}\"/>\n"
            f"</joint>\n")


def urdf_robot(X, parent: str, child: str, name: str | None = None,
               robot: str = "simcalib_calibration") -> str:
    """A complete two-link URDF (``parent``, ``child`` and the fixed joint of
    :func:`urdf_joint`), loadable as it is."""
    joint = urdf_joint(X, parent, child, name)
    return (f"<?xml version=\"1.0\"?>\n<!-- simcalib: X = T_{parent}_{child} (pose of "
            f"{child} in {parent}); rpy = fixed-axis roll pitch yaw, R = Rz(yaw) Ry(pitch) "
            f"Rx(roll) -->\n<robot name={quoteattr(robot)}>\n"
            f"  <link name={quoteattr(parent)}/>\n  <link name={quoteattr(child)}/>\n"
            + "".join("  " + ln + "\n" for ln in joint.splitlines()) + "</robot>\n")


def _floats(text: str | None, n: int, what: str) -> list[float]:
    if text is None:
        return [0.0] * n
    parts = text.split()
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"{what} must be {n} numbers; received {text!r}") from None
    if len(vals) != n:
        raise ValueError(f"{what} must be {n} numbers; received {text!r}")
    return vals


def parse_urdf_joint(text: str, name: str | None = None) -> ParsedTransform:
    """X from a URDF ``<joint>`` (alone or inside a ``<robot>``; ``name`` picks one when
    there are several)."""
    try:
        root = ET.fromstring(text.strip())
    except ET.ParseError as exc:
        raise ValueError(f"not a URDF/XML text ({exc}); received {text[:80]!r}") from None
    joints = [root] if root.tag == "joint" else root.findall("joint")
    if name is not None:
        joints = [j for j in joints if j.get("name") == name]
    if len(joints) != 1:
        found = [j.get("name") for j in ([root] if root.tag == "joint"
                                         else root.findall("joint"))]
        raise ValueError(f"expected one <joint>{f' named {name!r}' if name else ''}; "
                         f"found {len(joints)} (joints: {found})")
    j = joints[0]
    parent, child, origin = j.find("parent"), j.find("child"), j.find("origin")
    if parent is None or child is None:
        raise ValueError(f"joint {j.get('name')!r} lacks <parent link> or <child link>")
    xyz = _floats(origin.get("xyz") if origin is not None else None, 3, "origin xyz")
    rpy = _floats(origin.get("rpy") if origin is not None else None, 3, "origin rpy")
    X = transform_from_rotation_translation(matrix_from_rpy(*rpy), xyz)
    return ParsedTransform("urdf", X, parent.get("link"), child.get("link"),
                           {"name": j.get("name"), "type": j.get("type"), "rpy": rpy})


# ----------------------------------------------------------- static_transform_publisher
def _stp_args(X, frame_id: str, child_frame_id: str) -> list[str]:
    X = _check_X(X)
    frame_id = _check_frame(frame_id, "frame_id")
    child_frame_id = _check_frame(child_frame_id, "child_frame_id")
    vals = list(X[:3, 3]) + list(_qxyzw(X))
    args = []
    for flag, v in zip(("--x", "--y", "--z", "--qx", "--qy", "--qz", "--qw"), vals):
        args += [flag, _num(v)]
    return args + ["--frame-id", frame_id, "--child-frame-id", child_frame_id]


def static_transform_publisher(X, frame_id: str, child_frame_id: str) -> str:
    """The ROS 2 command publishing ``X = T_frame_id_child_frame_id`` on /tf_static."""
    return shlex.join(STP_PREFIX + _stp_args(X, frame_id, child_frame_id))


_FLAGS = {"--x": "x", "--y": "y", "--z": "z", "--qx": "qx", "--qy": "qy", "--qz": "qz",
          "--qw": "qw", "--roll": "roll", "--pitch": "pitch", "--yaw": "yaw",
          "--frame-id": "frame_id", "--child-frame-id": "child_frame_id"}


def _parse_stp_args(args: list[str], where: str) -> ParsedTransform:
    """Flags (ROS 2: ``--x .. --frame-id ..``) or the positional forms ``x y z qx qy qz qw
    frame child`` / ``x y z yaw pitch roll frame child`` (ROS 1 and old ROS 2)."""
    if any(a.startswith("--") for a in args):
        got: dict[str, str] = {}
        it = iter(args)
        for a in it:
            if a.startswith("--ros-args"):
                break
            if a not in _FLAGS:
                raise ValueError(f"{where}: unknown argument {a!r}; allowed: "
                                 f"{', '.join(_FLAGS)}")
            try:
                got[_FLAGS[a]] = next(it)
            except StopIteration:
                raise ValueError(f"{where}: {a} needs a value") from None
        num = {}
        for k, v in got.items():
            if k not in ("frame_id", "child_frame_id"):
                if not _is_number(v):
                    raise ValueError(f"{where}: --{k} must be a number; received {v!r}")
                num[k] = float(v)
        t = [num.get(k, 0.0) for k in "xyz"]
        if any(k in num for k in ("qx", "qy", "qz", "qw")):
            X = _from_tq(t, [num.get("qx", 0.0), num.get("qy", 0.0), num.get("qz", 0.0),
                             num.get("qw", 1.0)])
        else:
            X = transform_from_rotation_translation(
                matrix_from_rpy(num.get("roll", 0.0), num.get("pitch", 0.0),
                                num.get("yaw", 0.0)), t)
        if "frame_id" not in got or "child_frame_id" not in got:
            raise ValueError(f"{where}: --frame-id and --child-frame-id are required; "
                             f"received {args}")
        return ParsedTransform("static_tf", X, got["frame_id"], got["child_frame_id"])
    n_num = next((i for i, a in enumerate(args) if not _is_number(a)), len(args))
    if n_num == 7 and len(args) in (9, 10):        # x y z qx qy qz qw frame child [period]
        frames = args[7:9]
        X = _from_tq([float(v) for v in args[:3]], [float(v) for v in args[3:7]])
    elif n_num == 6 and len(args) in (8, 9):       # x y z yaw pitch roll frame child [period]
        frames = args[6:8]
        yaw, pitch, roll = (float(v) for v in args[3:6])
        X = transform_from_rotation_translation(matrix_from_rpy(roll, pitch, yaw),
                                                [float(v) for v in args[:3]])
    else:
        raise ValueError(f"{where}: expected --x .. --frame-id .. flags or the positional "
                         "'x y z qx qy qz qw frame child' / 'x y z yaw pitch roll frame "
                         f"child'; received {args}")
    return ParsedTransform("static_tf", X, frames[0], frames[1])


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def parse_static_transform_publisher(command: str) -> ParsedTransform:
    """X and frames from a ``static_transform_publisher`` command line (``ros2 run`` /
    ``rosrun`` prefix optional)."""
    args = shlex.split(command.replace("\\\n", " "), comments=True)
    for i, a in enumerate(args):
        if a == "static_transform_publisher":
            args = args[i + 1:]
            break
    return _parse_stp_args(args, "static_transform_publisher")


# ----------------------------------------------------------------------- launch file
def _node_name(frame_id: str, child_frame_id: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", f"static_tf_{frame_id}_to_{child_frame_id}")


def launch_file(X, frame_id: str, child_frame_id: str, node_name: str | None = None) -> str:
    """A ROS 2 Python launch file starting tf2_ros' static_transform_publisher with
    ``X = T_frame_id_child_frame_id`` (``ros2 launch ./static_transform.launch.py``)."""
    args = _stp_args(X, frame_id, child_frame_id)
    name = node_name or _node_name(frame_id, child_frame_id)
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise ConfigError(key="node_name", value=name,
                          allowed="a ROS node name (letters, digits, '_'; not a digit first)")
    pairs = "".join(f"                {args[i]!r}, {args[i + 1]!r},\n"
                    for i in range(0, len(args), 2))
    return (f'"""simcalib calibration: X = T_{frame_id}_{child_frame_id} (pose of '
            f'{child_frame_id} in {frame_id}),\npublished on /tf_static."""\n'
            "from launch import LaunchDescription\n"
            "from launch_ros.actions import Node\n\n\n"
            "def generate_launch_description():\n"
            "    return LaunchDescription([\n"
            "        Node(\n"
            "            package='tf2_ros',\n"
            "            executable='static_transform_publisher',\n"
            f"            name={name!r},\n"
            "            arguments=[\n"
            f"{pairs}"
            "            ],\n"
            "        ),\n"
            "    ])\n")


def _call_name(func) -> str:
    return func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")


def parse_launch_file(text: str) -> ParsedTransform:
    """X from the first tf2_ros static_transform_publisher ``Node`` of a Python launch file
    (read with :mod:`ast`; nothing is executed)."""
    try:
        tree = ast.parse(text)
    except SyntaxError as exc:
        raise ValueError(f"not Python source ({exc.msg}, line {exc.lineno})") from None
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and _call_name(node.func) == "Node"):
            continue
        kw = {k.arg: k.value for k in node.keywords if k.arg}
        try:
            pkg = ast.literal_eval(kw["package"]) if "package" in kw else None
            exe = ast.literal_eval(kw["executable"]) if "executable" in kw else None
        except ValueError:
            continue
        if pkg != "tf2_ros" or exe != "static_transform_publisher":
            continue
        if "arguments" not in kw:
            raise ValueError("static_transform_publisher Node has no arguments=")
        try:
            args = [str(a) for a in ast.literal_eval(kw["arguments"])]
        except ValueError:
            raise ValueError("the Node's arguments= is not a literal list of strings") from None
        p = _parse_stp_args(args, "launch file Node arguments")
        name = ast.literal_eval(kw["name"]) if "name" in kw else None
        return ParsedTransform("launch", p.X, p.parent, p.child, {"node_name": name})
    raise ValueError("no Node(package='tf2_ros', executable='static_transform_publisher') "
                     "in the launch file")


# --------------------------------------------------------------------- easy_handeye2
def easy_handeye2_calib(X, eye_on_hand: bool, robot_base_frame: str,
                        robot_effector_frame: str, tracking_base_frame: str,
                        tracking_marker_frame: str = "tracking_marker", *,
                        name: str = "simcalib", freehand_robot_movement: bool = True,
                        move_group_namespace: str = "/", move_group: str = "manipulator") -> str:
    """An easy_handeye2 calibration file (``~/.ros2/easy_handeye2/calibrations/NAME.calib``)
    holding X.

    Layout (easy_handeye2's ``HandeyeCalibration``)::

        parameters:
          name, calibration_type (eye_in_hand | eye_on_base), robot_base_frame,
          robot_effector_frame, tracking_base_frame, tracking_marker_frame,
          freehand_robot_movement, move_group_namespace, move_group
        transform:
          translation: {x, y, z}
          rotation: {x, y, z, w}

    The transform is the pose of ``tracking_base_frame`` (the camera / tracker) in
    ``robot_effector_frame`` when the eye is in hand, in ``robot_base_frame`` when it is on
    the base; easy_handeye2's publisher broadcasts it with that parent. So ``X`` must be
    ``T_effector_camera`` (eye in hand) or ``T_base_camera`` (eye on base).
    """
    import yaml
    X = _check_X(X)
    if not isinstance(eye_on_hand, (bool, np.bool_)):
        raise ConfigError(key="eye_on_hand", value=eye_on_hand, allowed="true or false")
    frames = {k: _check_frame(v, k) for k, v in (
        ("robot_base_frame", robot_base_frame), ("robot_effector_frame", robot_effector_frame),
        ("tracking_base_frame", tracking_base_frame),
        ("tracking_marker_frame", tracking_marker_frame))}
    name = _check_frame(name, "name")
    t, q = X[:3, 3], _qxyzw(X)
    doc = {"parameters": {"name": name,
                          "calibration_type": "eye_in_hand" if eye_on_hand else "eye_on_base",
                          **frames, "freehand_robot_movement": bool(freehand_robot_movement),
                          "move_group_namespace": move_group_namespace,
                          "move_group": move_group},
           "transform": {"translation": {k: float(v) + 0.0 for k, v in zip("xyz", t)},
                         "rotation": {k: float(v) + 0.0 for k, v in zip("xyzw", q)}}}
    parent = frames["robot_effector_frame" if eye_on_hand else "robot_base_frame"]
    head = (f"# simcalib: transform = pose of {frames['tracking_base_frame']} in {parent} "
            f"({doc['parameters']['calibration_type']})\n")
    return head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=False)


def parse_easy_handeye2(text: str) -> ParsedTransform:
    """X and frames from an easy_handeye2 ``.calib`` (also the older layout with
    ``parameters.eye_on_hand`` and ``transformation: {x, y, z, qx, qy, qz, qw}``)."""
    import yaml
    doc = yaml.safe_load(text)
    if not isinstance(doc, dict) or "parameters" not in doc:
        raise ValueError(f"not an easy_handeye2 calibration (no 'parameters'); received "
                         f"{str(doc)[:80]!r}")
    p = doc["parameters"]
    if "calibration_type" in p:
        if p["calibration_type"] not in ("eye_in_hand", "eye_on_base"):
            raise ValueError(f"calibration_type must be eye_in_hand or eye_on_base; received "
                             f"{p['calibration_type']!r}")
        in_hand = p["calibration_type"] == "eye_in_hand"
    else:
        in_hand = bool(p.get("eye_on_hand"))
    try:
        if "transform" in doc:
            tr, rot = doc["transform"]["translation"], doc["transform"]["rotation"]
            t, q = [tr[k] for k in "xyz"], [rot[k] for k in "xyzw"]
        else:
            tr = doc["transformation"]
            t, q = [tr[k] for k in "xyz"], [tr[k] for k in ("qx", "qy", "qz", "qw")]
        X = _from_tq([float(v) for v in t], [float(v) for v in q])
    except (KeyError, TypeError):
        raise ValueError("easy_handeye2 calibration needs transform: {translation: {x, y, z}, "
                         "rotation: {x, y, z, w}}") from None
    parent = p["robot_effector_frame"] if in_hand else p["robot_base_frame"]
    return ParsedTransform("easy_handeye2", X, parent, p["tracking_base_frame"],
                           {"parameters": dict(p), "eye_on_hand": in_hand})


# ---------------------------------------------------------------------------- Kalibr
def kalibr_yaml(X, camera_a: dict | None = None, camera_b: dict | None = None, *,
                rostopic_a: str | None = None, rostopic_b: str | None = None) -> str:
    """A Kalibr camchain with cam0 = sensor a and cam1 = sensor b.

    Kalibr's ``T_cn_cnm1`` of camera n maps points from camera n-1 to camera n
    (``p_cn = T_cn_cnm1 p_cnm1``). Here ``p_a = X p_b``, so cam1's
    ``T_cn_cnm1 = T_b_a = X^-1``. ``camera_a`` / ``camera_b``: extra keys of each camera
    block (``camera_model``, ``intrinsics``, ``distortion_model``, ``distortion_coeffs``,
    ``resolution``), copied as given; simcalib knows only the extrinsic.
    """
    import yaml
    X = _check_X(X)
    blocks = []
    for extra, topic, key in ((camera_a, rostopic_a, "camera_a"),
                              (camera_b, rostopic_b, "camera_b")):
        if extra is not None and not isinstance(extra, dict):
            raise ConfigError(key=key, value=extra, allowed="a dict of camera fields or None")
        b = dict(extra or {})
        if topic is not None:
            b["rostopic"] = topic
        blocks.append(b)
    T = invert_transform(X)
    blocks[1]["T_cn_cnm1"] = [[float(v) + 0.0 for v in row] for row in T]
    blocks[0]["cam_overlaps"], blocks[1]["cam_overlaps"] = [1], [0]
    head = ("# simcalib: cam0 = sensor a, cam1 = sensor b; cam1.T_cn_cnm1 = T_cam1_cam0 = "
            "X^-1\n# (maps points from cam0 to cam1; X = T_a_b = pose of cam1 in cam0)\n")
    return head + yaml.safe_dump({"cam0": blocks[0], "cam1": blocks[1]}, sort_keys=False,
                                 default_flow_style=None)


def parse_kalibr(text: str, camera: str = "cam1") -> ParsedTransform:
    """X = T_cam(n-1)_cam(n) = ``T_cn_cnm1^-1`` of ``camera`` in a Kalibr camchain (parent
    ``cam(n-1)``, child ``cam(n)``)."""
    import yaml
    doc = yaml.safe_load(text)
    if not isinstance(doc, dict) or camera not in doc:
        raise ValueError(f"no camera {camera!r} in the camchain; cameras: "
                         f"{sorted(doc) if isinstance(doc, dict) else '(not a mapping)'}")
    block = doc[camera]
    if "T_cn_cnm1" not in block:
        raise ValueError(f"{camera} has no T_cn_cnm1 (the first camera has none)")
    M = np.asarray(block["T_cn_cnm1"], dtype=np.float64)
    if M.shape != (4, 4):
        raise ValueError(f"{camera}.T_cn_cnm1 must be 4x4; received shape {M.shape}")
    M = check_transforms(M, f"{camera}.T_cn_cnm1", tol=1e-6)
    n = int(camera[3:]) if camera[3:].isdigit() else None
    prev = f"cam{n - 1}" if n else "previous camera"
    return ParsedTransform("kalibr", invert_transform(M), prev, camera,
                           {"T_cn_cnm1": M, "cameras": dict(doc)})


# ------------------------------------------------------------------------- writing
def _check_kinds(kinds) -> list[str]:
    if isinstance(kinds, str):
        kinds = [k.strip() for k in kinds.strip("[]").split(",") if k.strip()]
    kinds = list(kinds)
    if not kinds:
        raise ConfigError(key="export", value=kinds,
                          allowed=f"one or more of {', '.join(EXPORT_KINDS)}")
    for k in kinds:
        if k not in EXPORT_KINDS:
            raise unknown_choice("export kind", k, EXPORT_KINDS, key="export")
    return list(dict.fromkeys(kinds))


#: what the easy_handeye2 export needs besides frame_a / frame_b (the keys to set)
ROBOT_FRAME_NEEDED = ("the robot's other frame for the easy_handeye2 export: give "
                      "robot_frame=NAME, the robot base frame with eye=in_hand (frame_a is "
                      "the effector) or the effector frame with eye=on_base (frame_a is the "
                      "base); with bag= it is the other end of a's tf spec")


def _easy_handeye2_from_frames(X, f: ExportFrames) -> str:
    if f.eye not in EYES:
        raise ConfigError(key="eye", value=f.eye, allowed="in_hand or on_base for the "
                          "easy_handeye2 export (in_hand: frame_a is the effector; on_base: "
                          "frame_a is the robot base)")
    if f.robot_frame is None:
        raise ConfigError(key="robot_frame", value=None, allowed=ROBOT_FRAME_NEEDED)
    in_hand = f.eye == "in_hand"
    base, eff = (f.robot_frame, f.frame_a) if in_hand else (f.frame_a, f.robot_frame)
    return easy_handeye2_calib(X, in_hand, base, eff, f.frame_b,
                               f.marker_frame or "tracking_marker", name=f.name)


def _render(kind: str, X, f: ExportFrames) -> str:
    if kind == "urdf":
        return urdf_robot(X, f.frame_a, f.frame_b)
    if kind == "static_tf":
        return ("#!/bin/sh\n# simcalib: X = T_" + f"{f.frame_a}_{f.frame_b} (pose of "
                f"{f.frame_b} in {f.frame_a})\n"
                + static_transform_publisher(X, f.frame_a, f.frame_b) + "\n")
    if kind == "launch":
        return launch_file(X, f.frame_a, f.frame_b)
    if kind == "easy_handeye2":
        return _easy_handeye2_from_frames(X, f)
    return kalibr_yaml(X, rostopic_a=f.rostopic_a, rostopic_b=f.rostopic_b)


def write_exports(out_dir, X, kinds, frames: ExportFrames) -> dict[str, Path]:
    """Write the exports ``kinds`` (from :data:`EXPORT_KINDS`, a list or ``"a,b"``) of
    ``X = T_a_b`` into ``out_dir``; returns kind -> path. Everything is rendered (and so
    checked) before the first file is written."""
    X = _check_X(X)
    if not isinstance(frames, ExportFrames):
        raise TypeError(f"frames must be an ExportFrames; received {type(frames).__name__}")
    _check_frame(frames.frame_a, "frame_a")
    _check_frame(frames.frame_b, "frame_b")
    texts = {k: _render(k, X, frames) for k in _check_kinds(kinds)}
    from simcalib.config.files import output_folder
    out = output_folder(out_dir)
    paths = {}
    for k, text in texts.items():
        p = out / EXPORT_FILES[k].format(name=frames.name)
        p.write_text(text)
        if k == "static_tf":
            p.chmod(0o755)
        paths[k] = p
    return paths
