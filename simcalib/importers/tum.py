"""TUM RGB-D trajectory format: ``timestamp tx ty tz qx qy qz qw`` per line, whitespace
separated, ``#`` comments. simcalib's own TUM output (``reports.write_tum``: header
``# timestamp tx ty tz qx qy qz qw``) is the same layout; ``simcalib_tum`` is detected by
that header."""

from __future__ import annotations

import numpy as np

from simcalib.importers import (RawStream, first_data_line, is_pose_row, pose_rows,
                                 read_pose_rows, register_format)

NAME = "tum"
DESCRIPTION = "TUM: 'timestamp tx ty tz qx qy qz qw', whitespace separated"
TWO_STREAMS = False

_SIMCALIB_HEADER = "# timestamp tx ty tz qx qy qz qw"


def sniff(path, text: str) -> float:
    line = first_data_line(text)
    if not line or "," in line or not is_pose_row(line, None):
        return 0.0
    return 0.8 + (0.1 if str(path).endswith((".tum", ".txt")) else 0.0)


def read(path, text: str, **options) -> list[RawStream]:
    return read_pose_rows(path, text, None, "tum", "t tx ty tz qx qy qz qw", options)


def write(path, streams):
    """One stream as TUM rows (no header)."""
    (s,) = streams
    np.savetxt(path, pose_rows(s), fmt="%.9f")
    return [path]


register_format(__name__)
