"""Does a stream move, and how: rotation, translation only, or not at all.

What the estimation path correlates, scores and keeps depends on it
(:func:`check_streams_move` decides it once per calibration):

* ``rotation`` - either stream turns (90 % of its poses beyond :data:`STILL_DEG` of its
  first pose): the clock offset is read from the angular speeds, motions that do not turn
  carry no information and are dropped, minimal sets need rotation axes apart;
* ``translation`` - neither stream turns but both translate (90 % of the positions within
  :data:`STILL_DEG`, the positions spread beyond :data:`STILL_M`): a cart pushed without
  turning, a gantry, a linear stage. ``C X = X H`` reduces to ``t_C = R_X t_H``: X's
  rotation follows from the translations (two or more directions; one direction leaves the
  rotation about it free), X's translation from nothing. With no rotation the norms of a
  motion's translations agree in both sensors (``|t_C| = |t_H|``) and so do the speeds, so
  the clock offset is read from the translation speeds, and the motions are kept whatever
  their (noise) rotation.

Positions are taken in metres for :data:`STILL_M` (the threshold below which a stream
that does not turn is called still). That alone would make a file in millimetres whose rig
does not move read as translating by its noise (1 mm of noise is 1 "m"), so whether a
densely sampled stream translates is also decided without a length unit
(:func:`white_positions`): a path wanders from pose to pose far beyond one step, noise
around one place spreads no farther than its own pose-to-pose steps.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import rotation_angle_rad

__all__ = ["check_distinct", "check_streams_move", "STILL_DEG", "STILL_M", "rotation_extent_deg",
           "translation_extent_m", "motion_signal", "translates", "TRANSLATES_SHARE",
           "white_positions", "WHITE_RATIO", "DENSE_PERIOD_S", "MIN_WHITE_POSES"]

#: a stream whose poses (90 %) lie within this angle of its first pose does not rotate
STILL_DEG = 1.0
#: a stream that does not rotate and whose positions (90 %) lie within this distance of
#: their median does not move (m)
STILL_M = 0.005
#: a motion of a rig that does not turn carries the signal when it translates by at least
#: this share of the recording's median motion
TRANSLATES_SHARE = 0.1
#: positions within this many median pose-to-pose steps of their median (90 %) are white
#: noise around one place, in any length unit (i.i.d. noise: 1.2 in 3-D, 1.7 along one axis)
WHITE_RATIO = 3.0
#: ... judged on streams sampled at least this densely (median period, s) ...
DENSE_PERIOD_S = 0.2
#: ... with at least this many poses (stations, seconds apart, are white by nature)
MIN_WHITE_POSES = 50


def _poses(stream) -> np.ndarray:
    T = getattr(stream, "T_world_sensor", None)
    if T is None and isinstance(stream, tuple):
        T = stream[1]
    return np.asarray(T, dtype=np.float64)


def _stretches(stream, n: int) -> list[slice]:
    """The rows of each stretch of a stream's world (between its ``world_jumps_s``: a
    jump of the world frame is no motion of the rig)."""
    jumps = np.asarray(getattr(stream, "world_jumps_s", ()), dtype=np.float64)
    if not jumps.size:
        return [slice(0, n)]
    cuts = np.searchsorted(np.asarray(stream.timestamps_s, dtype=np.float64), jumps)
    edges = [0, *cuts.tolist(), n]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def rotation_extent_deg(stream) -> float:
    """How far a stream turns: the 90th percentile of its poses' angles from the first
    pose of their world's stretch (outlier poses do not count)."""
    R = _poses(stream)[:, :3, :3]
    angles = [rotation_angle_rad(R[k][0].T[None] @ R[k]) for k in _stretches(stream, len(R))]
    return float(np.degrees(np.percentile(np.concatenate(angles), 90)))


def translation_extent_m(stream) -> float:
    """How far a stream translates: the 90th percentile of its positions' distances from
    their world stretch's median (outlier poses do not count). The same for the file's
    inverse poses when the stream does not rotate (``p' = -R^T p`` with one ``R``)."""
    p = _poses(stream)[:, :3, 3]
    d = [np.linalg.norm(p[k] - np.median(p[k], axis=0), axis=1)
         for k in _stretches(stream, len(p))]
    return float(np.percentile(np.concatenate(d), 90))


def white_positions(stream) -> str | None:
    """Why a densely sampled stream's positions are noise around one place, whatever their
    length unit (None when they trace a path, or the stream is too sparse to tell): 90 % of
    them within :data:`WHITE_RATIO` median pose-to-pose steps of their median, on
    :data:`MIN_WHITE_POSES` or more poses at most :data:`DENSE_PERIOD_S` apart. A moving
    rig sampled densely wanders far beyond one step; stations, seconds apart, are not
    judged (their scale alone tells)."""
    t = np.asarray(stream.timestamps_s, dtype=np.float64)
    p = _poses(stream)[:, :3, 3]
    if t.size < MIN_WHITE_POSES or not np.median(np.diff(t)) <= DENSE_PERIOD_S:
        return None
    step = float(np.median(np.linalg.norm(np.diff(p, axis=0), axis=1)))
    extent = translation_extent_m(stream)
    if extent > WHITE_RATIO * step:
        return None
    return (f"its positions spread {extent:.3g} (in the file's unit, 90 % from their "
            f"median) and step {step:.3g} from pose to pose: white noise around one place, "
            f"not a path (a path wanders beyond {WHITE_RATIO:g} steps)")


