"""The kinds of a robot arm that stops: one pose per station and stream (``stations``,
``stations_short``, on two computers' clocks, a SCARA's), a burst of frames at each
(``bursts``, ``translation_bursts``), and a hand streamed through its stops with a camera
that sees only while it stands still (``stop_and_go``, also on another clock).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from simcalib.geometry import matrix_from_rotvec, transform_from_rotation_translation
from simcalib.studies.experiments.recording_models import (R_DOWN, WORKSPACE_CENTRE, _Draft,
                                                           _camera_poses, _continuous,
                                                           _hand_camera_rig, _noisy, _rotvecs,
                                                           _rz, _small_offset,
                                                           _station_poses, _station_stamps,
                                                           _stations_draft,
                                                           _stop_and_go_motion, _unit)

__all__: list[str] = []


def _kind_stations(rngs, s):
    return _stations_draft(rngs, s, (10, 40), "stations")


def _kind_stations_short(rngs, s):
    return _stations_draft(rngs, s, (3, 5), "stations_short")


def _kind_stations_two_clocks(rngs, s):
    d = _stations_draft(rngs, s, (10, 40), "stations_two_clocks")
    r = rngs["events"]
    off = float(r.choice([-1.0, 1.0]) * r.uniform(0.5, 10.0))
    off = off if s.offset_s is None else float(s.offset_s)
    t_a = 1000.0 + np.cumsum(r.uniform(2.0, 6.0, d.t_a.size))
    t_b = t_a + off + r.uniform(-0.05, 0.05, t_a.size)
    return replace(d, t_a=t_a, t_b=t_b, offset_s=off, t_ref_s=float(t_a[0]),
                   description=d.description.split(",")[0] + f", 2..6 s apart, b's clock "
                   f"{off:+.3f} s (+-50 ms trigger jitter), eye-in-hand (b = T_target_cam)")


def _kind_bumped_camera(rngs, s):
    """stations (27..40) with the camera knocked on its mount after 30..45 % of them: X
    turns by 2..6 deg and moves by 10..30 mm there. ``X`` is the later (longer) stretch's,
    the mount as it is now; ``X_before_change`` the earlier one's."""
    rig, ev = rngs["rig"], rngs["events"]
    k = s.stations if s.stations is not None else int(rig.integers(27, 40, endpoint=True))
    X0, Y = _hand_camera_rig(rig)
    j = int(np.ceil(k * ev.uniform(0.3, 0.45)))
    X1 = X0 @ transform_from_rotation_translation(
        matrix_from_rotvec(_rotvecs(ev, 1, 2, 6)[0]), _unit(ev, 1)[0] * ev.uniform(0.01, 0.03))
    A = _station_poses(rngs["motion"], k)
    t, how = _station_stamps(rngs["clock"], k, rngs["seed"])
    B = np.concatenate([_camera_poses(A[:j], X0, Y), _camera_poses(A[j:], X1, Y)])
    B = _noisy(B, s.sigma_rot_b_deg, s.sigma_trans_b_m, rngs["noise_b"], s.noise)
    A = _noisy(A, s.sigma_rot_a_deg, s.sigma_trans_a_m, rngs["noise_a"], s.noise)
    return _Draft(t, A, t.copy(), B, X1, f"bumped_camera: {k} stations, {how}, the camera "
                  f"moved on its mount before station {j} (eye-in-hand, b = T_target_cam)",
                  0.0, 0.0, float(t[0]), Y=Y, X_before_change=X0, change_row=j)


def _scara_poses(rng, k) -> np.ndarray:
    xy = WORKSPACE_CENTRE[:2] + rng.uniform(-0.25, 0.25, (k, 2))
    z = rng.choice(np.array([0.3, 0.4, 0.5]), k)
    R = _rz(rng.uniform(-np.pi, np.pi, k)) @ R_DOWN[None]
    return transform_from_rotation_translation(R, np.column_stack([xy, z]))


def _kind_scara(rngs, s):
    d = _stations_draft(rngs, s, (10, 30), "scara", poses=_scara_poses)
    return replace(d, undetermined_a=R_DOWN.T @ np.array([0.0, 0.0, 1.0]),
                   description=d.description + ", 4-DoF (rotation about the vertical only, z "
                   "on a 3-level grid): X's translation along the hand axis is undetermined")


