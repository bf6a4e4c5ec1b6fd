"""Output directories: refuse what would silently overwrite an earlier run, before any work.

``check_output_dir(path, overwrite)`` is called by ``run`` (simcalib.pipeline.stages) and
``calibrate`` before anything is computed: an ``output=`` naming an existing file, or a
directory that already holds an earlier run's results (without ``overwrite=true``), is a
:class:`~simcalib.errors.UsageError` (exit 2) naming the path and what to do.
"""

from __future__ import annotations

import os
from pathlib import Path

from simcalib.errors import UsageError

__all__ = ["RESULT_FILES", "check_output_dir", "earlier_results"]

#: files whose presence marks a directory as holding an earlier run's results
#: (``run``: results.json, extrinsics.json; ``calibrate``: calibration.json)
RESULT_FILES = ("results.json", "extrinsics.json", "calibration.json")


def earlier_results(path: Path) -> list[str]:
    """The names of :data:`RESULT_FILES` present in directory ``path``."""
    return [name for name in RESULT_FILES if (path / name).exists()]


def check_output_dir(path, overwrite: bool = False) -> Path:
    """``path`` as a Path, checked: not an existing file, and not a directory holding an
    earlier run's results unless ``overwrite``. Creates nothing."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise UsageError(f"output={str(out)!r} is an existing file, not a directory; give "
                         "a directory (new, or one without earlier results)")
    base = out.absolute()
    while not base.exists():      # the nearest folder that exists must let us write
        base = base.parent
    if not base.is_dir() or not os.access(base, os.W_OK | os.X_OK):
        raise UsageError(f"output={str(out)!r} cannot be written: {str(base)!r} is "
                         f"{'a file' if not base.is_dir() else 'not writable'}; give a "
                         "writable directory")
    found = earlier_results(out) if out.is_dir() else []
    if found and not overwrite:
        raise UsageError(f"output={str(out)!r} already holds an earlier run's results "
                         f"({', '.join(found)}); give another directory, or overwrite=true "
                         "to replace them")
    return out
