"""CSV of a robot controller's poses: a position and three angles per row, as controllers
log them (no quaternion, no matrix: those files are :mod:`simcalib.importers.csv`'s).

The column names tell the convention (case-insensitive, after
:func:`simcalib.importers.csv.classify`'s cleaning; a time column as there, else the row
index):

- ``ur``: Universal Robots' RTDE log, ``actual_TCP_pose_0..5`` (or ``target_TCP_pose_*``):
  x, y, z in metres and a rotation vector in radians.
- ``kuka``: ``X Y Z A B C``: millimetres, and degrees turned about z (A), the new y (B),
  the newest x (C).
- ``fanuc``: ``X Y Z W P R``: millimetres, and degrees turned about the fixed x (W), y (P),
  z (R) axes: the same matrix as R, P, W about z, y', x''.
- ``rpy``: ``x y z roll pitch yaw`` (ROS REP 103: fixed x, y, z axes): positions as
  written (metres in ROS); the angles in degrees where named ``*_deg``, in radians where
  named ``*_rad``, else radians unless a value lies beyond pi (then degrees; the
  detection message says which was read).
- ``rotvec``: ``x y z rotvec_x rotvec_y rotvec_z`` (or ``rvec_*``): as written, radians.

``rx ry rz`` is refused with what it may mean: Universal Robots write a rotation vector in
radians under those names, Techman and Yaskawa fixed-axis x-y-z angles in degrees, Doosan
z-y-z angles in degrees; the file cannot tell them apart. Millimetres are read as metres
(divided by 1000, said in the detection message). Written back as a UR RTDE log.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import matrix_from_euler_zyx, matrix_from_rotvec, rotvec_from_matrix
from simcalib.importers import RawStream, data_error, register_format
from simcalib.importers import csv as _csv

NAME = "robot_csv"
DESCRIPTION = ("CSV of a robot controller's poses: position + angles (UR rotation vector, "
               "KUKA XYZABC, Fanuc XYZWPR, roll/pitch/yaw, rotvec_x..)")
TWO_STREAMS = False


@dataclass(frozen=True)
class Convention:
    """How one controller writes a pose: the angle columns (in the order the rotation
    takes them), ``rotvec`` or ``euler_zyx`` (:func:`simcalib.geometry.
    matrix_from_euler_zyx`'s ``(a, b, c)``), the angles' unit (None: told by name or
    range), metres per position unit."""
    angles: tuple
    kind: str
    degrees: bool | None
    metres_per_unit: float
    label: str


CONVENTIONS = {
    "kuka": Convention(("a", "b", "c"), "euler_zyx", True, 1e-3,
                       "KUKA X Y Z A B C: mm, deg about z, y', x''"),
    "fanuc": Convention(("r", "p", "w"), "euler_zyx", True, 1e-3,
                        "Fanuc X Y Z W P R: mm, deg about fixed x, y, z"),
    "rpy": Convention(("yaw", "pitch", "roll"), "euler_zyx", None, 1.0,
                      "x y z roll pitch yaw (REP 103, fixed x, y, z axes)"),
    "rotvec": Convention(("rotvec_x", "rotvec_y", "rotvec_z"), "rotvec", False, 1.0,
                         "x y z + rotation vector (rad)"),
}
_UR = re.compile(r"(?:.*_)?tcp_pose_?([0-5])")
_ALIASES = {"rvec_x": "rotvec_x", "rvec_y": "rotvec_y", "rvec_z": "rotvec_z"}
_UNIT = re.compile(r"(roll|pitch|yaw)_(deg|rad)")


def _flat(name: str) -> str:
    flat = re.sub(r"[^a-z0-9]+", "_", _csv._clean(name)).strip("_")
    return _ALIASES.get(flat, flat)


def _match(names: list[str]):
    """``(convention name, {role: column}, angle units named)`` of a header, or None.
    Roles: ``x y z`` and the convention's angle names."""
    flat = [_flat(n) for n in names]
    ur = {int(m.group(1)): k for k, f in enumerate(flat) if (m := _UR.fullmatch(f))}
    if len(ur) == 6:
        return "ur", {r: ur[i] for i, r in enumerate(("x", "y", "z", *CONVENTIONS[
            "rotvec"].angles))}, None
    units = {m.group(1): m.group(2) for f in flat if (m := _UNIT.fullmatch(f))}
    flat = [m.group(1) if (m := _UNIT.fullmatch(f)) else f for f in flat]
    cols = {f: k for k, f in enumerate(flat)}
    if not {"x", "y", "z"} <= set(cols):
        return None
    for name, conv in CONVENTIONS.items():
        if set(conv.angles) <= set(cols):
            return name, {r: cols[r] for r in ("x", "y", "z", *conv.angles)}, units or None
    if {"rx", "ry", "rz"} <= set(cols):
        return "rx_ry_rz", {}, None
    return None


def _full_pose_columns(names: list[str]) -> bool:
    """A quaternion or a matrix is named too: the csv reader's file."""
    _, pos, quat, qidx, mat = _csv._layout(names)
    return len(mat) >= 12 or set("xyzw") <= set(quat) or len(qidx) == 4


def sniff(path, text: str) -> float:
    lineno, names = _csv._header(text)
    if not names or _full_pose_columns(names):
        return 0.0
    return 0.95 if _match(names) else 0.0


def _radians(angles: np.ndarray, conv: Convention, units, path) -> tuple[np.ndarray, str]:
    """The angle columns in radians and how their unit was told."""
    if conv.degrees is not None:
        return (np.radians(angles) if conv.degrees else angles), (
            "deg" if conv.degrees else "rad")
    if units:
        if len(set(units.values())) > 1:
            raise data_error(f"{path}: the angle columns name different units {units}; "
                             "allowed: all *_deg or all *_rad")
        unit = next(iter(units.values()))
        return (np.radians(angles) if unit == "deg" else angles), f"{unit} (named)"
    beyond = np.nanmax(np.abs(angles)) > math.pi + 1e-6 if angles.size else False
    return (np.radians(angles), "deg (a value beyond pi)") if beyond else (
        angles, "rad (no value beyond pi; name the columns *_deg for degrees)")


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"robot_csv reader takes no options; received {sorted(options)}")
    lineno, names = _csv._header(text)
    found = _match(names) if names else None
    if found is None:
        raise data_error(f"{path}: no robot pose columns found in the header {names}")
    name, cols, units = found
    if name == "rx_ry_rz":
        raise data_error(
            f"{path}: columns rx, ry, rz are a rotation vector in radians (Universal "
            "Robots), fixed-axis x-y-z angles in degrees (Techman, Yaskawa) or z-y-z angles "
            "in degrees (Doosan), by the controller; the file cannot tell which. Rename "
            "them: rotvec_x, rotvec_y, rotvec_z for a rotation vector, or roll_deg, "
            "pitch_deg, yaw_deg for fixed x-y-z angles (or write quaternions)")
    conv = CONVENTIONS["rotvec" if name == "ur" else name]
    A, truncated = _csv._rows(path, text, lineno, len(names))
    repairs = {"truncated_last_row_dropped": 1} if truncated else {}
    time = _csv._layout(names)[0]
    t, synthetic, notes = _csv._times(A, [(k, s) for k, s in time if k not in cols.values()])
    angles, unit = _radians(A[:, [cols[r] for r in conv.angles]], conv, units, path)
    M = np.zeros((A.shape[0], 4, 4))
    M[:, 3, 3] = 1.0
    M[:, :3, :3] = (matrix_from_rotvec(np.nan_to_num(angles)) if conv.kind == "rotvec"
                    else matrix_from_euler_zyx(np.nan_to_num(angles)))
    M[:, :3, 3] = A[:, [cols["x"], cols["y"], cols["z"]]] * conv.metres_per_unit
    M[~np.isfinite(angles).all(axis=1)] = np.nan          # a NaN angle: a dropped row
    label = "UR RTDE actual_TCP_pose: m, rotation vector (rad)" if name == "ur" else conv.label
    mm = ", positions in mm read as metres" if conv.metres_per_unit != 1.0 else ""
    notes.append(f"{label}; angles in {unit}{mm}")
    return [RawStream(t, matrices=M, quat_order="matrix", note="; ".join(notes),
                      synthetic_time=synthetic, repairs=repairs)]


def write(path, streams):
    """One stream as a UR RTDE log: ``timestamp,actual_TCP_pose_0..5``."""
    (s,) = streams
    T = np.asarray(s.T_world_sensor)
    rows = np.column_stack([s.timestamps_s, T[:, :3, 3], rotvec_from_matrix(T[:, :3, :3])])
    header = "timestamp," + ",".join(f"actual_TCP_pose_{k}" for k in range(6))
    np.savetxt(path, rows, fmt="%.12g", delimiter=",", header=header, comments="")
    return [path]


register_format(__name__)
