"""The kinds of generated recording (:data:`KINDS`: stations, short, bursts, stop-and-go,
continuous, a low-rate camera, offsets and drift, outliers, gaps, robot error, planar,
SCARA, pure and nearly pure translation, inverted, scalar-first, stamps in ms / us / ns, b
in another scale, no motion) and :func:`generate` (a kind and a seed -> a
:class:`Recording`), the true streams, and the TUM files a recording is written as
(``a.txt``, ``b.txt``, ``truth.json``).
"""

from __future__ import annotations

import math
from dataclasses import fields, replace
from typing import Callable

import numpy as np

from simcalib.geometry import (invert_transform, matrix_from_quat, matrix_from_rotvec,
                               quat_from_matrix, random_rotation_matrices, rotvec_from_matrix,
                               transform_from_rotation_translation)
from simcalib.importers import PoseStreamData, stream_from_arrays
from simcalib.importers._stamps import UNIT_FACTORS
from simcalib.studies.experiments.recording_files import read_truth, write_tum
from simcalib.studies.experiments.recording_models import (Kind, R_DOWN, R_FORWARD, Recording,
                                                           Settings, WORKSPACE_CENTRE, _continuous,
                                                           _camera_poses, _Draft,
                                                           _eval_sinusoids, _hand_camera_rig,
                                                           _noisy, _rngs, _rotvecs, _rz,
                                                           _sinusoids, _station_poses,
                                                           _stations_draft, _stop_and_go_motion,
                                                           _unit)

__all__ = ["KINDS", "generate", "true_streams", "write_tum", "read_truth", "workspace_X"]



# --------------------------------------------------------------------------- the kinds
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


def _kind_continuous(rngs, s):
    return _continuous(rngs, s)


def _small_offset(rngs, s) -> float:
    """The clock offset of the kinds about something else (gaps, readings, planar): uniform
    in +-50 ms (a real recording never has exactly 0), unless ``offset_s`` is given."""
    drawn = float(rngs["clock"].uniform(-0.05, 0.05))     # always drawn: same arrays
    return drawn if s.offset_s is None else float(s.offset_s)


def _kind_offset(rngs, s):
    r = rngs["events"]
    large = rngs["seed"] % 3 == 2          # seeds 2, 5, 8, ...: tens of seconds
    off = (r.choice([-1.0, 1.0]) * r.uniform(10.0, 40.0)) if large else r.uniform(-0.2, 0.2)
    drift_ppm = (r.choice([-1.0, 1.0]) * r.uniform(30.0, 100.0)   # seeds 1, 4, 7, ...
                 if rngs["seed"] % 3 == 1 else 0.0)
    off = s.offset_s if s.offset_s is not None else float(off)
    drift_ppm = s.drift_ppm if s.drift_ppm is not None else float(drift_ppm)
    return _continuous(rngs, s, offset_s=off, drift=1e-6 * drift_ppm, label="offset")


def _kind_clock_drift(rngs, s):
    r = rngs["events"]
    off = float(r.uniform(-0.2, 0.2)) if s.offset_s is None else float(s.offset_s)
    drift_ppm = float(r.choice([-1.0, 1.0]) * r.uniform(50.0, 150.0))
    drift_ppm = drift_ppm if s.drift_ppm is None else float(s.drift_ppm)
    return _continuous(rngs, s, offset_s=off, drift=1e-6 * drift_ppm, label="clock_drift")


def _kind_outliers(rngs, s):
    d = _continuous(rngs, s, offset_s=0.037 if s.offset_s is None else s.offset_s,
                    label="outliers")
    r = rngs["events"]
    frac = s.outlier_fraction if s.outlier_fraction is not None else r.uniform(0.05, 0.2)
    mask = r.random(d.B.shape[0]) < frac
    n = int(mask.sum())
    jump = transform_from_rotation_translation(matrix_from_rotvec(_rotvecs(r, n, 10, 60)),
                                               _unit(r, n) * r.uniform(0.2, 1.0, n)[:, None])
    B = d.B.copy()
    B[mask] = B[mask] @ jump
    return replace(d, B=B, outliers_b=mask, description=d.description
                   + f", {n} outlier poses in b ({100 * n / mask.size:.1f} %, jumps 10..60 deg "
                   "/ 0.2..1 m)")


