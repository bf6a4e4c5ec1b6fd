"""easy_handeye sample files (YAML), two streams: ``robot`` and ``tracking``.

Accepted layouts (the sample lists saved by easy_handeye / easy_handeye2):

* a list of samples (or ``{samples: [...]}``), each ``{robot: TF, tracking: TF}``;
* ``{hand_world_samples: [TF...], camera_marker_samples: [TF...]}`` (easy_handeye 1
  ``SampleList``), read as ``robot`` and ``tracking``;

where ``TF`` is ``{translation: {x, y, z}, rotation: {x, y, z, w}}`` (optionally wrapped in
``transform:``). ``robot`` holds the robot base -> effector lookup (pose of the effector in
the base), ``tracking`` the tracking base -> marker lookup (pose of the marker in the tracker,
the inverse of the sensor pose for an eye-in-hand camera): both are read as stored, and
:mod:`simcalib.estimation.readings` decides from the data which reading makes the pair consistent.
Samples carry no usable timestamps: the sample index is the time (synchronous pairs).
"""

from __future__ import annotations

import numpy as np

from simcalib.importers import RawStream, data_error, register_format

NAME = "easy_handeye"
DESCRIPTION = "easy_handeye YAML samples (robot / tracking transforms)"
TWO_STREAMS = True


def _load(text):
    import yaml
    return yaml.safe_load(text)


def _samples(doc):
    if isinstance(doc, dict) and "hand_world_samples" in doc and "camera_marker_samples" in doc:
        return list(zip(doc["hand_world_samples"], doc["camera_marker_samples"])), "v1"
    if isinstance(doc, dict) and "samples" in doc:
        doc = doc["samples"]
    if isinstance(doc, list) and doc and all(isinstance(s, dict) and "robot" in s
                                             and "tracking" in s for s in doc):
        return [(s["robot"], s["tracking"]) for s in doc], "v2"
    return None, None


def sniff(path, text: str) -> float:
    if "translation" not in text or "rotation" not in text:
        return 0.0
    try:
        pairs, _ = _samples(_load(text))
    except Exception:  # noqa: BLE001
        return 0.0
    return 0.95 if pairs else 0.0


def _tf(d, where):
    if isinstance(d, dict) and "transform" in d:
        d = d["transform"]
    try:
        tr, rot = d["translation"], d["rotation"]
        return ([float(tr[k]) for k in "xyz"], [float(rot[k]) for k in "xyzw"])
    except (KeyError, TypeError, ValueError):
        raise data_error(f"{where}: expected {{translation: {{x, y, z}}, rotation: "
                         f"{{x, y, z, w}}}}; received {str(d)[:120]!r}") from None


def read(path, text: str, **options) -> list[RawStream]:
    if options:
        raise TypeError(f"easy_handeye reader takes no options; received {sorted(options)}")
    pairs, layout = _samples(_load(text))
    if not pairs:
        raise data_error(f"{path}: no easy_handeye samples (list of {{robot, tracking}} or "
                         "hand_world_samples / camera_marker_samples)")
    out = []
    for k, name in enumerate(("robot", "tracking")):
        vals = [_tf(p[k], f"{path}, sample {i}, {name}") for i, p in enumerate(pairs)]
        P = np.array([v[0] for v in vals])
        Q = np.array([v[1] for v in vals])
        out.append(RawStream(np.arange(len(vals), dtype=np.float64), position_m=P,
                             quat_xyzw=Q, name=name, synthetic_time=True,
                             note=f"easy_handeye {layout} samples; sample index as time"))
    return out


def write(path, streams):
    """Two streams as easy_handeye2 samples ``[{robot: TF, tracking: TF}, ...]`` (paired
    by index: the samples carry no time)."""
    import yaml
    from simcalib.geometry import quat_from_matrix
    robot, tracking = streams
    if robot.n != tracking.n:
        raise ValueError(f"easy_handeye samples pair the streams by index; received "
                         f"{robot.n} and {tracking.n} poses")

    def tf(T):
        q = quat_from_matrix(T[:3, :3])
        return {"translation": dict(zip("xyz", map(float, T[:3, 3]))),
                "rotation": dict(zip("xyzw", map(float, q)))}
    doc = [{"robot": tf(a), "tracking": tf(b)}
           for a, b in zip(robot.T_world_sensor, tracking.T_world_sensor)]
    path.write_text(yaml.safe_dump(doc))
    return [path]


register_format(__name__)
