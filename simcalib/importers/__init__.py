"""Reading pose streams from files: a registry of formats, one module per format.

    from simcalib.importers import read_pose_stream, read_pose_streams, available
    s = read_pose_stream("hand.csv")                 # format detected, message in s.detection
    s = read_pose_stream("cam.txt", format="tum")    # or named explicitly
    a, b = read_pose_streams("samples.yaml")         # two-stream formats (easy_handeye, moveit)

Every stream is a :class:`PoseStreamData`: timestamps (s), ``T_world_sensor`` (N, 4, 4) as the
file states it (whether the file really holds ``T_world_sensor`` or its inverse, and whether a
quaternion was scalar-first, is decided from the data by :mod:`simcalib.estimation.readings`), the
source file, the format and the repairs made (counted, named).

Formats (``available()``, the registry :data:`FORMATS`): ``tum``, ``simcalib_tum``
(simcalib's own TUM output), ``eth``, ``csv``, ``easy_handeye``, ``moveit``, ``kitti``, ... A
format module defines ``NAME``, ``DESCRIPTION``, ``TWO_STREAMS`` (bool), ``sniff(path,
text) -> float`` (0..1 confidence), ``read(path, text, **options) -> list[RawStream]`` and
``write(path, streams) -> list[Path]`` (the streams in that format: what a user of the
format would hand us; the registry test writes every format, detects and reads it back),
and ends with ``register_format(__name__)``; the registry imports every module of this
folder on its first lookup, so a new format file needs no import list.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from simcalib.errors import DataError, unknown_choice
from simcalib.geometry import (invert_transform, matrix_from_quat, quat_from_matrix,
                               transform_from_rotation_translation)
from simcalib.registry import Registry
from simcalib.importers._stamps import longest_recording as _longest_recording
from simcalib.importers._stamps import stamps_in_seconds as _stamps_in_seconds

__all__ = ["PoseStreamData", "RawStream", "data_error", "available", "read_pose_stream",
           "read_pose_streams", "detect_format", "stream_from_arrays", "MIN_POSES", "FORMATS",
           "register_format", "write_pose_streams"]

MIN_POSES = 3


def _check_format(name: str, module) -> None:
    missing = [a for a in ("NAME", "DESCRIPTION", "TWO_STREAMS", "sniff", "read", "write")
               if not hasattr(module, a)]
    if missing or not all(callable(getattr(module, f)) for f in ("sniff", "read", "write")):
        raise TypeError(f"a pose-file format module needs NAME, DESCRIPTION, TWO_STREAMS, "
                        f"sniff(), read() and write(); {getattr(module, '__name__', module)!r} "
                        f"lacks {missing or ['callable sniff/read/write']}")


#: name -> format module (info: ``description``, ``two_streams``).
FORMATS = Registry("pose-file format", key="format", package="simcalib.importers",
                   check=_check_format)


def data_error(message: str) -> DataError:
    """The error for a bad pose file: :class:`simcalib.errors.DataError` (a ``ValueError``;
    exit code 3 on the command line)."""
    return DataError(message)


@dataclass(frozen=True)
class RawStream:
    """What a format reader returns before validation: timestamps and either positions +
    quaternions ``(x, y, z, w)`` (already reordered from the file's column order) or 4x4
    matrices. ``quat_order`` records the order in the file (``xyzw``, ``wxyz``) or
    ``matrix``; ``name`` labels the stream inside a two-stream file."""
    timestamps_s: np.ndarray
    position_m: np.ndarray | None = None
    quat_xyzw: np.ndarray | None = None
    matrices: np.ndarray | None = None
    quat_order: str = "xyzw"
    name: str = ""
    note: str = ""
    synthetic_time: bool = False
    #: repairs the reader made (e.g. ``{"truncated_last_row_dropped": 1}``), counted
    repairs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class PoseStreamData:
    """One pose stream read from a file.

    ``timestamps_s`` (N,) strictly increasing; ``T_world_sensor`` (N, 4, 4) rigid, as read
    (see :mod:`simcalib.estimation.readings` for the reading actually used); ``source`` the file;
    ``format`` the format name; ``detection`` how the format was chosen; ``repairs`` maps a
    repair name to its count (e.g. ``{"duplicate_rows_dropped": 3}``); ``quat_order`` the
    file's quaternion order (``xyzw``/``wxyz``) or ``matrix``; ``name`` the stream label;
    ``inverted``/``scalar_first_reinterpreted`` record convention changes applied since
    reading; ``synthetic_time``: the file had no timestamps (sample index used as time);
    ``stamps_unit``: the unit the file's stamps were told to be in (``s``, ``ms``, ``us``,
    ``ns``: given, unix time, or told with the other stream by
    :mod:`simcalib.estimation.stamp_units`), ``""`` while read as seconds untold;
    ``world_jumps_s``: the stamps (own clock) where the stream's world frame jumps
    (:mod:`simcalib.estimation.world_jumps`): each stretch between them is its own world;
    empty: one world.
    """
    timestamps_s: np.ndarray
    T_world_sensor: np.ndarray
    source: str
    format: str
    detection: str = ""
    repairs: dict = field(default_factory=dict)
    quat_order: str = "xyzw"
    name: str = ""
    inverted: bool = False
    scalar_first_reinterpreted: bool = False
    synthetic_time: bool = False
    stamps_unit: str = ""
    world_jumps_s: tuple = ()

    def __len__(self) -> int:
        return int(self.timestamps_s.shape[0])

    @property
    def n(self) -> int:
        return len(self)

    @property
    def duration_s(self) -> float:
        return float(self.timestamps_s[-1] - self.timestamps_s[0])

    @property
    def rate_hz(self) -> float:
        """Median sampling rate."""
        dt = np.diff(self.timestamps_s)
        return float(1.0 / np.median(dt)) if dt.size else float("nan")

    def with_inverse(self) -> "PoseStreamData":
        """The same stream read as the inverse poses (``T_sensor_world`` <-> ``T_world_sensor``)."""
        return replace(self, T_world_sensor=invert_transform(self.T_world_sensor),
                       inverted=not self.inverted)

    def with_swapped_scalar(self) -> "PoseStreamData":
        """The same stream with the file's quaternions read in the other order
        (scalar-first <-> scalar-last). Only for quaternion formats."""
        if self.quat_order == "matrix":
            raise ValueError(f"stream {self.name or self.source!r} was read from 4x4 matrices; "
                             "it has no quaternion order to swap")
        T = invert_transform(self.T_world_sensor) if self.inverted else self.T_world_sensor
        q = quat_from_matrix(T[:, :3, :3])          # = +-(file's 4 numbers) in xyzw reading
        q_other = np.concatenate([q[:, 1:], q[:, :1]], axis=1)
        T2 = transform_from_rotation_translation(matrix_from_quat(q_other), T[:, :3, 3])
        if self.inverted:
            T2 = invert_transform(T2)
        return replace(self, T_world_sensor=T2,
                       scalar_first_reinterpreted=not self.scalar_first_reinterpreted)

    def describe(self) -> str:
        rep = ", ".join(f"{k}: {v}" for k, v in self.repairs.items() if v) or "none"
        label = f" [{self.name}]" if self.name else ""
        return (f"{self.source}{label}: {self.n} poses over {self.duration_s:.3f} s "
                f"(~{self.rate_hz:.1f} Hz), format {self.format} ({self.detection}); "
                f"repairs: {rep}")


# --------------------------------------------------------------------------- registry
def register_format(module_name: str):
    """Register the (imported) format module ``module_name`` under its ``NAME``."""
    module = sys.modules[module_name]
    _check_format("", module)
    return FORMATS.register(module.NAME, module, description=module.DESCRIPTION,
                            two_streams=bool(module.TWO_STREAMS))


def available() -> list[str]:
    """Names of the registered formats, sorted."""
    return sorted(FORMATS.names())


def _module(name: str):
    if not isinstance(name, str) or name not in FORMATS:
        raise unknown_choice("pose-file format", name, available(), key="format")
    return FORMATS.get(name)


def _read_text(path) -> tuple[Path, str]:
    p = Path(path)
    if not p.is_file():
        raise data_error(f"pose file {str(path)!r} does not exist or is not a file")
    try:
        text = p.read_text(encoding="utf-8-sig", errors="strict")   # a byte-order mark is dropped
    except UnicodeDecodeError:
        raise data_error(f"pose file {str(p)!r} is not UTF-8 text; pose files are text "
                         f"(formats: {', '.join(available())})") from None
    if not text.strip():
        raise data_error(f"pose file {str(p)!r} is empty")
    lines = text.strip().splitlines()
    if all(not ln.strip() or ln.lstrip().startswith(("#", "%", "//")) for ln in lines):
        raise data_error(f"pose file {str(p)!r} holds no pose rows: its {len(lines)} lines are "
                         "comments or blank")
    return p, text


def detect_format(path, text: str | None = None) -> tuple[str, str]:
    """``(format name, message)``: the most confident sniffer wins; the message names the
    detected format and the runner-up."""
    p = Path(path)
    if text is None:
        p, text = _read_text(p)
    scores = []
    for name in available():
        try:
            s = float(_module(name).sniff(p, text))
        except Exception:  # noqa: BLE001 - a sniffer that chokes simply does not match
            s = 0.0
        scores.append((s, name))
    scores.sort(key=lambda x: (-x[0], x[1]))       # ties: by name, whatever the load order
    best_s, best = scores[0]
    if best_s <= 0:
        first = text.strip().splitlines()[0][:120]
        raise data_error(f"could not detect the format of {str(p)!r} (first line: {first!r}); "
                         f"name it explicitly, one of: {', '.join(available())}")
    runner = scores[1]
    msg = (f"detected format {best!r} ({_module(best).DESCRIPTION}; confidence {best_s:.2f}"
           + (f", next {runner[1]!r} {runner[0]:.2f}" if runner[0] > 0 else "") + ")")
    return best, msg


def write_pose_streams(path, streams, format: str) -> list[Path]:
    """Write ``streams`` (:class:`PoseStreamData`; two for a two-stream format) to ``path``
    in ``format``; returns the files written (a format may write a companion file, e.g.
    KITTI's stamps)."""
    module = _module(format)
    streams = list(streams)
    want = 2 if module.TWO_STREAMS else 1
    if len(streams) != want:
        raise ValueError(f"format {format!r} holds {want} stream(s); received {len(streams)}")
    return [Path(p) for p in module.write(Path(path), streams)]


def read_pose_streams(path, format: str | None = None, *, stamps_unit: str = "auto",
                      recording: int | None = None, **options) -> list[PoseStreamData]:
    """All streams of a file (one for single-stream formats, two for easy_handeye / moveit).

    ``format``: a name from :func:`available`, or None to detect it. ``stamps_unit``: how
    the stamps' unit is read (:mod:`simcalib.importers._stamps`: ``auto``, ``pair``, or the
    unit). ``recording``: of a file holding several recordings (stamps that restart), the
    one of that number (from 1), else the longest. ``options`` go to the format reader
    (e.g. ``columns=`` for csv). Raises the project's DataError (ValueError) on bad input
    that cannot be repaired.
    """
    p, text = _read_text(path)
    if format is None:
        format, detection = detect_format(p, text)
    else:
        _module(format)
        detection = f"format {format!r} named explicitly"
    raws = _module(format).read(p, text, **options)
    return [_finalise(r, str(p), format, detection, stamps_unit, recording) for r in raws]


def read_pose_stream(path, format: str | None = None, stream: str | int | None = None,
                     *, stamps_unit: str = "auto", recording: int | None = None,
                     **options) -> PoseStreamData:
    """One stream of a file. For two-stream formats ``stream`` picks it by name or index
    (required there); ``stamps_unit`` and ``recording`` as for :func:`read_pose_streams`."""
    streams = read_pose_streams(path, format, stamps_unit=stamps_unit, recording=recording,
                                **options)
    if len(streams) == 1 and stream in (None, 0, streams[0].name):
        return streams[0]
    names = [s.name for s in streams]
    if stream is None:
        raise data_error(f"{str(path)!r} holds {len(streams)} streams ({', '.join(names)}); "
                         "pick one with stream=NAME or an index")
    if isinstance(stream, (int, np.integer)) and not isinstance(stream, bool):
        if 0 <= stream < len(streams):
            return streams[int(stream)]
    elif stream in names:
        return streams[names.index(stream)]
    raise data_error(f"stream {stream!r} not in {str(path)!r}; allowed: {', '.join(names)} "
                     f"or 0..{len(streams) - 1}")


def stream_from_arrays(timestamps_s, T_world_sensor, *, source: str = "<memory>",
                       name: str = "", quat_order: str = "xyzw",
                       stamps_unit: str = "auto") -> PoseStreamData:
    """A validated :class:`PoseStreamData` from arrays (same checks and repairs as files;
    ``stamps_unit`` as for :func:`read_pose_streams`)."""
    T = np.asarray(T_world_sensor, dtype=np.float64)
    t = np.asarray(timestamps_s, dtype=np.float64)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise ValueError(f"T_world_sensor must have shape (N, 4, 4); received {T.shape}")
    if t.shape != (T.shape[0],):
        raise ValueError(f"timestamps_s must have shape ({T.shape[0]},); received {t.shape}")
    raw = RawStream(t, matrices=T, quat_order="matrix", name=name)
    s = _finalise(raw, source, "arrays", "given as arrays", stamps_unit)
    return replace(s, quat_order=quat_order)


# ------------------------------------------------------------------- validation/repair
QUAT_NORM_TOL = 1e-3      # beyond this deviation from 1 a quaternion is renormalised (counted)
#: a position coordinate beyond this (m) is a corrupt row, dropped as a repair (no rig is
#: 1e9 m from its origin: 2.6x the Moon's distance)
MAX_POSITION_M = 1e9
QUAT_NORM_MAX_DEV = 0.2   # beyond this it is not a unit quaternion at all: error


def _finalise(raw: RawStream, source: str, fmt: str, detection: str,
              stamps_unit: str = "auto", recording: int | None = None) -> PoseStreamData:
    """The validated :class:`PoseStreamData` of ``raw``: rows with NaN/inf dropped,
    quaternions renormalised or rotation blocks re-orthonormalised when slightly off,
    sorted by time, duplicates dropped — each repair counted in ``repairs``."""
    label = f"{source}" + (f" [{raw.name}]" if raw.name else "")
    repairs: dict[str, int] = dict(raw.repairs)
    t, T = _finite_poses(raw, label, repairs)
    t, T = _ordered_unique(t, T, repairs, recording)
    if t.size < MIN_POSES:
        hint = ("; rows sharing a stamp hold different poses that no neighbouring stamp "
                "tells apart: are the stamps written too coarsely?"
                if repairs.get("duplicate_timestamps_dropped_ambiguous") else "")
        raise data_error(f"{label}: {t.size} usable poses after repairs "
                         f"({', '.join(f'{k}: {v}' for k, v in repairs.items()) or 'none'}); "
                         f"at least {MIN_POSES} are needed{hint}")
    t, unit_note, unit = _stamps_in_seconds(t, label, repairs, stamps_unit)
    t.setflags(write=False)
    T.setflags(write=False)
    return PoseStreamData(timestamps_s=t, T_world_sensor=T, source=source, format=fmt,
                          detection=detection + "".join(f"; {n}" for n in (raw.note, unit_note)
                                                        if n),
                          repairs=repairs, quat_order=raw.quat_order, name=raw.name,
                          synthetic_time=raw.synthetic_time, stamps_unit=unit)


def _finite_poses(raw: RawStream, label: str, repairs: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(t (N,), T (N, 4, 4))`` of the rows of ``raw`` without NaN/inf, as rigid transforms
    (quaternions checked and renormalised, matrices checked by :func:`_project_rigid`)."""
    t = np.asarray(raw.timestamps_s, dtype=np.float64).reshape(-1)
    n0 = t.shape[0]
    if raw.matrices is not None:
        M = np.asarray(raw.matrices, dtype=np.float64)
        finite = np.isfinite(M).all(axis=(1, 2)) & np.isfinite(t)
    else:
        pos = np.asarray(raw.position_m, dtype=np.float64)
        q = np.asarray(raw.quat_xyzw, dtype=np.float64)
        finite = np.isfinite(pos).all(1) & np.isfinite(q).all(1) & np.isfinite(t)
    n_bad = int((~finite).sum())
    if n_bad:
        repairs["nan_rows_dropped"] = n_bad
        if n_bad == n0:
            raise data_error(f"{label}: all {n0} rows contain NaN or inf")
    trans = M[:, :3, 3] if raw.matrices is not None else pos
    far = finite & ~(np.abs(np.where(finite[:, None], trans, 0.0)) <= MAX_POSITION_M).all(1)
    if far.any():   # no rig is that far: a corrupt row (and 1e300 m would overflow the math)
        repairs["far_rows_dropped"] = int(far.sum())
        finite = finite & ~far
        if not finite.any():
            raise data_error(f"{label}: every row's position is beyond {MAX_POSITION_M:g} m")
    keep = finite
    if raw.matrices is not None:
        t, M = t[keep], M[keep]
        return t, _project_rigid(M, label, repairs)
    zero = finite & ~q.any(axis=1)      # (0, 0, 0, 0): a tracker's "no pose" row
    if zero.any():
        repairs["zero_quaternion_rows_dropped"] = int(zero.sum())
        keep = finite = finite & ~zero
        if not finite.any():
            raise data_error(f"{label}: every row's quaternion is (0, 0, 0, 0) or NaN")
    norm = np.linalg.norm(np.where(finite[:, None], q, [0.0, 0.0, 0.0, 1.0]), axis=1)
    far = np.abs(norm - 1.0) > QUAT_NORM_MAX_DEV
    if far.any():
        k = int(np.argmax(far))
        raise data_error(
            f"{label}: row {k} has quaternion {q[k].tolist()} of norm {norm[k]:.4g}; "
            f"unit quaternions (|q| within {QUAT_NORM_MAX_DEV} of 1) are required - "
            "wrong columns or quaternion order?")
    renorm = finite & (np.abs(norm - 1.0) > QUAT_NORM_TOL)
    if renorm.any():
        repairs["quaternions_renormalised"] = int(renorm.sum())
    t, pos, q = t[keep], pos[keep], q[keep]
    return t, transform_from_rotation_translation(matrix_from_quat(q), pos)


def _ordered_unique(t: np.ndarray, T: np.ndarray, repairs: dict,
                    recording: int | None = None) -> tuple:
    """``(t, T)`` sorted by time (stable) and without repeated timestamps. Repeated rows of
    one pose keep one (``duplicate_rows_dropped``); rows of one stamp with different poses
    keep the one consistent with the neighbouring stamps (:func:`_consistent_rows`;
    ``duplicate_timestamps_kept_consistent``), or none of them when that cannot be told
    (``duplicate_timestamps_dropped_ambiguous``): a re-published stale pose may come first
    or last. Stamps that restart (:func:`~simcalib.importers._stamps.longest_recording`) are
    not sorted together (``recording``: which one is kept)."""
    t, T = _longest_recording(t, T, repairs, recording)
    if t.size >= 2 and np.any(np.diff(t) < 0):
        order = np.argsort(t, kind="stable")
        repairs["out_of_order_rows_sorted"] = int(np.sum(order != np.arange(t.size)))
        t, T = t[order], T[order]
    if t.size < 2 or not np.any(np.diff(t) == 0):
        return t, T
    same = np.zeros(t.size, dtype=bool)          # the same stamp and pose as the row before
    same[1:] = (np.diff(t) == 0) & (np.abs(T[1:] - T[:-1]).max(axis=(1, 2)) < 1e-9)
    if same.any():
        repairs["duplicate_rows_dropped"] = int(same.sum())
        t, T = t[~same], T[~same]
    keep, n_kept, n_dropped = _consistent_rows(t, T)
    if n_kept:
        repairs["duplicate_timestamps_kept_consistent"] = n_kept
    if n_dropped:
        repairs["duplicate_timestamps_dropped_ambiguous"] = n_dropped
    return t[keep], T[keep]


def _consistent_rows(t: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, int, int]:
    """``(keep mask, rows dropped from stamps kept, rows of stamps dropped)`` for rows
    sharing a stamp (``t`` sorted) with different poses. A row repeating a neighbouring
    stamp's pose is a copy of it (a stale pose re-published, a frame stamped late); of the
    others the one nearest the pose interpolated between the neighbouring stamps' (one
    neighbour's at an end; distances in the stream's median step of rotation plus
    translation) is kept. When no neighbouring stamp holds a single row to compare with
    (every stamp repeated: stamps written too coarsely), the stamp is dropped."""
    start = np.concatenate([[True], np.diff(t) > 0])
    first = np.flatnonzero(start)
    size = np.diff(np.append(first, t.size))
    keep = np.ones(t.size, dtype=bool)
    if first.size == t.size:
        return keep, 0, 0
    scale = _step_scale(T[first])
    n_kept = n_dropped = 0
    for g in np.flatnonzero(size > 1):
        rows = np.arange(first[g], first[g] + size[g])
        nbg = [k for k in (g - 1, g + 1) if 0 <= k < first.size]
        nb_rows = np.concatenate([np.arange(first[k], first[k] + size[k]) for k in nbg]) \
            if nbg else np.zeros(0, dtype=np.int64)
        copy = np.array([np.abs(T[nb_rows] - T[r]).max(axis=(1, 2)).min() < 1e-9
                         if nb_rows.size else False for r in rows])
        cand = rows[~copy] if (~copy).any() else rows
        keep[rows] = False
        if cand.size == 1:
            keep[cand[0]] = True
            n_kept += rows.size - 1
            continue
        single = [first[k] for k in nbg if size[k] == 1]
        if single:
            keep[cand[int(np.argmin(_off_neighbours(t, T, single, cand, scale)))]] = True
            n_kept += rows.size - 1
        else:
            n_dropped += rows.size
    return keep, n_kept, n_dropped


def _step_scale(Tu: np.ndarray) -> tuple[float, float]:
    """The median rotation (rad) and translation (m) between consecutive poses."""
    from simcalib.geometry import rotation_angle_rad
    if Tu.shape[0] < 2:
        return 1.0, 1.0
    r = np.median(rotation_angle_rad(np.swapaxes(Tu[:-1, :3, :3], 1, 2) @ Tu[1:, :3, :3]))
    p = np.median(np.linalg.norm(np.diff(Tu[:, :3, 3], axis=0), axis=1))
    return max(float(r), 1e-12), max(float(p), 1e-12)


def _off_neighbours(t, T, single, cand, scale) -> np.ndarray:
    """How far each candidate row lies from the pose interpolated at its stamp between the
    neighbouring rows ``single``, in median steps (rotation plus translation)."""
    from simcalib.geometry import rotation_angle_rad
    R_ref, p_ref = _between(t, T, single, t[cand[0]])
    d_r = rotation_angle_rad(np.swapaxes(T[cand, :3, :3], 1, 2) @ R_ref)
    d_p = np.linalg.norm(T[cand, :3, 3] - p_ref, axis=1)
    return d_r / scale[0] + d_p / scale[1]


def _between(t, T, rows, t_q):
    """``(R, p)``: the pose at ``t_q`` interpolated between the rows ``rows`` (one or two,
    around ``t_q``): the chordal mean of the rotations weighted by nearness, linear
    translation."""
    if len(rows) == 1:
        return T[rows[0], :3, :3], T[rows[0], :3, 3]
    i, j = rows
    w = (t_q - t[i]) / (t[j] - t[i])
    M = (1.0 - w) * T[i, :3, :3] + w * T[j, :3, :3]
    U, _, Vt = np.linalg.svd(M)
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    return R, (1.0 - w) * T[i, :3, 3] + w * T[j, :3, 3]


def _project_rigid(M: np.ndarray, label: str, repairs: dict) -> np.ndarray:
    """Check 4x4 rows: bottom row (0,0,0,1); rotation blocks re-orthonormalised (SVD) when
    slightly off (counted), error when far off."""
    bottom_ok = np.abs(M[:, 3, :] - np.array([0, 0, 0, 1.0])).max(axis=1) < 1e-6
    if not bottom_ok.all():
        k = int(np.argmax(~bottom_ok))
        raise data_error(f"{label}: matrix {k} has bottom row {M[k, 3].tolist()}; "
                         "rigid transforms end in (0, 0, 0, 1) - is the matrix row-major 4x4?")
    R = M[:, :3, :3]
    err = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(R)
    far = (err > 0.05) | (det < 0)
    if far.any():
        k = int(np.argmax(far))
        raise data_error(f"{label}: matrix {k} is not a rotation (|R^T R - I| = {err[k]:.3g}, "
                         f"det = {det[k]:.3g}); is the matrix transposed or not row-major?")
    off = err > 1e-9
    T = M.copy()
    if off.any():
        U, _, Vt = np.linalg.svd(R[off])
        T[off, :3, :3] = U @ Vt
        if (err > 1e-6).any():
            repairs["rotations_reorthonormalised"] = int((err > 1e-6).sum())
    return T


# ------------------------------------------------------------------------ text helpers
def first_data_line(text: str, comment: str = "#") -> str:
    """The first line that is neither blank nor a comment, stripped ("" if none)."""
    for line in text.splitlines():
        s = line.strip()
        if s and not s.startswith(comment):
            return s
    return ""


def is_pose_row(line: str, sep: str | None) -> bool:
    """Whether ``line`` is a row of 8 numbers ``t, x, y, z, qx, qy, qz, qw`` split on
    ``sep`` (``None``: whitespace): what the ETH and TUM sniffers look for."""
    parts = line.split(sep)
    if len(parts) != 8:
        return False
    try:
        [float(p) for p in parts]
    except ValueError:
        return False
    return True


def pose_rows(stream: PoseStreamData) -> np.ndarray:
    """``(N, 8)`` rows ``t, x, y, z, qx, qy, qz, qw`` of a stream (as read: its
    ``T_world_sensor``), what the TUM, ETH and CSV writers write."""
    T = np.asarray(stream.T_world_sensor, dtype=np.float64)
    return np.column_stack([np.asarray(stream.timestamps_s, dtype=np.float64), T[:, :3, 3],
                            quat_from_matrix(T[:, :3, :3])])


def read_pose_rows(path, text: str, sep: str | None, fmt: str, layout: str,
                   options: dict) -> list[RawStream]:
    """One stream from rows of 8 numbers (time, position, quaternion x y z w) split on
    ``sep``; ``fmt`` (reader name) and ``layout`` (the columns, for the error) name the
    format in messages. Such readers take no options."""
    if options:
        raise TypeError(f"{fmt} reader takes no options; received {sorted(options)}")
    try:
        rows, truncated = numeric_rows(text, sep)
    except DataError as e:
        raise data_error(f"{path}: {e}") from None
    if rows.shape[1] != 8:
        lineno = next(k for k, ln in enumerate(text.splitlines(), 1)
                      if ln.strip() and not ln.strip().startswith(("#", "%")))
        raise data_error(f"{path}: line {lineno}: {rows.shape[1]} values a row; {fmt.upper()} "
                         f"rows have 8 ({layout})")
    return [RawStream(rows[:, 0], position_m=rows[:, 1:4], quat_xyzw=rows[:, 4:8],
                      repairs={"truncated_last_row_dropped": truncated} if truncated else {})]


def numeric_rows(text: str, sep: str | None, comment: str = "#") -> tuple[np.ndarray, int]:
    """Parse numeric rows (``sep`` None: whitespace). Returns (array, n_lines_skipped):
    the file's last row, when it holds fewer values than the rows before it (a recording
    cut off while writing), is skipped; other unparsable lines raise with the line
    number."""
    lines = [(k, ln.strip()) for k, ln in enumerate(text.splitlines(), 1)]
    lines = [(k, s) for k, s in lines if s and not s.startswith((comment, "%"))]
    rows = []
    width = None
    for i, (lineno, s) in enumerate(lines):
        parts = [p.strip() for p in (s.split(sep) if sep else s.split()) if p.strip() != ""]
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            if i == len(lines) - 1 and width is not None and len(parts) <= width:
                return np.asarray(rows, dtype=np.float64), 1     # cut mid-number
            raise data_error(f"line {lineno}: could not read numbers from {s[:100]!r}") from None
        if width is None:
            width = len(vals)
        elif len(vals) < width and i == len(lines) - 1:
            return np.asarray(rows, dtype=np.float64), 1          # the last row cut short
        elif len(vals) != width:
            raise data_error(f"line {lineno}: {len(vals)} values, earlier lines have {width}")
        rows.append(vals)
    if not rows:
        raise data_error("no numeric rows found")
    return np.asarray(rows, dtype=np.float64), 0