def _kind_gaps(rngs, s):
    d = _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="gaps")
    r = rngs["events"]
    which = "b" if rngs["seed"] % 2 == 0 else "a"       # seeds take turns
    t = d.t_a if which == "a" else d.t_b
    span = t[-1] - t[0]
    keep = np.ones(t.size, dtype=bool)
    gaps = []
    n = int(r.integers(1, 2, endpoint=True))
    regions = [(0.15, 0.85)] if n == 1 else [(0.15, 0.4), (0.6, 0.85)]     # never overlapping
    for lo, hi in regions:
        length = r.uniform(1.0, 3.0)
        start = t[0] + r.uniform(lo, hi) * span - 0.5 * length
        keep &= ~((t >= start) & (t < start + length))
        gaps.append(f"{length:.1f} s at {start - t[0]:.1f} s")
    desc = d.description + f", gaps in {which}: " + ", ".join(gaps)
    if which == "a":
        return replace(d, t_a=d.t_a[keep], A=d.A[keep], description=desc)
    return replace(d, t_b=d.t_b[keep], B=d.B[keep], description=desc)


def _robot_error_field(rng) -> tuple[Callable, tuple[float, float]]:
    """A systematic, pose-dependent kinematic error: three random low-order (sinusoidal)
    functions of the pose (position and rotation vector) with an rms of 0.1..0.5 deg /
    1..3 mm over the workspace (correlated between nearby poses, not white). Returns
    ``(T_true_hand -> E, (rms deg, rms m))``: the error in the hand frame (the robot
    REPORTS ``T_true_hand @ E``) and the rms its maker would state as its accuracy."""
    w = rng.normal(0.0, 1.0, (3, 6))
    ph = rng.uniform(0.0, 2 * np.pi, 3)
    # each sin term has mean square ~1/2, three terms along unit vectors: rms ~ amp
    rms_deg, rms_m = rng.uniform(0.1, 0.5), rng.uniform(0.001, 0.003)
    amp_r = math.radians(rms_deg) / math.sqrt(1.5)
    amp_t = rms_m / math.sqrt(1.5)
    dirs_r = _unit(rng, 3) * amp_r
    dirs_t = _unit(rng, 3) * amp_t

    def error(A):
        f = np.concatenate([(A[:, :3, 3] - WORKSPACE_CENTRE) / 0.25,
                            rotvec_from_matrix(R_DOWN.T[None] @ A[:, :3, :3])], axis=1)
        basis = np.sin(f @ w.T + ph)                               # (N, 3)
        return transform_from_rotation_translation(matrix_from_rotvec(basis @ dirs_r),
                                                   basis @ dirs_t)
    return error, (float(rms_deg), float(rms_m))


def _depth_biased(B, bias: float) -> np.ndarray:
    """Camera poses ``T_target_cam`` whose camera-to-target distance d reads
    ``(1 + bias d / 0.5 m)`` times too long (a depth-scale bias growing with d)."""
    T_cam_target = invert_transform(B)
    p = T_cam_target[:, :3, 3]
    d = np.linalg.norm(p, axis=1)
    T_cam_target[:, :3, 3] = p * (1.0 + bias * d / 0.5)[:, None]
    return invert_transform(T_cam_target)


def _camera_error(rng, B, on: bool, sigma_rot_deg: float, sigma_trans_m: float
                  ) -> tuple[np.ndarray, float]:
    """Camera poses (``T_target_cam``) with errors that grow with the viewing distance d:
    a depth-scale bias of 0.2..0.8 % x (d / 0.5 m) along the line of sight and noise of
    sigma (default 0.1 deg / 1 mm) x (d / 0.5 m)^2. Returns (poses, bias)."""
    d = np.linalg.norm(invert_transform(B)[:, :3, 3], axis=1)
    bias = rng.uniform(0.002, 0.008)
    n = B.shape[0]
    rot = _unit(rng, n) * (rng.normal(0.0, math.radians(sigma_rot_deg), n)
                           * (d / 0.5) ** 2)[:, None]
    dt = rng.normal(0.0, sigma_trans_m, (n, 3)) * ((d / 0.5)[:, None] ** 2)
    if not on:
        return B, bias
    return _depth_biased(B, bias) @ transform_from_rotation_translation(
        matrix_from_rotvec(rot), dt), bias


#: stations of the dense, noise-free solve that gives a recording's X_workspace
WORKSPACE_STATIONS = 2000


