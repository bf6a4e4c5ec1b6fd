"""simcalib's own TUM output (``simcalib.report.results.write_tum``): the first line
:data:`SIGNATURE` (``# simcalib TUM trajectory``), then the column header
``# timestamp tx ty tz qx qy qz qw`` and TUM rows; poses are ``T_world_cam``.

Only a file that starts with the signature is labelled simcalib output: the column header
alone is the standard TUM header, which any tool (or ``numpy.savetxt``) may write, so such
a file (also one written by simcalib before the signature) is read as plain ``tum``."""

from __future__ import annotations

from simcalib.importers import tum, register_format

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


register_format(__name__)