def _kind_bursts(rngs, s):
    """8..25 stations, a burst of 3..8 frames at 30 Hz at each (both streams logged per
    frame); the camera's error is mostly common to a burst (one view of a still target:
    the station's error, plus a fifth of it per frame)."""
    rig = rngs["rig"]
    k = s.stations if s.stations is not None else int(rig.integers(8, 25, endpoint=True))
    m = int(rig.integers(3, 8, endpoint=True))
    X, Y = _hand_camera_rig(rig)
    P = _station_poses(rngs["motion"], k)
    return _burst_draft(rngs, s, P, m, X, Y, f"bursts: {k} stations", "")


def _burst_draft(rngs, s, P, m, X, Y, head: str, how: str, **extra) -> "_Draft":
    """Stations ``P`` (k, 4, 4) of the hand, a burst of ``m`` frames at 30 Hz at each, 3..8 s
    apart (both streams logged per frame); the camera's error mostly common to a burst (the
    station's error, plus a fifth of it per frame)."""
    k = P.shape[0]
    t = (1000.0 + np.cumsum(rngs["clock"].uniform(3.0, 8.0, k))[:, None]
         + np.arange(m)[None] / 30.0).ravel()
    B = _noisy(_camera_poses(P, X, Y), s.sigma_rot_b_deg, s.sigma_trans_b_m, rngs["noise_b"],
               s.noise)
    B = _noisy(np.repeat(B, m, axis=0), 0.2 * s.sigma_rot_b_deg, 0.2 * s.sigma_trans_b_m,
               rngs["noise_b"], s.noise)
    A = _noisy(np.repeat(P, m, axis=0), s.sigma_rot_a_deg, s.sigma_trans_a_m,
               rngs["noise_a"], s.noise)
    return _Draft(t, A, t.copy(), B, X, f"{head} x {m} frames at 30 Hz{how}, stamps 3..8 s "
                  "apart, camera error mostly common to a burst", 0.0, 0.0, float(t[0]), Y=Y,
                  **extra)


def _kind_translation_bursts(rngs, s):
    """a gantry that stops at 8..25 stations (fixed orientation) and logs a burst of 3..8
    frames at 30 Hz at each (both streams), the camera's error mostly common to a burst;
    X's translation undetermined (nothing turns)."""
    rig = rngs["rig"]
    k = s.stations if s.stations is not None else int(rig.integers(8, 25, endpoint=True))
    m = int(rig.integers(3, 8, endpoint=True))
    X, Y = _hand_camera_rig(rig)
    R0 = R_DOWN @ matrix_from_rotvec(_rotvecs(rngs["motion"], 1, 10, 40)[0])
    p = WORKSPACE_CENTRE + rngs["motion"].uniform(-0.25, 0.25, (k, 3))
    P = transform_from_rotation_translation(np.broadcast_to(R0, (k, 3, 3)), p)
    return _burst_draft(rngs, s, P, m, X, Y, f"translation_bursts: a gantry stopping at {k} "
                        "stations", " without turning", undetermined_a=np.eye(3))


def _stop_and_go_draft(rngs, s, offset_s: float, label: str) -> _Draft:
    """a streams the whole session through 8..20 stops; b (its clock ``offset_s`` ahead)
    sees the target only while the hand stands still."""
    k = s.stations if s.stations is not None else int(rngs["rig"].integers(8, 20,
                                                                           endpoint=True))
    motion, duration, still = _stop_and_go_motion(rngs["motion"], k)
    d = _continuous(rngs, replace(s, duration_s=duration), offset_s=offset_s, hand=motion,
                    label=label)
    tau = d.t_b - d.offset_s - (d.t_ref_s - 0.5 * duration)     # b's instants on the motion
    seen = ((tau[:, None] >= still[None, :, 0]) & (tau[:, None] <= still[None, :, 1])).any(1)
    return replace(d, t_b=d.t_b[seen], B=d.B[seen], description=d.description
                   + f", {k} stops; b only while the hand stands still ({int(seen.sum())} "
                   "poses)")


def _kind_stop_and_go(rngs, s):
    return _stop_and_go_draft(rngs, s, _small_offset(rngs, s), "stop_and_go")


def _kind_stop_and_go_two_clocks(rngs, s):
    """stop_and_go with b stamped by another computer: its clock 5..40 s early or late,
    plus +-50 ms (``offset_s``: the whole offset)."""
    r = rngs["events"]
    shift = float(r.choice([-1.0, 1.0]) * r.uniform(5.0, 40.0))
    small = _small_offset(rngs, s)              # always drawn: the same arrays
    off = small + shift if s.offset_s is None else small
    d = _stop_and_go_draft(rngs, s, off, "stop_and_go_two_clocks")
    return replace(d, description=d.description + f", b's clock {off:+.3f} s (another "
                   "computer)")