def workspace_X(rng, X, Y, error, bias: float, stations: int = WORKSPACE_STATIONS
                ) -> np.ndarray:
    """The X that a robot reporting ``T_hand @ error(T_hand)`` and a camera with the depth
    ``bias`` imply over the workspace: dqopt on the motions between ``stations`` random
    stations (consecutive in draw order), free of noise. (A constant error ``E0`` in the
    hand frame gives exactly ``E0^-1 X`` with zero residual: no recording can tell it.)"""
    from simcalib.solvers.api import solve_batch
    A = _station_poses(rng, stations)
    B = _depth_biased(_camera_poses(A, X, Y), bias)
    A = A @ error(A)
    C = invert_transform(A[:-1]) @ A[1:]
    H = invert_transform(B[:-1]) @ B[1:]
    return np.asarray(solve_batch(C[None], H[None], method="dqopt").X[0])


def _kind_robot_error(rngs, s):
    clean = replace(s, sigma_rot_b_deg=0.0, sigma_trans_b_m=0.0)
    d = _stations_draft(rngs, clean, (10, 40), "robot_error")
    r = rngs["events"]
    error, accuracy = _robot_error_field(r)
    A = d.A @ error(d.A) if s.noise else d.A
    B, bias = _camera_error(r, d.B, s.noise, s.sigma_rot_b_deg, s.sigma_trans_b_m)
    X_ws = workspace_X(rngs["workspace"], d.X, d.Y, error, bias) if s.noise else None
    return replace(d, A=A, B=B, X_workspace=X_ws, accuracy_a=accuracy,
                   description=d.description
                   + ", systematic pose-dependent robot error (rms 0.1..0.5 deg / 1..3 mm), "
                   "distance-dependent camera error")


def _vehicle_motion(rng, duration_s) -> Callable:
    """``tau -> T_odom_vehicle``: planar driving (yaw only), 0.5..1.5 m/s."""
    grid = np.arange(0.0, duration_s + 1.0, 0.005)
    yaw_rate = _eval_sinusoids(_sinusoids(rng, 0.15, 0.3, 0.05, 0.3, dims=1), grid)[:, 0]
    speed = 1.0 + 0.5 * np.sin(2 * np.pi * rng.uniform(0.03, 0.1) * grid
                               + rng.uniform(0, 2 * np.pi))
    yaw = np.cumsum(yaw_rate) * 0.005
    x = np.cumsum(speed * np.cos(yaw)) * 0.005
    y = np.cumsum(speed * np.sin(yaw)) * 0.005

    def poses(tau):
        p = np.stack([np.interp(tau, grid, x), np.interp(tau, grid, y), np.zeros(tau.size)], 1)
        return transform_from_rotation_translation(_rz(np.interp(tau, grid, yaw)), p)
    return poses


def _kind_planar(rngs, s):
    rig = rngs["rig"]
    X = transform_from_rotation_translation(
        R_FORWARD @ matrix_from_rotvec(_rotvecs(rig, 1, 0, 15)[0]),
        np.array([rig.uniform(0.5, 1.5), rig.uniform(-0.3, 0.3), rig.uniform(0.5, 1.5)]))
    Y = transform_from_rotation_translation(random_rotation_matrices(rig),
                                            rig.normal(0.0, 2.0, 3))
    d = _continuous(rngs, s, hand=_vehicle_motion(rngs["motion"], s.duration_s), rig=(X, Y),
                    offset_s=_small_offset(rngs, s), label="planar")
    return replace(d, undetermined_a=np.array([0.0, 0.0, 1.0]),
                   description=d.description + ", vehicle (yaw only): X's translation along "
                   "the vertical is undetermined")


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


def _stage_motion(rng, planar: bool) -> Callable:
    """``tau -> T_world_stage``: a cart (``planar``: in the floor's plane) or a gantry / linear
    stage (in 3-D) translating ~0.1..0.3 m (sums of sinusoids) with a fixed orientation."""
    R0 = random_rotation_matrices(rng)
    amp, f, ph = _sinusoids(rng, 0.05, 0.15, 0.03, 0.25)
    if planar:
        amp = amp * np.array([1.0, 1.0, 0.0])
    centre = rng.uniform(-1.0, 1.0, 3)

    def poses(tau):
        p = centre + _eval_sinusoids((amp, f, ph), tau)
        return transform_from_rotation_translation(np.broadcast_to(R0, (tau.size, 3, 3)), p)
    return poses


