"""A kind and a seed -> a :class:`~simcalib.studies.experiments.recording_models.Recording`
(:func:`generate`): the kind's draft put in its files' form (inverted, scalar first,
stamps in their unit); and both streams read the true way (:func:`true_streams`).
"""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np

from simcalib.geometry import (invert_transform, matrix_from_quat, quat_from_matrix,
                               transform_from_rotation_translation)
from simcalib.importers import PoseStreamData, stream_from_arrays
from simcalib.importers._stamps import UNIT_FACTORS
from simcalib.studies.experiments.recording_kinds.catalogue import KINDS
from simcalib.studies.experiments.recording_models import Recording, Settings, _rngs

__all__ = ["generate", "true_streams"]


def _file_stream(t, T, invert: bool, scalar_first: bool, name: str,
                 unit: str = "s") -> PoseStreamData:
    """The stream as a file holds it: ``T_sensor_world`` when ``invert``; with
    ``scalar_first`` the quaternion numbers ``(w, x, y, z)`` in the places a TUM reader
    takes for ``(x, y, z, w)``; the stamps ``t`` (s) written in ``unit``."""
    if invert:
        T = invert_transform(T)
    if scalar_first:
        q = quat_from_matrix(T[:, :3, :3])
        T = transform_from_rotation_translation(
            matrix_from_quat(np.concatenate([q[:, 3:], q[:, :3]], axis=1)), T[:, :3, 3])
    if unit != "s":         # the numbers a file in that unit holds, read as they are
        return stream_from_arrays(t * UNIT_FACTORS[unit], T, source=f"<{name}>", name=name,
                                  quat_order="xyzw", stamps_unit="pair")
    return stream_from_arrays(t, T, source=f"<{name}>", name=name, quat_order="xyzw")


def _frozen(a) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a


def generate(kind: str, seed: int, **overrides) -> Recording:
    """The recording of ``kind`` for ``seed`` (``overrides``: fields of :class:`Settings`).
    Unknown kinds or override keys raise ValueError listing the valid ones."""
    if kind not in KINDS:
        raise ValueError(f"unknown recording kind {kind!r}; valid kinds: {', '.join(KINDS)}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer; received {seed!r}")
    spec = KINDS[kind]
    valid = [f.name for f in fields(Settings)]
    bad = sorted(set(overrides) - set(valid))
    if bad:
        raise ValueError(f"unknown override(s) {', '.join(bad)}; valid: {', '.join(valid)}")
    unused = sorted(set(overrides) - set(spec.settings))
    if unused:
        raise ValueError(f"kind {kind!r} does not use {', '.join(unused)}; its settings: "
                         f"{', '.join(spec.settings)}")
    d = spec.make(_rngs(int(seed), kind), Settings(**{**spec.defaults, **overrides}))
    na, nb = d.t_a.size, d.t_b.size
    oa = d.outliers_a if d.outliers_a is not None else np.zeros(na, dtype=bool)
    ob = d.outliers_b if d.outliers_b is not None else np.zeros(nb, dtype=bool)
    return Recording(
        kind=kind, seed=int(seed),
        stream_a=_file_stream(d.t_a, d.A, d.invert_a, d.scalar_first_a, "a", d.stamps_unit_a),
        stream_b=_file_stream(d.t_b, d.B, d.invert_b, d.scalar_first_b, "b", d.stamps_unit_b),
        X_true=_frozen(d.X), offset_s=float(d.offset_s), drift=float(d.drift),
        t_ref_s=float(d.t_ref_s), invert_a=d.invert_a, invert_b=d.invert_b,
        scalar_first_a=d.scalar_first_a, scalar_first_b=d.scalar_first_b,
        outliers_a=_frozen(oa), outliers_b=_frozen(ob), description=d.description,
        offset_determined=spec.offset_determined, expect=spec.expect,
        undetermined_a=None if d.undetermined_a is None else _frozen(_unit_rows(
            d.undetermined_a)),
        X_workspace=None if d.X_workspace is None else _frozen(d.X_workspace),
        accuracy_a=d.accuracy_a, stamps_unit_a=d.stamps_unit_a, stamps_unit_b=d.stamps_unit_b,
        scale_b=float(d.scale_b),
        X_before_change=None if d.X_before_change is None else _frozen(d.X_before_change),
        change_row=d.change_row, step_s=float(d.step_s), step_at_s=d.step_at_s)


def _unit_rows(u) -> np.ndarray:
    """Directions ``(k, 3)`` as unit rows (one direction ``(3,)`` -> ``(1, 3)``)."""
    u = np.atleast_2d(np.asarray(u, dtype=np.float64))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def true_streams(rec: Recording) -> tuple[PoseStreamData, PoseStreamData]:
    """Both streams read the TRUE way (``T_world_sensor``, quaternion order fixed, stamps in
    seconds, b's translations in a's scale), in the order simcalib.estimation.readings
    applies a reading (swap, then invert)."""
    out = []
    for s, inv, sf, unit in ((rec.stream_a, rec.invert_a, rec.scalar_first_a, rec.stamps_unit_a),
                             (rec.stream_b, rec.invert_b, rec.scalar_first_b, rec.stamps_unit_b)):
        if unit != "s":
            s = replace(s, timestamps_s=np.asarray(s.timestamps_s) / UNIT_FACTORS[unit])
        if sf:
            s = s.with_swapped_scalar()
        if inv:
            s = s.with_inverse()
        out.append(s)
    if rec.scale_b != 1.0:
        T = np.array(out[1].T_world_sensor)
        T[:, :3, 3] /= rec.scale_b
        out[1] = replace(out[1], T_world_sensor=T)
    return out[0], out[1]
