"""simcalib's own TUM output (``simcalib.reports.write_tum``): TUM rows under the header
``# timestamp tx ty tz qx qy qz qw``; poses are ``T_world_cam``."""

from __future__ import annotations

from simcalib.importers import tum

NAME = "simcalib_tum"
DESCRIPTION = "simcalib TUM output: header '# timestamp tx ty tz qx qy qz qw' + TUM rows"
TWO_STREAMS = False


def sniff(path, text: str) -> float:
    first = text.lstrip().splitlines()[0].strip() if text.strip() else ""
    if first != tum._SIMCALIB_HEADER:
        return 0.0
    return 0.95 if tum.sniff(path, text) > 0 else 0.0


def read(path, text: str, **options):
    return tum.read(path, text, **options)
