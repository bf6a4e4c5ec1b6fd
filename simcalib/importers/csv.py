"""CSV with a header naming its columns (any order; comma, semicolon, tab or whitespace
separated).

Recognised column names (case-insensitive; prefixes such as ``field.pose.`` are ignored):
time ``t``/``time``/``timestamp``/``stamp``/``%time`` (nanoseconds if named ``*_ns``/
``nsec``); position ``x y z``/``tx ty tz``/``px``.../``position.x``...; quaternion
``qx qy qz qw``/``quat_x``.../``orientation.x``.../``rotation_w``... (order given by the names,
so scalar-first and scalar-last files both read right), or ``q0 q1 q2 q3`` / ABB's
``q1 q2 q3 q4`` (read scalar-first, the usual meaning, and said so); or a 4x4 row-major
matrix ``m00 .. m33``
(also ``T_0_0``, ``r00``...; the bottom row may be omitted: 12 columns). Without a time
column the row index is used as time (said so in the detection message).
"""

from __future__ import annotations

import re

import numpy as np

from simcalib.importers import RawStream, data_error, pose_rows, register_format

NAME = "csv"
DESCRIPTION = "CSV with a header naming the columns (quaternion xyzw/wxyz or 4x4 matrix)"
TWO_STREAMS = False

_TIME = {"t", "time", "timestamp", "timestamps", "stamp", "times", "sec", "secs", "time_s",
         "timestamp_s", "t_s"}
_TIME_NS = {"time_ns", "timestamp_ns", "t_ns", "stamp_ns", "nsec", "nsecs"}
_QUAT_PREFIX = ("q", "quat", "quaternion", "orientation", "rotation", "rot", "ori")
_POS_PREFIX = ("", "p", "pos", "position", "t", "trans", "translation", "xyz")
_MAT = re.compile(r"(?:m|t|mat|matrix|r|h|pose)_?([0-3])_?([0-3])")


def _split(line: str) -> list[str]:
    for sep in (",", ";", "\t"):
        if sep in line:
            return [p.strip() for p in line.split(sep)]
    return line.split()


def _clean(name: str) -> str:
    n = name.strip().strip('"').strip("'").lower().lstrip("#%").strip()
    for pre in ("field.", "pose.", "transform."):
        while n.startswith(pre):
            n = n[len(pre):]
    return n


def classify(name: str):
    """``("time", scale)``, ``("pos", axis)``, ``("quat", axis)``, ``("q_index", k)``,
    ``("mat", (i, j))`` or ``None`` for a column name."""
    n = _clean(name)
    flat = re.sub(r"[^a-z0-9]+", "_", n).strip("_")
    if flat in _TIME_NS or flat.endswith(("_nsec", "_nsecs")):
        return ("time", 1e-9)
    if flat.endswith(("_sec", "_secs")):                # ROS header.stamp.secs
        return ("time", 1.0)
    if flat in _TIME or flat.endswith("_time") or flat.endswith("stamp"):
        return ("time", 1.0)
    m = _MAT.fullmatch(flat.replace("_", "")) or _MAT.fullmatch(flat)
    if m:
        return ("mat", (int(m.group(1)), int(m.group(2))))
    m = re.fullmatch(r"q_?([0-4])", flat)
    if m:
        return ("q_index", int(m.group(1)))
    m = re.fullmatch(r"(.*?)_?([xyzw])", flat)
    if m:
        head, axis = m.group(1).strip("_"), m.group(2)
        tail = head.split("_")[-1] if head else ""
        if tail in _QUAT_PREFIX or head in _QUAT_PREFIX:
            return ("quat", axis)
        if axis != "w" and (tail in _POS_PREFIX or head in _POS_PREFIX):
            return ("pos", axis)
    return None


def _header(text: str):
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith(("#", "%")):
            s = s.lstrip("#%").strip()      # a commented header: '# timestamp tx ty ...'
            if not any(classify(c) for c in _split(s)):
                continue
        return lineno, _split(s)
    return None, []


def _layout(names: list[str]):
    roles = [classify(c) for c in names]
    time = [(k, r[1]) for k, r in enumerate(roles) if r and r[0] == "time"]
    pos = {r[1]: k for k, r in enumerate(roles) if r and r[0] == "pos"}
    quat = {r[1]: k for k, r in enumerate(roles) if r and r[0] == "quat"}
    qidx = {r[1]: k for k, r in enumerate(roles) if r and r[0] == "q_index"}
    mat = {r[1]: k for k, r in enumerate(roles) if r and r[0] == "mat"}
    return time, pos, quat, qidx, mat


def sniff(path, text: str) -> float:
    lineno, names = _header(text)
    if not names:
        return 0.0
    from simcalib.importers import tum
    header = text.splitlines()[lineno - 1].lstrip()
    if header.startswith(("#", "%")) and tum.sniff(path, text) > 0:
        return 0.0          # TUM rows under the TUM header comment: the TUM reader's file
    try:
        [float(c) for c in names]
        return 0.0          # a numeric first line is not a header
    except ValueError:
        pass
    time, pos, quat, qidx, mat = _layout(names)
    if len(mat) >= 12:
        return 0.95
    if set("xyz") <= set(pos) and (set("xyzw") <= set(quat) or len(qidx) == 4):
        return 0.95
    return 0.0


