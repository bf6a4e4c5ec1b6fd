"""EuRoC MAV ground truth: the ASL CSV files of the EuRoC data sets (Burri et al., IJRR
2016) — ``mav0/state_groundtruth_estimate0/data.csv`` (pose, velocity and IMU biases, 17
columns) and ``mav0/vicon0/data.csv`` (pose, 8 columns).

The header names the columns: ``#timestamp`` (nanoseconds; ``#timestamp [ns]`` in the Vicon
file), ``p_RS_R_x [m]`` .. ``p_RS_R_z`` (the body S in the world R) and ``q_RS_w []``,
``q_RS_x`` .. ``q_RS_z`` (scalar FIRST); other columns are ignored. Poses are ``T_R_S`` =
``T_world_sensor``. A file with positions only (``leica0``: a total station tracking a
prism) is not a pose stream and is refused naming the missing columns.
"""

from __future__ import annotations

import re

import numpy as np

from simcalib.importers import RawStream, data_error, pose_rows, register_format

NAME = "euroc"
DESCRIPTION = ("EuRoC ASL CSV ground truth: '#timestamp' (ns), p_RS_R_x..z, q_RS_w..z "
               "(scalar first)")
TWO_STREAMS = False

_POS = ("p_RS_R_x", "p_RS_R_y", "p_RS_R_z")
_QUAT = ("q_RS_x", "q_RS_y", "q_RS_z", "q_RS_w")          # read into x, y, z, w
_COLUMNS = ("#timestamp [ns]", *(f"{c} [m]" for c in _POS),
            "q_RS_w []", "q_RS_x []", "q_RS_y []", "q_RS_z []")


def _names(line: str) -> list[str]:
    """Column names of a header line, units (``[m]``) and the leading ``#`` removed."""
    return [re.sub(r"\s*\[.*?\]\s*$", "", c.strip()).lstrip("#").strip()
            for c in line.split(",")]


def _header(text: str) -> tuple[int, list[str]]:
    for lineno, line in enumerate(text.splitlines(), 1):
        if line.strip():
            return lineno, _names(line)
    return 0, []


def sniff(path, text: str) -> float:
    first = text.lstrip().split("\n", 1)[0]
    if not first.startswith("#timestamp") or "p_RS_R_x" not in first:
        return 0.0
    return 0.97 if "q_RS_w" in first else 0.5       # positions only: refused by read


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"euroc reader takes no options; received {sorted(options)}")
    lineno, names = _header(text)
    want = ("timestamp", *_POS, *_QUAT)
    missing = [c for c in want if c not in names]
    if missing:
        raise data_error(f"{path}: a EuRoC pose file needs the columns {list(want)}; "
                         f"missing {missing} (positions alone, e.g. leica0, are no pose)")
    cols = [names.index(c) for c in want]
    stamps, values = [], []
    for k, line in enumerate(text.splitlines()[lineno:], lineno + 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.split(",")
        if len(parts) != len(names):
            raise data_error(f"{path}, line {k}: {len(parts)} values for {len(names)} "
                             "header columns")
        try:
            stamps.append(int(parts[cols[0]]))              # exact nanoseconds
            values.append([float(parts[c]) for c in cols[1:]])
        except ValueError:
            raise data_error(f"{path}, line {k}: could not read {s[:100]!r} (integer "
                             "nanoseconds, then numbers)") from None
    if not values:
        raise data_error(f"{path}: header but no data rows")
    t_ns = np.asarray(stamps, dtype=np.int64)
    t = (t_ns // 10**9).astype(np.float64) + (t_ns % 10**9) * 1e-9   # seconds
    A = np.asarray(values, dtype=np.float64)
    return [RawStream(t, position_m=A[:, :3], quat_xyzw=A[:, 3:], quat_order="wxyz",
                      note="nanosecond stamps; quaternion columns w, x, y, z")]


def write(path, streams):
    """One stream as a EuRoC ``vicon0/data.csv``: stamps in integer nanoseconds, position,
    quaternion scalar first."""
    (s,) = streams
    rows = pose_rows(s)
    t_ns = np.round(rows[:, 0] * 1e9).astype(np.int64)
    with open(path, "w") as f:
        f.write(",".join(_COLUMNS) + "\n")
        for tn, r in zip(t_ns, rows):
            f.write(f"{tn}," + ",".join(f"{v:.9f}" for v in (*r[1:4], r[7], *r[4:7]))
                    + "\n")
    return [path]


register_format(__name__)