def _kind_translation(rngs, s):
    planar = rngs["seed"] % 2 == 1              # seeds take turns: gantry (3-D), cart (2-D)
    d = _continuous(rngs, s, hand=_stage_motion(rngs["motion"], planar),
                    offset_s=_small_offset(rngs, s), label="translation")
    return replace(d, undetermined_a=np.eye(3), description=d.description + (
        ", a cart translating in a plane" if planar else ", a stage translating in 3-D")
        + " without rotating: X's rotation follows from the translations, its translation "
        "is undetermined")


def _weak_turn(rng, motion: Callable, duration_s: float) -> Callable:
    """``motion`` with a slight rotation added: sums of sinusoids in the rotation vector,
    scaled so that the stage turns by 1..5 deg in all (90 % of its poses within that of
    the first: just beyond :data:`simcalib.estimation.stillness.STILL_DEG`)."""
    rot = _sinusoids(rng, 0.5, 1.0, 0.03, 0.25)
    extent_deg = float(rng.uniform(1.0, 5.0))
    grid = np.linspace(0.0, duration_s, 2001)
    v = _eval_sinusoids(rot, grid)
    R = matrix_from_rotvec(v)
    turn = np.degrees(np.percentile(np.linalg.norm(rotvec_from_matrix(
        R[0].T[None] @ R), axis=1), 90))
    scale = extent_deg / max(float(turn), 1e-9)

    def poses(tau):
        T = motion(tau)
        T[:, :3, :3] = T[:, :3, :3] @ matrix_from_rotvec(scale * _eval_sinusoids(rot, tau))
        return T
    poses.extent_deg = extent_deg
    return poses


def _kind_weak_rotation(rngs, s):
    """a stage or a cart translating ~0.1..0.3 m that turns only slightly (1..5 deg in all:
    a cart that barely turns, a gantry whose head wobbles), clock offset +-0.2 s."""
    planar = rngs["seed"] % 2 == 1
    r = rngs["events"]
    off = float(r.uniform(-0.2, 0.2)) if s.offset_s is None else float(s.offset_s)
    hand = _weak_turn(rngs["motion"], _stage_motion(rngs["motion"], planar), s.duration_s)
    d = _continuous(rngs, s, hand=hand, offset_s=off, label="weak_rotation")
    return replace(d, description=d.description + (
        ", a cart translating in a plane" if planar else ", a stage translating in 3-D")
        + f" that turns by only {hand.extent_deg:.1f} deg in all")


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


def _kind_inverted(rngs, s):
    d = _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="inverted")
    return replace(d, invert_b=True, description=d.description + ", file b holds "
                   "T_cam_target (inverted)")


def _kind_scalar_first(rngs, s):
    d = _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="scalar_first")
    which = "b" if rngs["seed"] % 2 == 0 else "a"       # seeds take turns
    return replace(d, scalar_first_a=which == "a", scalar_first_b=which == "b",
                   description=d.description + f", file {which} writes quaternions w first")


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


def _kind_stop_and_go(rngs, s):
    """a streams the whole session; b sees the target only while the hand stands still."""
    k = s.stations if s.stations is not None else int(rngs["rig"].integers(8, 20,
                                                                           endpoint=True))
    motion, duration, still = _stop_and_go_motion(rngs["motion"], k)
    d = _continuous(rngs, replace(s, duration_s=duration), offset_s=_small_offset(rngs, s),
                    hand=motion, label="stop_and_go")
    tau = d.t_b - d.offset_s - (d.t_ref_s - 0.5 * duration)     # b's instants on the motion
    seen = ((tau[:, None] >= still[None, :, 0]) & (tau[:, None] <= still[None, :, 1])).any(1)
    return replace(d, t_b=d.t_b[seen], B=d.B[seen], description=d.description
                   + f", {k} stops; b only while the hand stands still ({int(seen.sum())} "
                   "poses)")


def _kind_low_rate_camera(rngs, s):
    return _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="low_rate_camera")


#: which file writes its stamps in which unit, relative to its first stamp ("unix ...":
#: since the Unix epoch, :data:`UNIX_EPOCH_S` before the recording's clock), by seed % 8
_STAMP_UNIT_CYCLE = (("ms", "s"), ("s", "ms"), ("ms", "ms"), ("us", "s"), ("s", "ns"),
                     ("us", "us"), ("unix s", "s"), ("s", "unix s"))
