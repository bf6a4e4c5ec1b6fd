"""simcalib's own TUM output (``simcalib.report.results.write_tum``): the first line
:data:`SIGNATURE` (``# simcalib TUM trajectory``), then the column header
``# timestamp tx ty tz qx qy qz qw`` and TUM rows; poses are ``T_world_cam``.

Only a file that starts with the signature is labelled simcalib output: the column header
alone is the standard TUM header, which any tool (or ``numpy.savetxt``) may write, so such
a file (also one written by simcalib before the signature) is read as plain ``tum``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simcalib.importers import PoseStreamData, pose_rows, register_format, tum

NAME = "simcalib_tum"
SIGNATURE = "# simcalib TUM trajectory"
COLUMNS = "# timestamp tx ty tz qx qy qz qw"
DESCRIPTION = f"simcalib TUM output: first line '{SIGNATURE}', then '{COLUMNS}' + TUM rows"
TWO_STREAMS = False


def sniff(path, text: str) -> float:
    first = text.lstrip().splitlines()[0].strip() if text.strip() else ""
    if first != SIGNATURE:
        return 0.0
    return 0.95 if tum.sniff(path, text) > 0 else 0.0


def read(path, text: str, **options):
    return tum.read(path, text, **options)


def write(path, streams):
    """One stream: the signature line, the column header, then TUM rows."""
    (s,) = streams
    path = Path(path)
    with path.open("w") as f:
        f.write(f"{SIGNATURE}\n{COLUMNS}\n")
        np.savetxt(f, pose_rows(s), fmt="%.9f")
    return [path]


def write_trajectory(path, timestamp_s, T_world_cam) -> Path:
    """simcalib's TUM trajectory file of poses ``T_world_cam`` ``(N, 4, 4)`` at
    ``timestamp_s`` ``(N,)`` (what a run writes per camera)."""
    t = np.asarray(timestamp_s, dtype=np.float64)
    T = np.asarray(T_world_cam, dtype=np.float64)
    if T.shape[0] != t.shape[0]:
        raise ValueError(f"{t.shape[0]} timestamps for {T.shape[0]} poses")
    return write(path, [PoseStreamData(t, T, str(path), NAME)])[0]


register_format(__name__)
