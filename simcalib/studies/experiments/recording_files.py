"""Generated recordings as files: TUM rows of each stream as its file holds it, and the
truth beside them (:func:`write_tum`, :func:`read_truth`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from simcalib.geometry import quat_from_matrix
from simcalib.importers import PoseStreamData
from simcalib.studies.experiments.recording_models import Recording

__all__ = ["write_tum", "read_truth"]


def _tum_rows(s: PoseStreamData) -> np.ndarray:
    T = s.T_world_sensor
    return np.column_stack([s.timestamps_s, T[:, :3, 3], quat_from_matrix(T[:, :3, :3])])


def write_tum(rec: Recording, folder) -> dict:
    """Write ``a.txt``, ``b.txt`` (TUM rows ``t x y z qx qy qz qw`` of the FILE form: an
    inverted or scalar-first file is written that way) and ``truth.json`` into ``folder``.
    Returns ``{"a": path, "b": path, "truth": path}``."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"a": out / "a.txt", "b": out / "b.txt", "truth": out / "truth.json"}
    for key, s in (("a", rec.stream_a), ("b", rec.stream_b)):
        np.savetxt(paths[key], _tum_rows(s), fmt="%.17g",
                   header=f"simcalib benchmark recording {rec.kind} seed {rec.seed}, "
                          f"stream {key}")
    paths["truth"].write_text(json.dumps(rec.truth_dict(), indent=2) + "\n")
    return paths


def read_truth(folder) -> dict:
    """The ``truth.json`` written by :func:`write_tum`."""
    return json.loads((Path(folder) / "truth.json").read_text())