def _rows(path, text: str, lineno: int, width: int) -> tuple[np.ndarray, bool]:
    """``(rows, truncated)``: the data rows under the header; the file's last row, when it
    holds fewer values than the header names (a recording cut off while writing), is
    dropped (``truncated``)."""
    lines = [(k, ln.strip()) for k, ln in enumerate(text.splitlines()[lineno:], lineno + 1)]
    lines = [(k, s) for k, s in lines if s and not s.startswith("#")]
    rows = []
    for i, (k, s) in enumerate(lines):
        parts = _split(s)
        last = i == len(lines) - 1 and rows
        if len(parts) < width and last:
            return np.asarray(rows, dtype=np.float64), True
        if len(parts) != width:
            raise data_error(f"{path}, line {k}: {len(parts)} values for {width} header "
                             "columns")
        try:
            rows.append([float(p) if p.lower() not in ("", "nan", "none", "null") else np.nan
                         for p in parts])
        except ValueError:
            raise data_error(f"{path}, line {k}: could not read numbers from {s[:100]!r}") \
                from None
    if not rows:
        raise data_error(f"{path}: header but no data rows")
    return np.asarray(rows, dtype=np.float64), False


def _times(A: np.ndarray, time: list) -> tuple[np.ndarray, bool, list]:
    """``(t, synthetic, notes)``: the stamps of the rows ``A`` from the time columns
    ``time`` (``[(column, scale)]``): a seconds and a nanoseconds column (ROS
    ``stamp.secs`` / ``stamp.nsecs``) are added, else the first is used; without one the
    row index (``synthetic``)."""
    if not time:
        return np.arange(A.shape[0], dtype=np.float64), True, [
            "no time column: the row index is used as time"]
    sec = [c for c, sc in time if sc == 1.0]
    nsec = [c for c, sc in time if sc == 1e-9]
    if sec and nsec:
        return A[:, sec[0]] + 1e-9 * A[:, nsec[0]], False, [
            "stamps: a seconds column plus a nanoseconds column (ROS secs + nsecs)"]
    col, scale = time[0]
    return A[:, col] * scale, False, []


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"csv reader takes no options; received {sorted(options)}")
    lineno, names = _header(text)
    if not names:
        raise data_error(f"{path}: no header line found")
    time, pos, quat, qidx, mat = _layout(names)
    A, truncated = _rows(path, text, lineno, len(names))
    repairs = {"truncated_last_row_dropped": 1} if truncated else {}
    t, synthetic, notes = _times(A, time)
    return [raw_stream(path, A, t, (pos, quat, qidx, mat), notes, synthetic, repairs)]


def raw_stream(path, A, t, layout, notes, synthetic, repairs, name="") -> RawStream:
    """The :class:`RawStream` of the rows ``A`` whose pose columns are ``layout`` (``(pos,
    quat, qidx, mat)``: role -> column, :func:`_layout`), stamped ``t``."""
    pos, quat, qidx, mat = layout
    notes = list(notes)
    if len(mat) >= 12:
        M = np.zeros((A.shape[0], 4, 4))
        M[:, 3, 3] = 1.0
        for (i, j), col in mat.items():
            M[:, i, j] = A[:, col]
        missing = [(i, j) for i in range(3) for j in range(4) if (i, j) not in mat]
        if missing:
            raise data_error(f"{path}: matrix columns missing for entries {missing}")
        notes.append("4x4 row-major matrix columns")
        return RawStream(t, matrices=M, quat_order="matrix", note="; ".join(notes),
                         synthetic_time=synthetic, repairs=repairs, name=name)
    P = A[:, [pos["x"], pos["y"], pos["z"]]]
    if set("xyzw") <= set(quat):
        Q = A[:, [quat["x"], quat["y"], quat["z"], quat["w"]]]
        order = "wxyz" if quat["w"] < quat["x"] else "xyzw"
        notes.append(f"quaternion columns named, file order {order}")
    else:
        k = min(qidx)                       # q0..q3, or ABB's q1..q4
        Q = A[:, [qidx[k + 1], qidx[k + 2], qidx[k + 3], qidx[k]]]
        order = "wxyz"
        notes.append(f"columns q{k}..q{k + 3} read scalar-first (q{k} = w); the convention "
                     "check tests the other order")
    return RawStream(t, position_m=P, quat_xyzw=Q, quat_order=order, note="; ".join(notes),
                     synthetic_time=synthetic, repairs=repairs, name=name)


def write(path, streams):
    """One stream with the header ``t,x,y,z,qx,qy,qz,qw``."""
    (s,) = streams
    np.savetxt(path, pose_rows(s), fmt="%.9f", delimiter=",", header="t,x,y,z,qx,qy,qz,qw",
               comments="")
    return [path]


register_format(__name__)
