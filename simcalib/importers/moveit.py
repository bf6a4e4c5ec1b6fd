"""MoveIt Calibration sample files (YAML), two streams: ``effector_wrt_world`` and
``object_wrt_sensor``.

A list of samples (or ``{samples: [...]}``), each with ``effector_wrt_world`` and
``object_wrt_sensor`` as a 4x4 transform: 16 numbers row-major (flat list) or 4 rows of 4.
``effector_wrt_world`` is the pose of the effector in the robot base (``T_world_effector``);
``object_wrt_sensor`` the pose of the target in the camera (``T_sensor_object``, the inverse
of a sensor pose). Both are read as stored; :mod:`simcalib.estimation.readings` decides the reading.
The sample index is the time (synchronous pairs).
"""

from __future__ import annotations

import numpy as np

from simcalib.importers import RawStream, data_error, register_format

NAME = "moveit"
DESCRIPTION = "MoveIt calibration samples YAML (effector_wrt_world / object_wrt_sensor 4x4)"
TWO_STREAMS = True
_KEYS = ("effector_wrt_world", "object_wrt_sensor")


def _samples(doc):
    if isinstance(doc, dict) and "samples" in doc:
        doc = doc["samples"]
    if isinstance(doc, list) and doc and all(isinstance(s, dict) and all(k in s for k in _KEYS)
                                             for s in doc):
        return doc
    return None


def sniff(path, text: str) -> float:
    if _KEYS[0] not in text:
        return 0.0
    import yaml
    try:
        return 0.97 if _samples(yaml.safe_load(text)) else 0.0
    except Exception:  # noqa: BLE001
        return 0.0


def _matrix(v, where):
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise data_error(f"{where}: expected 16 numbers or 4 rows of 4; received "
                         f"{str(v)[:120]!r}") from None
    if a.size != 16:
        raise data_error(f"{where}: expected 16 numbers (4x4 row-major); received {a.size}")
    return a.reshape(4, 4)


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"moveit reader takes no options; received {sorted(options)}")
    import yaml
    samples = _samples(yaml.safe_load(text))
    if not samples:
        raise data_error(f"{path}: no MoveIt calibration samples (list of maps with "
                         f"{' and '.join(_KEYS)})")
    out = []
    for key in _KEYS:
        M = np.stack([_matrix(s[key], f"{path}, sample {i}, {key}")
                      for i, s in enumerate(samples)])
        out.append(RawStream(np.arange(len(samples), dtype=np.float64), matrices=M,
                             quat_order="matrix", name=key, synthetic_time=True,
                             note="MoveIt samples; sample index as time"))
    return out


def write(path, streams):
    """Two streams as MoveIt samples (``effector_wrt_world``, ``object_wrt_sensor``: 16
    numbers row-major each), paired by index."""
    import yaml
    a, b = streams
    if a.n != b.n:
        raise ValueError(f"MoveIt samples pair the streams by index; received {a.n} and "
                         f"{b.n} poses")
    doc = [{_KEYS[0]: np.asarray(A).reshape(-1).tolist(),
            _KEYS[1]: np.asarray(B).reshape(-1).tolist()}
           for A, B in zip(a.T_world_sensor, b.T_world_sensor)]
    path.write_text(yaml.safe_dump(doc))
    return [path]


register_format(__name__)