UNIX_EPOCH_S = 1.765e9


def _kind_stamp_units(rngs, s):
    """continuous, an offset of +-0.2 s (30..100 ppm drift in odd seeds), one or both files
    stamped relative to their first pose in ms, us or ns, or one since the Unix epoch
    (:data:`_STAMP_UNIT_CYCLE`)."""
    r = rngs["events"]
    off = float(r.uniform(-0.2, 0.2)) if s.offset_s is None else float(s.offset_s)
    drift_ppm = float(r.choice([-1.0, 1.0]) * r.uniform(30.0, 100.0))
    drift_ppm = (drift_ppm if rngs["seed"] % 2 else 0.0) if s.drift_ppm is None \
        else float(s.drift_ppm)
    d = _continuous(rngs, s, offset_s=off, drift=1e-6 * drift_ppm, label="stamp_units")
    ua, ub = _STAMP_UNIT_CYCLE[rngs["seed"] % len(_STAMP_UNIT_CYCLE)]
    # the origin subtracted: the file's first pose, 0 (seconds as they are) or the epoch
    sa, sb = (-UNIX_EPOCH_S if u.startswith("unix") else float(t[0]) if u != "s" else 0.0
              for u, t in ((ua, d.t_a), (ub, d.t_b)))
    how = f"stamps of a in {ua}, of b in {ub}"
    return replace(d, t_a=d.t_a - sa, t_b=d.t_b - sb, offset_s=d.offset_s - sb + sa,
                   t_ref_s=d.t_ref_s - sa, stamps_unit_a=ua.split()[-1],
                   stamps_unit_b=ub.split()[-1], description=d.description + f", {how}")


def _with_scale(rngs, d):
    """``d`` with b's translations times a scale drawn log-uniformly in [1.1, 3] (odd seeds)
    or [0.3, 1 / 1.1] (even seeds): clearly off 1, on both sides (a scale within a few %
    of 1 is what ``scale_b=auto`` keeps, docs/calibrate.md)."""
    r = rngs["events"]
    hi = math.log(3.0) if rngs["seed"] % 2 else math.log(1.0 / 0.3)
    sign = 1.0 if rngs["seed"] % 2 else -1.0
    scale = math.exp(sign * r.uniform(math.log(1.1), hi))
    B = d.B.copy()
    B[:, :3, 3] *= scale
    return replace(d, B=B, scale_b=scale, description=d.description
                   + f", b's translations x {scale:.4g} (unknown scale)")


def _kind_scale(rngs, s):
    return _with_scale(rngs, _continuous(rngs, s, offset_s=_small_offset(rngs, s),
                                         label="scale"))


def _kind_scale_stations(rngs, s):
    return _with_scale(rngs, _stations_draft(rngs, s, (10, 40), "scale_stations"))


def _kind_no_motion_b(rngs, s):
    d = _continuous(rngs, s, label="no_motion_b")
    B = np.broadcast_to(d.B[0], d.B.shape).copy()
    B = _noisy(B, s.sigma_rot_b_deg, s.sigma_trans_b_m, rngs["events"], s.noise)
    return replace(d, B=B, description=d.description + ", b does not move (bad input)")