def motion_signal(stream_a, stream_b) -> str:
    """``"rotation"`` when either stream turns by :data:`STILL_DEG` or more, else
    ``"translation"`` (whether they move at all is checked by
    :func:`check_streams_move`)."""
    turns = max(rotation_extent_deg(stream_a), rotation_extent_deg(stream_b))
    return "rotation" if turns >= STILL_DEG else "translation"


def translates(d) -> np.ndarray:
    """Which motions of a rig that does not turn carry a signal: translation lengths ``d``
    of at least :data:`TRANSLATES_SHARE` of their median (the rest is standing still)."""
    d = np.asarray(d, dtype=np.float64)
    return d > TRANSLATES_SHARE * float(np.median(d)) if d.size else d > 0


def check_distinct(sa, sb) -> None:
    """Bad input: a DataError where a and b hold the same poses, row for row (one file or
    topic given twice, or a copy of it stamped anew). Two sensors of a rig sit apart; the
    same poses would give X = identity, a number about the input, not the rig."""
    from simcalib.errors import DataError
    Ta, Tb = sa.T_world_sensor, sb.T_world_sensor
    if Ta.shape == Tb.shape and np.allclose(Ta, Tb, rtol=0.0, atol=1e-9):
        same = np.array_equal(sa.timestamps_s, sb.timestamps_s)
        raise DataError(
            f"a ({sa.source}) and b ({sb.source}) hold the same {len(sa)} poses, row for row"
            + (" at the same stamps" if same else "") + ": the same file or topic given "
            "twice? a and b must be the two sensors' own poses (e.g. the robot's T_base_ee "
            "and the camera's T_cam_target)")


def check_streams_move(sa, sb) -> str:
    """How the rig moves (:mod:`simcalib.estimation.stillness`): ``"rotation"`` or
    ``"translation"`` (neither stream turns, both translate: a degenerate motion that
    determines X's rotation, not its translation; every stage then works on the
    translations). Bad input is a clear DataError: a stream that does not rotate while the
    other does, one that does not move while the other translates, or nothing moving at
    all (a wrong topic or file, a frozen tracker)."""
    from simcalib.errors import DataError
    ext = {"a": rotation_extent_deg(sa), "b": rotation_extent_deg(sb)}
    streams = {"a": sa, "b": sb}
    for name, other in _still_beside_moving(ext, STILL_DEG):
        raise DataError(
            f"stream {name} ({streams[name].source}) does not rotate: 90 % of its poses "
            f"lie within {ext[name]:.2g} deg of its first pose, while stream {other} "
            f"turns by {ext[other]:.3g} deg; both sensors of a rigid rig turn alike (a "
            "wrong file or topic, or a frozen tracker?)")
    if max(ext.values()) >= STILL_DEG:
        return "rotation"
    move, why = _translation_extents(streams)
    if max(move.values()) < STILL_M:
        raise DataError(
            f"nothing moves: neither stream rotates (90 % of the poses within "
            f"{ext['a']:.2g} deg (a) and {ext['b']:.2g} deg (b) of the first) nor translates "
            f"(a: {why['a']}; b: {why['b']}); a calibration needs the rig to move (a wrong "
            "file or topic, or a frozen tracker?)")
    for name, other in _still_beside_moving(move, STILL_M):
        raise DataError(
            f"stream {name} ({streams[name].source}) does not move: it neither rotates "
            f"nor translates ({why[name]}), while stream {other} translates by "
            f"{1e3 * move[other]:.3g} mm; both sensors of a rigid rig that does not turn "
            "translate alike (a wrong file or topic, or a frozen tracker?)")
    return "translation"


def _translation_extents(streams: dict) -> tuple[dict, dict]:
    """``({name: extent (m)}, {name: why it is still})``: how far each stream translates,
    0 where its positions are white noise around one place whatever the length unit
    (:func:`simcalib.estimation.stillness.white_positions`: a still rig's file in mm)."""
    move, why = {}, {}
    for k, s in streams.items():
        extent, white = translation_extent_m(s), white_positions(s)
        move[k] = 0.0 if white else extent
        why[k] = white or (f"90 % of its positions within {1e3 * extent:.2g} mm of their "
                           f"median, < {1e3 * STILL_M:g} mm")
    return move, why


def _still_beside_moving(extent: dict, still: float) -> list[tuple[str, str]]:
    """``[(name, other)]`` where stream ``name`` stays within ``still`` while ``other``
    moves 5x as far (and beyond a fifth of ``still``): bad input, not a degenerate motion."""
    return [(n, o) for n, o in (("a", "b"), ("b", "a"))
            if extent[n] < still and extent[o] > 5.0 * max(extent[n], 0.2 * still)]
