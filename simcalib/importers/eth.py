"""ETH hand_eye_calibration CSV: ``t, x, y, z, qx, qy, qz, qw`` per line, comma separated,
no header (seconds, metres, quaternion scalar-last)."""

from __future__ import annotations

import numpy as np

from simcalib.importers import (RawStream, first_data_line, is_pose_row, pose_rows,
                                 read_pose_rows, register_format)

NAME = "eth"
DESCRIPTION = "ETH hand_eye_calibration CSV: 't, x, y, z, qx, qy, qz, qw', no header"
TWO_STREAMS = False


def sniff(path, text: str) -> float:
    return 0.9 if is_pose_row(first_data_line(text), ",") else 0.0


def read(path, text: str, **options) -> list[RawStream]:
    return read_pose_rows(path, text, ",", "eth", "t, x, y, z, qx, qy, qz, qw", options)


def write(path, streams):
    """One stream as comma-separated rows, no header."""
    (s,) = streams
    np.savetxt(path, pose_rows(s), fmt="%.9f", delimiter=", ")
    return [path]


register_format(__name__)