KINDS: dict[str, Kind] = {
    "stations": Kind(_kind_stations, "robot arm stopping at 10..40 stations, one pose per "
                     "station per stream (eye-in-hand); stamps: the station index in even "
                     "seeds, seconds apart in odd ones", False),
    "stations_short": Kind(_kind_stations_short, "the same with only 3..5 stations", False),
    "stations_two_clocks": Kind(_kind_stations_two_clocks, "stations (10..40) stamped by two "
                                "computers' clocks: b 0.5..10 s early or late, +-50 ms of "
                                "trigger jitter, no stamp shared", False, extra=("offset_s",)),
    "continuous": Kind(_kind_continuous, "smooth 6-DoF motion, a 100 Hz, b 30 Hz, stamp "
                       "jitter, dropped frames, offset exactly 0", True),
    "offset": Kind(_kind_offset, "continuous with a clock offset: +-0.2 s, tens of seconds "
                   "in seeds 2, 5, ...; 30..100 ppm drift in seeds 1, 4, ...", True,
                   extra=("offset_s", "drift_ppm")),
    "clock_drift": Kind(_kind_clock_drift, "continuous for 120 s, two free-running clocks "
                        "50..150 ppm apart (6..18 ms over the recording), offset +-0.2 s",
                        True, extra=("offset_s", "drift_ppm"), defaults={"duration_s": 120.0}),
    "outliers": Kind(_kind_outliers, "continuous with 5..20 % outlier poses in b and a 37 ms "
                     "offset", True, extra=("offset_s", "outlier_fraction")),
    "gaps": Kind(_kind_gaps, "continuous with one or two gaps of 1..3 s in one stream (b in "
                 "even seeds, a in odd ones), offset +-50 ms", True, extra=("offset_s",)),
    "robot_error": Kind(_kind_robot_error, "stations with systematic robot kinematic error "
                        "and distance-dependent camera error", False),
    "planar": Kind(_kind_planar, "vehicle driving in a plane (yaw only): X's vertical "
                   "translation undetermined; offset +-50 ms", True, "degenerate",
                   extra=("offset_s",)),
    "scara": Kind(_kind_scara, "4-DoF SCARA stations (vertical rotations, z on a grid)",
                  False, "degenerate"),
    "translation": Kind(_kind_translation, "a stage (3-D, even seeds) or a cart (in a plane, "
                        "odd seeds) that translates without rotating, offset +-50 ms: X's "
                        "translation undetermined", True, "degenerate", extra=("offset_s",)),
    "weak_rotation": Kind(_kind_weak_rotation, "a stage (3-D, even seeds) or a cart (in a "
                          "plane, odd seeds) translating ~0.1..0.3 m that turns by only 1..5 "
                          "deg in all, offset +-0.2 s", True, extra=("offset_s",)),
    "translation_bursts": Kind(_kind_translation_bursts, "a gantry stopping at 8..25 "
                               "stations without turning, a burst of 3..8 frames at each "
                               "(both streams): X's translation undetermined", False,
                               "degenerate"),
    "inverted": Kind(_kind_inverted, "continuous, file b written as T_sensor_world, offset "
                     "+-50 ms", True, extra=("offset_s",)),
    "scalar_first": Kind(_kind_scalar_first, "continuous, one file with the quaternion "
                         "scalar first (b in even seeds, a in odd ones), offset +-50 ms", True,
                         extra=("offset_s",)),
    "bursts": Kind(_kind_bursts, "robot arm stopping at 8..25 stations, a burst of 3..8 "
                   "frames at each (both streams), the camera's error mostly common to a "
                   "burst", False),
    "stop_and_go": Kind(_kind_stop_and_go, "a streamed at 100 Hz through 8..20 stops and the "
                        "moves between them, b (30 Hz) only while the hand stands still, "
                        "offset +-50 ms (it cannot show)", False,
                        extra=("offset_s", "rate_a_hz", "rate_b_hz", "drop_fraction",
                               "jitter_a_s", "jitter_b_s")),
    "low_rate_camera": Kind(_kind_low_rate_camera, "continuous, a 5 Hz camera with 0.5 deg / "
                            "5 mm noise, 20 % of both streams' frames dropped, 60 s, offset "
                            "+-50 ms (found to ~6 ms)", True, extra=("offset_s",),
                            defaults={"rate_b_hz": 5.0, "sigma_rot_b_deg": 0.5,
                                      "sigma_trans_b_m": 0.005, "duration_s": 60.0,
                                      "drop_fraction": 0.2}, offset_tol_ms=20.0),
    "stamp_units": Kind(_kind_stamp_units, "continuous, offset +-0.2 s (30..100 ppm drift in "
                        "odd seeds), one or both files stamped from their first pose in ms, us "
                        "or ns, or one since the Unix epoch (by seed: a ms, b ms, both ms, a "
                        "us, b ns, both us, a Unix s, b Unix s)", True,
                        extra=("offset_s", "drift_ppm")),
    "scale": Kind(_kind_scale, "continuous, b's translations in another scale (x 0.3..0.91 "
                  "in even seeds, x 1.1..3 in odd ones, log-uniform: a monocular SLAM track, a "
                  "wrong target size), offset +-50 ms", True, extra=("offset_s",)),
    "scale_stations": Kind(_kind_scale_stations, "stations (10..40) with b's translations in "
                           "another scale (as scale)", False),
    "no_motion_b": Kind(_kind_no_motion_b, "bad input: b does not move", True, "data_error"),
}


# -------------------------------------------------------------------------- generate
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
        scale_b=float(d.scale_b))


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
