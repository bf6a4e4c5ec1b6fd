"""The kinds of one smooth motion streamed by both sensors (a at 100 Hz, b at 30 Hz):
``continuous``, clock offsets and drift, outliers, gaps, a low-rate camera, a vehicle in
a plane, a stage or a cart that (nearly) only translates, and b that does not move.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from simcalib.geometry import (matrix_from_rotvec, random_rotation_matrices, rotvec_from_matrix,
                               transform_from_rotation_translation)
from simcalib.studies.experiments.recording_models import (R_FORWARD, _continuous,
                                                           _eval_sinusoids, _noisy, _rotvecs,
                                                           _rz, _sinusoids, _small_offset,
                                                           _unit)

__all__: list[str] = []


def _kind_continuous(rngs, s):
    return _continuous(rngs, s)


def _kind_offset(rngs, s):
    r = rngs["events"]
    large = rngs["seed"] % 3 == 2          # seeds 2, 5, 8, ...: tens of seconds
    off = (r.choice([-1.0, 1.0]) * r.uniform(10.0, 40.0)) if large else r.uniform(-0.2, 0.2)
    drift_ppm = (r.choice([-1.0, 1.0]) * r.uniform(30.0, 100.0)   # seeds 1, 4, 7, ...
                 if rngs["seed"] % 3 == 1 else 0.0)
    off = s.offset_s if s.offset_s is not None else float(off)
    drift_ppm = s.drift_ppm if s.drift_ppm is not None else float(drift_ppm)
    return _continuous(rngs, s, offset_s=off, drift=1e-6 * drift_ppm, label="offset")


def _kind_clock_step(rngs, s):
    """continuous, offset +-0.2 s, and b's clock stepping forward once by 0.3..2 s (an NTP
    correction, a logger restarted on another clock) at an instant 30..70 % of the way
    through. (Not back: b's stamps would then go back in the file, and the importer takes
    such a file for two recordings and keeps the longer.)"""
    r = rngs["events"]
    off = float(r.uniform(-0.2, 0.2)) if s.offset_s is None else float(s.offset_s)
    step = float(r.uniform(0.3, 2.0))
    where = float(r.uniform(0.3, 0.7))
    d = _continuous(rngs, s, offset_s=off, label="clock_step")
    at_a = float(d.t_a[0] + where * (d.t_a[-1] - d.t_a[0]))
    after = d.t_b - off >= at_a
    return replace(d, t_b=np.where(after, d.t_b + step, d.t_b), t_ref_s=float(d.t_a[0]),
                   step_s=step, step_at_s=float(d.t_b[np.argmax(after)] - off),
                   description=d.description + f", b's clock stepping {step:+.3f} s at "
                   f"{at_a - d.t_a[0]:.1f} s")


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


def _kind_low_rate_camera(rngs, s):
    return _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="low_rate_camera")


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


def _kind_no_motion_b(rngs, s):
    d = _continuous(rngs, s, label="no_motion_b")
    B = np.broadcast_to(d.B[0], d.B.shape).copy()
    B = _noisy(B, s.sigma_rot_b_deg, s.sigma_trans_b_m, rngs["events"], s.noise)
    return replace(d, B=B, description=d.description + ", b does not move (bad input)")
