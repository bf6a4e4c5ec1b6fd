"""Does a stream move, and how: rotation, translation only, or not at all.

What the estimation path correlates, scores and keeps depends on it
(:func:`simcalib.estimation.path.check_streams_move` decides it once per calibration):

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
that does not turn is called still); a file in millimetres whose rig does not move at all
reads as translating by its noise, and the calibration then reports X's rotation as poorly
determined from that noise.
"""

from __future__ import annotations

import numpy as np

from simcalib.geometry import rotation_angle_rad

__all__ = ["STILL_DEG", "STILL_M", "rotation_extent_deg", "translation_extent_m",
           "motion_signal", "translates", "TRANSLATES_SHARE"]

#: a stream whose poses (90 %) lie within this angle of its first pose does not rotate
STILL_DEG = 1.0
#: a stream that does not rotate and whose positions (90 %) lie within this distance of
#: their median does not move (m)
STILL_M = 0.005
#: a motion of a rig that does not turn carries the signal when it translates by at least
#: this share of the recording's median motion
TRANSLATES_SHARE = 0.1


def _poses(stream) -> np.ndarray:
    T = getattr(stream, "T_world_sensor", None)
    if T is None and isinstance(stream, tuple):
        T = stream[1]
    return np.asarray(T, dtype=np.float64)


def rotation_extent_deg(stream) -> float:
    """How far a stream turns: the 90th percentile of its poses' angles from the first
    pose (outlier poses do not count)."""
    R = _poses(stream)[:, :3, :3]
    return float(np.degrees(np.percentile(rotation_angle_rad(R[0].T[None] @ R), 90)))


def translation_extent_m(stream) -> float:
    """How far a stream translates: the 90th percentile of its positions' distances from
    their median (outlier poses do not count). The same for the file's inverse poses when
    the stream does not rotate (``p' = -R^T p`` with one ``R``)."""
    p = _poses(stream)[:, :3, 3]
    return float(np.percentile(np.linalg.norm(p - np.median(p, axis=0), axis=1), 90))


def motion_signal(stream_a, stream_b) -> str:
    """``"rotation"`` when either stream turns by :data:`STILL_DEG` or more, else
    ``"translation"`` (whether they move at all is checked by
    :func:`simcalib.estimation.path.check_streams_move`)."""
    turns = max(rotation_extent_deg(stream_a), rotation_extent_deg(stream_b))
    return "rotation" if turns >= STILL_DEG else "translation"


def translates(d) -> np.ndarray:
    """Which motions of a rig that does not turn carry a signal: translation lengths ``d``
    of at least :data:`TRANSLATES_SHARE` of their median (the rest is standing still)."""
    d = np.asarray(d, dtype=np.float64)
    return d > TRANSLATES_SHARE * float(np.median(d)) if d.size else d > 0
