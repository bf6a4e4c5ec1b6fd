"""ETH hand_eye_calibration CSV: ``t, x, y, z, qx, qy, qz, qw`` per line, comma separated,
no header (seconds, metres, quaternion scalar-last)."""

from __future__ import annotations

from simcalib.importers import RawStream, numeric_rows

NAME = "eth"
DESCRIPTION = "ETH hand_eye_calibration CSV: 't, x, y, z, qx, qy, qz, qw', no header"
TWO_STREAMS = False


def sniff(path, text: str) -> float:
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.split(",")
        if len(parts) != 8:
            return 0.0
        try:
            [float(p) for p in parts]
        except ValueError:
            return 0.0
        return 0.9
    return 0.0


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"eth reader takes no options; received {sorted(options)}")
    rows, _ = numeric_rows(text, ",")
    if rows.shape[1] != 8:
        raise ValueError(f"{path}: ETH rows have 8 values (t, x, y, z, qx, qy, qz, qw); "
                         f"received {rows.shape[1]}")
    return [RawStream(rows[:, 0], position_m=rows[:, 1:4], quat_xyzw=rows[:, 4:8])]
