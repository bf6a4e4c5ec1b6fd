"""TUM RGB-D trajectory format: ``timestamp tx ty tz qx qy qz qw`` per line, whitespace
separated, ``#`` comments. simcalib's own TUM output (``reports.write_tum``: header
``# timestamp tx ty tz qx qy qz qw``) is the same layout; ``simcalib_tum`` is detected by
that header."""

from __future__ import annotations


from simcalib.importers import RawStream, numeric_rows

NAME = "tum"
DESCRIPTION = "TUM: 'timestamp tx ty tz qx qy qz qw', whitespace separated"
TWO_STREAMS = False

_SIMCALIB_HEADER = "# timestamp tx ty tz qx qy qz qw"


def _first_data_line(text: str) -> str:
    for line in text.splitlines():
        s = line.strip()
        if s and not s.startswith("#"):
            return s
    return ""


def sniff(path, text: str) -> float:
    line = _first_data_line(text)
    if not line or "," in line:
        return 0.0
    parts = line.split()
    if len(parts) != 8:
        return 0.0
    try:
        [float(p) for p in parts]
    except ValueError:
        return 0.0
    score = 0.8 + (0.1 if str(path).endswith((".tum", ".txt")) else 0.0)
    return score


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"tum reader takes no options; received {sorted(options)}")
    rows, _ = numeric_rows(text, None)
    if rows.shape[1] != 8:
        raise ValueError(f"{path}: TUM rows have 8 values (t tx ty tz qx qy qz qw); "
                         f"received {rows.shape[1]}")
    return [RawStream(rows[:, 0], position_m=rows[:, 1:4], quat_xyzw=rows[:, 4:8])]
