"""KITTI odometry poses: one pose per line, 12 numbers separated by whitespace — the top
3x4 block of ``T_world_cam`` row-major (``r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz``;
KITTI: the pose of the left camera cam0 in the first frame's cam0, metres), no header, no
stamps. The format of the KITTI odometry benchmark's ``poses/XX.txt`` and of what the
tools that evaluate on it write (evo ``--save_as_kitti``, ORB-SLAM's ``CameraTrajectory``
in KITTI mode).

The stamps live in a file of their own, one time in seconds per line: ``times=PATH`` when
given, else the first that exists of ``<stem>_times.txt`` beside the poses (what
:func:`write` and evo write), ``times.txt`` beside them, and KITTI's own layout
``dataset/sequences/<stem>/times.txt`` for ``dataset/poses/<stem>.txt``. Without one the
line index is the time (said so in the detection message, ``synthetic_time``). The text
is rounded (6 digits in KITTI's files): the rotation blocks are re-orthonormalised (counted
as a repair when one is off by more than 1e-6).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simcalib.importers import RawStream, data_error, first_data_line, numeric_rows, \
    register_format

NAME = "kitti"
DESCRIPTION = ("KITTI odometry poses: 12 numbers a line (3x4 T_world_cam row-major), "
               "stamps from times.txt beside")
TWO_STREAMS = False


def _block(values) -> np.ndarray | None:
    """The 3x3 rotation block of one line of 12 numbers, or None if it is not one."""
    if len(values) != 12:
        return None
    R = np.asarray(values, dtype=np.float64).reshape(3, 4)[:, :3]
    if not np.isfinite(R).all():
        return None
    return R


def sniff(path, text: str) -> float:
    line = first_data_line(text)
    if not line or "," in line or ";" in line:
        return 0.0
    try:
        R = _block([float(v) for v in line.split()])
    except ValueError:
        return 0.0
    if R is None or np.abs(R.T @ R - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
        return 0.0
    return 0.9


def times_file(path) -> Path | None:
    """The stamps file of the poses file ``path`` (module docstring), or None."""
    p = Path(path)
    for cand in (p.with_name(f"{p.stem}_times.txt"), p.with_name("times.txt"),
                 p.parent.parent / "sequences" / p.stem / "times.txt"):
        if cand.is_file() and cand.resolve() != p.resolve():
            return cand
    return None


def read(path, text: str, *, times=None, **options) -> list[RawStream]:
    """One stream; ``times``: the stamps file (default: found beside, :func:`times_file`)."""
    if options:
        raise TypeError(f"kitti reader takes only times=PATH; received {sorted(options)}")
    rows, _ = numeric_rows(text, None)
    if rows.shape[1] != 12:
        raise data_error(f"{path}: KITTI rows have 12 values (a 3x4 matrix row-major); "
                         f"received {rows.shape[1]}")
    M = np.zeros((rows.shape[0], 4, 4))
    M[:, :3, :] = rows.reshape(-1, 3, 4)
    M[:, 3, 3] = 1.0
    tfile = Path(times) if times is not None else times_file(path)
    if tfile is None:
        return [RawStream(np.arange(M.shape[0], dtype=np.float64), matrices=M,
                          quat_order="matrix", synthetic_time=True,
                          note="no times.txt beside the poses: the line index is the time")]
    if not tfile.is_file():
        raise data_error(f"{path}: times file {str(tfile)!r} does not exist")
    t, _ = numeric_rows(tfile.read_text(), None)
    if t.shape[1] != 1 or t.shape[0] != M.shape[0]:
        raise data_error(f"{path}: {M.shape[0]} poses but {tfile} holds {t.shape[0]} lines "
                         f"of {t.shape[1]} values; one time (s) a line, one a pose")
    return [RawStream(t[:, 0], matrices=M, quat_order="matrix",
                      note=f"stamps from {tfile.name}")]


def write(path, streams) -> list[Path]:
    """Write one stream (a :class:`~simcalib.importers.PoseStreamData`) as KITTI poses at
    ``path`` and its stamps at ``<stem>_times.txt`` beside; returns both paths."""
    (s,) = streams
    p = Path(path)
    T = np.asarray(s.T_world_sensor, dtype=np.float64)
    np.savetxt(p, T[:, :3, :].reshape(-1, 12), fmt="%.12e")
    stamps = p.with_name(f"{p.stem}_times.txt")
    np.savetxt(stamps, np.asarray(s.timestamps_s, dtype=np.float64), fmt="%.9f")
    return [p, stamps]


register_format(__name__)
