"""Benchmark recordings of many kinds (recordings `calibrate` has
never seen), and the comparison of the ``calibrate`` defaults with a classic solver on them.

    from simcalib.studies.experiments.recordings import KINDS, generate, write_tum
    rec = generate("outliers", seed=3)            # a Recording: both streams + the truth
    write_tum(rec, "out/rec")                     # a.txt, b.txt, truth.json
    python -m simcalib.studies.experiments.recordings --kinds stations offset --seeds 5 \\
        --output docs/recordings.md
    python -m simcalib experiment recordings kinds=[stations,offset] seeds=5

Every recording is a rigid pair of sensors: ``a`` a robot hand (``T_base_hand``) or a
vehicle (``T_odom_vehicle``), ``b`` a camera in its own world (``T_target_cam`` or a SLAM
world), ``X = T_a_b``, so ``T_wa_a X = Y T_wb_b`` with a fixed ``Y = T_wa_wb`` and
``C X = X H`` for every motion. The streams are given in the FILE's form: possibly
inverted (``T_sensor_world``) or with the quaternion written scalar-first; the
:class:`Recording` says which reading is correct, the true clock offset ``t_b - t_a`` (and
drift), and which poses are outliers. Every random draw comes from
``np.random.default_rng`` children of ``np.random.SeedSequence(seed)``: the same kind and
seed give the same arrays.

The comparison (:func:`evaluate`, :func:`main`): the ``calibrate`` COMMAND with its
defaults on the TUM files (offset estimated, reading detected, RANSAC), against OpenCV's
Park solver (``cv2.calibrateHandEye(..., CALIB_HAND_EYE_PARK)``) given the TRUE offset and
the TRUE reading on the synchronised poses (continuous kinds: b interpolated at a's
shifted stamps, subsampled to at most :data:`PARK_MAX_POSES` poses; all i<j pairs).
Park gets no outlier rejection.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import sys
import tempfile
import time
import zlib
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Callable

import numpy as np

from simcalib.geometry import (invert_transform, matrix_from_quat, matrix_from_rotvec,
                               perturb_transforms, quat_from_matrix, random_rotation_matrices,
                               rotation_error_rad, rotvec_from_matrix,
                               transform_from_rotation_translation)
from simcalib.importers import PoseStreamData, stream_from_arrays
from simcalib.studies.experiments import experiment

__all__ = ["Recording", "Settings", "Kind", "KINDS", "generate", "write_tum", "read_truth",
           "Outcome", "evaluate", "park_baseline", "true_streams", "motion_outliers",
           "summarise", "markdown", "synchronised_truth", "acceptance_failures",
           "translation_error_determined", "run_all", "RecordingsConfig", "run", "main",
           "PARK_MAX_POSES"]

PARK_MAX_POSES = 60
#: acceptance (tests/test_studies_experiments_recordings.py): errors <= max(PARK_FACTOR x Park's, floor), the
#: offset within OFFSET_TOL_MS where the data determine it, outlier motions rejected
PARK_FACTOR = 1.5
ROT_FLOOR_DEG = 0.05
TRANS_FLOOR_MM = 0.5
OFFSET_TOL_MS = 3.0
MIN_PRECISION = 0.95
MIN_RECALL = 0.5
#: hand orientation looking straight down (camera towards the table): Rx(pi)
R_DOWN = np.diag([1.0, -1.0, -1.0])
#: centre of the hand's workspace in the robot base frame (m)
WORKSPACE_CENTRE = np.array([0.5, 0.0, 0.45])
#: camera axes (x right, y down, z forward) in a vehicle frame (x forward, y left, z up)
R_FORWARD = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
_RNG_STREAMS = ("rig", "motion", "noise_a", "noise_b", "clock", "events")


# ----------------------------------------------------------------------------- truth
@dataclass(frozen=True, eq=False)
class Recording:
    """A generated recording and its truth.

    ``stream_a`` / ``stream_b``: :class:`PoseStreamData` as the FILES hold them;
    ``X_true``: ``T_a_b``; ``offset_s``: the true clock offset ``t_b - t_a`` at clock-a time
    ``t_ref_s`` with ``drift`` (s/s): ``offset(t_a) = offset_s + drift (t_a - t_ref_s)``;
    ``invert_a`` / ``invert_b``: the file holds ``T_sensor_world``; ``scalar_first_a`` /
    ``_b``: the file's quaternion is written ``(w, x, y, z)``; ``outliers_a`` /
    ``outliers_b``: bool per pose of each stream; ``offset_determined``: the data determine
    the offset (continuous motion); ``expect``: ``determined``, ``degenerate`` (then
    ``undetermined_a``, a unit vector in frame a, is the direction of X's translation the
    motion cannot determine) or ``data_error`` (the calibration must refuse it).
    """
    kind: str
    seed: int
    stream_a: PoseStreamData
    stream_b: PoseStreamData
    X_true: np.ndarray
    offset_s: float
    drift: float
    t_ref_s: float
    invert_a: bool
    invert_b: bool
    scalar_first_a: bool
    scalar_first_b: bool
    outliers_a: np.ndarray
    outliers_b: np.ndarray
    description: str
    offset_determined: bool
    expect: str
    undetermined_a: np.ndarray | None = None

    def offset_at(self, t_a) -> np.ndarray:
        """The true offset ``t_b - t_a`` at clock-a times ``t_a``."""
        return self.offset_s + self.drift * (np.asarray(t_a, dtype=np.float64) - self.t_ref_s)

    def truth_dict(self) -> dict:
        """The truth as JSON-ready values (``truth.json``)."""
        return {"kind": self.kind, "seed": self.seed, "description": self.description,
                "X_true": self.X_true.tolist(), "offset_s": self.offset_s,
                "drift": self.drift, "t_ref_s": self.t_ref_s,
                "offset_convention": "offset(t_a) = offset_s + drift (t_a - t_ref_s) = t_b - t_a",
                "invert_a": self.invert_a, "invert_b": self.invert_b,
                "scalar_first_a": self.scalar_first_a, "scalar_first_b": self.scalar_first_b,
                "outliers_a": np.flatnonzero(self.outliers_a).tolist(),
                "outliers_b": np.flatnonzero(self.outliers_b).tolist(),
                "offset_determined": self.offset_determined, "expect": self.expect,
                "undetermined_a": None if self.undetermined_a is None
                else self.undetermined_a.tolist()}


@dataclass(frozen=True)
class Settings:
    """What ``generate(kind, seed, **overrides)`` may change (None: the kind's own draw).

    ``noise=False``: no pose noise, stamp jitter or systematic (robot / camera) error; the
    outlier poses stay (they are masked in the truth)."""
    noise: bool = True
    duration_s: float = 20.0
    rate_a_hz: float = 100.0
    rate_b_hz: float = 30.0
    drop_fraction: float = 0.02
    stations: int | None = None
    offset_s: float | None = None
    drift_ppm: float | None = None
    outlier_fraction: float | None = None
    sigma_rot_a_deg: float = 0.02
    sigma_trans_a_m: float = 0.0002
    sigma_rot_b_deg: float = 0.1
    sigma_trans_b_m: float = 0.001
    jitter_a_s: float = 0.0002
    jitter_b_s: float = 0.001

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "noise":
                if not isinstance(v, bool):
                    raise ValueError(f"noise must be true or false; received {v!r}")
                continue
            if v is None and f.default is None:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{f.name} must be a finite number; received {v!r}")
        if self.duration_s < 5.0 or self.rate_a_hz <= 0 or self.rate_b_hz <= 0:
            raise ValueError(f"duration_s must be >= 5 and the rates > 0; received "
                             f"{self.duration_s}, {self.rate_a_hz}, {self.rate_b_hz}")
        if not 0.0 <= self.drop_fraction < 0.5:
            raise ValueError(f"drop_fraction must be in [0, 0.5); received {self.drop_fraction}")
        if self.stations is not None and (not isinstance(self.stations, int)
                                          or self.stations < 3):
            raise ValueError(f"stations must be an integer >= 3; received {self.stations!r}")
        if self.outlier_fraction is not None and not 0.0 <= self.outlier_fraction < 0.5:
            raise ValueError(f"outlier_fraction must be in [0, 0.5); received "
                             f"{self.outlier_fraction}")
        for name in ("sigma_rot_a_deg", "sigma_trans_a_m", "sigma_rot_b_deg",
                     "sigma_trans_b_m", "jitter_a_s", "jitter_b_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0; received {getattr(self, name)}")


@dataclass(frozen=True, eq=False)
class _Draft:
    """What a kind function produces: true-reading stamps and poses of both streams (clock
    a / clock b), X, the clock model and the file form."""
    t_a: np.ndarray
    A: np.ndarray
    t_b: np.ndarray
    B: np.ndarray
    X: np.ndarray
    description: str
    offset_s: float = 0.0
    drift: float = 0.0
    t_ref_s: float = 0.0
    outliers_a: np.ndarray | None = None
    outliers_b: np.ndarray | None = None
    invert_a: bool = False
    invert_b: bool = False
    scalar_first_a: bool = False
    scalar_first_b: bool = False
    undetermined_a: np.ndarray | None = None


@dataclass(frozen=True)
class Kind:
    """A registered kind: ``make(rngs, settings) -> _Draft``, one line of description,
    whether the data determine the clock offset, and what the calibration should do."""
    make: Callable
    description: str
    offset_determined: bool
    expect: str = "determined"
    extra: tuple = ()           # kind-specific Settings it reads (offset_s, ...)

    @property
    def settings(self) -> tuple:
        """The :class:`Settings` fields this kind reads (the overrides it accepts)."""
        return _COMMON_SETTINGS + (_CONTINUOUS_SETTINGS if self.offset_determined
                                   else ("stations",)) + self.extra


_COMMON_SETTINGS = ("noise", "sigma_rot_a_deg", "sigma_trans_a_m", "sigma_rot_b_deg",
                    "sigma_trans_b_m")
_CONTINUOUS_SETTINGS = ("duration_s", "rate_a_hz", "rate_b_hz", "drop_fraction",
                        "jitter_a_s", "jitter_b_s")


# --------------------------------------------------------------------- small helpers
def _rngs(seed: int, kind: str) -> dict:
    """Independent Generators per purpose: children of ``SeedSequence([seed, crc32(kind)])``
    (every kind draws its own rig and motion for a seed)."""
    children = np.random.SeedSequence([seed, zlib.crc32(kind.encode())]).spawn(
        len(_RNG_STREAMS))
    out = {name: np.random.default_rng(s) for name, s in zip(_RNG_STREAMS, children)}
    out["seed"] = seed      # for kinds whose seeds take turns (which file, ...)
    return out


def _unit(rng, n) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _rotvecs(rng, n, lo_deg, hi_deg) -> np.ndarray:
    """``n`` rotation vectors about uniform axes by angles uniform in [lo, hi] degrees."""
    return _unit(rng, n) * np.radians(rng.uniform(lo_deg, hi_deg, n))[:, None]


def _rz(angle) -> np.ndarray:
    a = np.asarray(angle, dtype=np.float64)
    return matrix_from_rotvec(np.stack([np.zeros_like(a), np.zeros_like(a), a], axis=-1))


def _sinusoids(rng, amp_lo, amp_hi, f_lo, f_hi, dims=3, terms=3):
    return (rng.uniform(amp_lo, amp_hi, (terms, dims)), rng.uniform(f_lo, f_hi, (terms, dims)),
            rng.uniform(0.0, 2 * np.pi, (terms, dims)))


def _eval_sinusoids(params, tau) -> np.ndarray:
    amp, f, ph = params
    return np.einsum("kd,nkd->nd", amp,
                     np.sin(2 * np.pi * f[None] * tau[:, None, None] + ph[None]))


def _hand_camera_rig(rng) -> tuple[np.ndarray, np.ndarray]:
    """``X = T_hand_cam`` (3..12 cm off the flange, looking roughly along the hand's z) and
    ``Y = T_base_target`` (a target on the table under the arm)."""
    X = transform_from_rotation_translation(
        matrix_from_rotvec(_rotvecs(rng, 1, 0, 30)[0]) @ _rz(rng.uniform(-np.pi, np.pi)),
        _unit(rng, 1)[0] * rng.uniform(0.03, 0.12))
    Y = transform_from_rotation_translation(
        _rz(rng.uniform(-np.pi, np.pi)) @ matrix_from_rotvec(_rotvecs(rng, 1, 0, 5)[0]),
        np.array([0.5, 0.0, 0.0]) + rng.uniform(-0.05, 0.05, 3))
    return X, Y


def _camera_poses(A, X, Y) -> np.ndarray:
    """``T_wb_b = Y^-1 T_wa_a X`` for every hand pose."""
    return invert_transform(Y)[None] @ A @ X[None]


def _sample_instants(rng, rate_hz, duration_s, drop) -> np.ndarray:
    """True sampling instants (s from the start): a random phase, ``rate_hz``, a fraction
    ``drop`` of frames dropped (never the first or last)."""
    tau = rng.uniform(0.0, 1.0 / rate_hz) + np.arange(int(duration_s * rate_hz)) / rate_hz
    keep = rng.random(tau.size) >= drop
    keep[[0, -1]] = True
    return tau[keep]


def _jitter(rng, n, sigma) -> np.ndarray:
    return rng.normal(0.0, sigma, n) if sigma > 0 else np.zeros(n)


def _noisy(T, sigma_rot_deg, sigma_trans_m, rng, on: bool) -> np.ndarray:
    return perturb_transforms(T, math.radians(sigma_rot_deg), sigma_trans_m, rng) if on else T


# ----------------------------------------------------------------------- motion models
def _station_poses(rng, k) -> np.ndarray:
    """``k`` hand poses over a 0.5 m workspace, rotated 10..60 deg from looking down."""
    p = WORKSPACE_CENTRE + rng.uniform(-0.25, 0.25, (k, 3))
    R = R_DOWN[None] @ matrix_from_rotvec(_rotvecs(rng, k, 10, 60))
    return transform_from_rotation_translation(R, p)


def _station_stamps(rng, k, seed) -> tuple[np.ndarray, str]:
    """Even seeds: the station index (0, 1, 2, ...); odd seeds: real stamps 2..6 s apart."""
    if seed % 2 == 0:
        return np.arange(k, dtype=np.float64), "stamps = station index"
    return 1000.0 + np.cumsum(rng.uniform(2.0, 6.0, k)), "stamps 2..6 s apart"


def _smooth_hand_motion(rng) -> Callable:
    """``tau -> T_base_hand(tau)``: a sum of sinusoids in position (~0.2 m) and rotation
    vector (~20 deg per axis) about the looking-down orientation."""
    pos = _sinusoids(rng, 0.03, 0.08, 0.03, 0.25)
    rot = _sinusoids(rng, 0.1, 0.22, 0.03, 0.25)

    def poses(tau):
        R = R_DOWN[None] @ matrix_from_rotvec(_eval_sinusoids(rot, tau))
        return transform_from_rotation_translation(R, WORKSPACE_CENTRE + _eval_sinusoids(pos, tau))
    return poses


@dataclass(frozen=True, eq=False)
class _Clock:
    """Clock b against clock a: ``t_b = t_a + offset_s + drift (t_a - t_ref_s)``."""
    t0: float
    offset_s: float
    drift: float
    t_ref_s: float


def _continuous(rngs, s: Settings, *, offset_s=0.0, drift=0.0, hand=None, rig=None,
                label="continuous") -> _Draft:
    """a at ``rate_a_hz``, b at ``rate_b_hz`` on one smooth motion, stamp jitter, dropped
    frames, b's clock ``offset_s`` (+ drift) ahead."""
    clock_rng = rngs["clock"]
    X, Y = rig if rig is not None else _hand_camera_rig(rngs["rig"])
    motion = hand if hand is not None else _smooth_hand_motion(rngs["motion"])
    t0 = 1000.0 + clock_rng.uniform(0.0, 100.0)
    clock = _Clock(t0, offset_s, drift, t0 + 0.5 * s.duration_s)
    tau_a = _sample_instants(clock_rng, s.rate_a_hz, s.duration_s, s.drop_fraction)
    tau_b = _sample_instants(clock_rng, s.rate_b_hz, s.duration_s, s.drop_fraction)
    A = motion(tau_a)
    B = _camera_poses(motion(tau_b), X, Y)
    t_a = t0 + tau_a + _jitter(clock_rng, tau_a.size, s.jitter_a_s * s.noise)
    ta_true_b = t0 + tau_b
    t_b = (ta_true_b + clock.offset_s + clock.drift * (ta_true_b - clock.t_ref_s)
           + _jitter(clock_rng, tau_b.size, s.jitter_b_s * s.noise))
    A = _noisy(A, s.sigma_rot_a_deg, s.sigma_trans_a_m, rngs["noise_a"], s.noise)
    B = _noisy(B, s.sigma_rot_b_deg, s.sigma_trans_b_m, rngs["noise_b"], s.noise)
    desc = (f"{label}: a {s.rate_a_hz:g} Hz ({t_a.size} poses), b {s.rate_b_hz:g} Hz "
            f"({t_b.size}), {s.duration_s:g} s, offset {1e3 * offset_s:.1f} ms"
            + (f", drift {1e6 * drift:.0f} ppm" if drift else ""))
    return _Draft(t_a, A, t_b, B, X, desc, offset_s, drift, clock.t_ref_s)


def _stations_draft(rngs, s: Settings, k_range, label, poses=None) -> _Draft:
    rig_rng = rngs["rig"]
    k = s.stations if s.stations is not None else int(rig_rng.integers(*k_range,
                                                                      endpoint=True))
    X, Y = _hand_camera_rig(rig_rng)
    A = poses(rngs["motion"], k) if poses is not None else _station_poses(rngs["motion"], k)
    t, how = _station_stamps(rngs["clock"], k, rngs["seed"])
    B = _noisy(_camera_poses(A, X, Y), s.sigma_rot_b_deg, s.sigma_trans_b_m,
               rngs["noise_b"], s.noise)
    A = _noisy(A, s.sigma_rot_a_deg, s.sigma_trans_a_m, rngs["noise_a"], s.noise)
    return _Draft(t, A, t.copy(), B, X, f"{label}: {k} stations, {how}, eye-in-hand "
                  "(b = T_target_cam)", 0.0, 0.0, float(t[0]))


# --------------------------------------------------------------------------- the kinds
def _kind_stations(rngs, s):
    return _stations_draft(rngs, s, (10, 40), "stations")


def _kind_stations_short(rngs, s):
    return _stations_draft(rngs, s, (3, 5), "stations_short")


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


def _robot_error(rng, A, on: bool) -> np.ndarray:
    """A systematic, pose-dependent kinematic error: three random low-order (sinusoidal)
    functions of the pose (position and rotation vector) with an rms of 0.1..0.5 deg /
    1..3 mm over the workspace, applied in the hand frame (correlated between nearby poses,
    not white)."""
    f = np.concatenate([(A[:, :3, 3] - WORKSPACE_CENTRE) / 0.25,
                        rotvec_from_matrix(R_DOWN.T[None] @ A[:, :3, :3])], axis=1)
    w = rng.normal(0.0, 1.0, (3, 6))
    ph = rng.uniform(0.0, 2 * np.pi, 3)
    basis = np.sin(f @ w.T + ph)                                   # (N, 3)
    # each sin term has mean square ~1/2, three terms along unit vectors: rms ~ amp
    amp_r = math.radians(rng.uniform(0.1, 0.5)) / math.sqrt(1.5)
    amp_t = rng.uniform(0.001, 0.003) / math.sqrt(1.5)
    e_r = basis @ (_unit(rng, 3) * amp_r)
    e_t = basis @ (_unit(rng, 3) * amp_t)
    if not on:
        return A
    return A @ transform_from_rotation_translation(matrix_from_rotvec(e_r), e_t)


def _camera_error(rng, B, on: bool, sigma_rot_deg: float, sigma_trans_m: float
                  ) -> np.ndarray:
    """Camera poses (``T_target_cam``) with errors that grow with the viewing distance d:
    a depth-scale bias of 0.2..0.8 % x (d / 0.5 m) along the line of sight and noise of
    sigma (default 0.1 deg / 1 mm) x (d / 0.5 m)^2."""
    T_cam_target = invert_transform(B)
    p = T_cam_target[:, :3, 3]
    d = np.linalg.norm(p, axis=1)
    bias = rng.uniform(0.002, 0.008)
    scale = (d / 0.5)[:, None]
    n = B.shape[0]
    rot = _unit(rng, n) * (rng.normal(0.0, math.radians(sigma_rot_deg), n)
                           * (d / 0.5) ** 2)[:, None]
    dt = rng.normal(0.0, sigma_trans_m, (n, 3)) * (scale ** 2)
    if not on:
        return B
    T_cam_target = T_cam_target.copy()
    T_cam_target[:, :3, 3] = p * (1.0 + bias * scale)
    return invert_transform(T_cam_target) @ transform_from_rotation_translation(
        matrix_from_rotvec(rot), dt)


def _kind_robot_error(rngs, s):
    clean = replace(s, sigma_rot_b_deg=0.0, sigma_trans_b_m=0.0)
    d = _stations_draft(rngs, clean, (10, 40), "robot_error")
    r = rngs["events"]
    A = _robot_error(r, d.A, s.noise)
    B = _camera_error(r, d.B, s.noise, s.sigma_rot_b_deg, s.sigma_trans_b_m)
    return replace(d, A=A, B=B, description=d.description + ", systematic pose-dependent "
                   "robot error (rms 0.1..0.5 deg / 1..3 mm), distance-dependent camera error")


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


def _kind_inverted(rngs, s):
    d = _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="inverted")
    return replace(d, invert_b=True, description=d.description + ", file b holds "
                   "T_cam_target (inverted)")


def _kind_scalar_first(rngs, s):
    d = _continuous(rngs, s, offset_s=_small_offset(rngs, s), label="scalar_first")
    which = "b" if rngs["seed"] % 2 == 0 else "a"       # seeds take turns
    return replace(d, scalar_first_a=which == "a", scalar_first_b=which == "b",
                   description=d.description + f", file {which} writes quaternions w first")


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
    "continuous": Kind(_kind_continuous, "smooth 6-DoF motion, a 100 Hz, b 30 Hz, stamp "
                       "jitter, dropped frames, offset exactly 0", True),
    "offset": Kind(_kind_offset, "continuous with a clock offset: +-0.2 s, tens of seconds "
                   "in seeds 2, 5, ...; 30..100 ppm drift in seeds 1, 4, ...", True,
                   extra=("offset_s", "drift_ppm")),
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
    "inverted": Kind(_kind_inverted, "continuous, file b written as T_sensor_world, offset "
                     "+-50 ms", True, extra=("offset_s",)),
    "scalar_first": Kind(_kind_scalar_first, "continuous, one file with the quaternion "
                         "scalar first (b in even seeds, a in odd ones), offset +-50 ms", True,
                         extra=("offset_s",)),
    "no_motion_b": Kind(_kind_no_motion_b, "bad input: b does not move", True, "data_error"),
}


# -------------------------------------------------------------------------- generate
def _file_stream(t, T, invert: bool, scalar_first: bool, name: str) -> PoseStreamData:
    """The stream as a file holds it: ``T_sensor_world`` when ``invert``; with
    ``scalar_first`` the quaternion numbers ``(w, x, y, z)`` in the places a TUM reader
    takes for ``(x, y, z, w)``."""
    if invert:
        T = invert_transform(T)
    if scalar_first:
        q = quat_from_matrix(T[:, :3, :3])
        T = transform_from_rotation_translation(
            matrix_from_quat(np.concatenate([q[:, 3:], q[:, :3]], axis=1)), T[:, :3, 3])
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
    d = spec.make(_rngs(int(seed), kind), Settings(**overrides))
    na, nb = d.t_a.size, d.t_b.size
    oa = d.outliers_a if d.outliers_a is not None else np.zeros(na, dtype=bool)
    ob = d.outliers_b if d.outliers_b is not None else np.zeros(nb, dtype=bool)
    return Recording(
        kind=kind, seed=int(seed),
        stream_a=_file_stream(d.t_a, d.A, d.invert_a, d.scalar_first_a, "a"),
        stream_b=_file_stream(d.t_b, d.B, d.invert_b, d.scalar_first_b, "b"),
        X_true=_frozen(d.X), offset_s=float(d.offset_s), drift=float(d.drift),
        t_ref_s=float(d.t_ref_s), invert_a=d.invert_a, invert_b=d.invert_b,
        scalar_first_a=d.scalar_first_a, scalar_first_b=d.scalar_first_b,
        outliers_a=_frozen(oa), outliers_b=_frozen(ob), description=d.description,
        offset_determined=spec.offset_determined, expect=spec.expect,
        undetermined_a=None if d.undetermined_a is None else _frozen(
            d.undetermined_a / np.linalg.norm(d.undetermined_a)))


def true_streams(rec: Recording) -> tuple[PoseStreamData, PoseStreamData]:
    """Both streams read the TRUE way (``T_world_sensor``, quaternion order fixed), in the
    order simcalib.estimation.readings applies a reading (swap, then invert)."""
    out = []
    for s, inv, sf in ((rec.stream_a, rec.invert_a, rec.scalar_first_a),
                       (rec.stream_b, rec.invert_b, rec.scalar_first_b)):
        if sf:
            s = s.with_swapped_scalar()
        if inv:
            s = s.with_inverse()
        out.append(s)
    return out[0], out[1]


# ------------------------------------------------------------------------- TUM files
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


# -------------------------------------------------------------------------- baseline
def synchronised_truth(rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True-reading poses ``(T_a, T_b, clean)`` of a and b at common instants: station
    kinds pair by stamp; continuous kinds interpolate b at a's stamps shifted by the TRUE
    offset (:func:`simcalib.estimation.alignment.interpolate_poses`, not across gaps). ``clean``: the
    instant uses no outlier pose."""
    from simcalib.estimation.alignment import interpolate_poses
    sa, sb = true_streams(rec)
    ta, Ta, tb, Tb = sa.timestamps_s, sa.T_world_sensor, sb.timestamps_s, sb.T_world_sensor
    if ta.shape == tb.shape and np.array_equal(ta, tb):
        return Ta, Tb, ~(rec.outliers_a | rec.outliers_b)
    gap = 2.5 * float(np.median(np.diff(tb)))
    tq = ta + rec.offset_at(ta)
    Tb_at_a, valid = interpolate_poses(tb, Tb, tq, gap)
    clean = ~(rec.outliers_a | _contaminated(tq, tb, rec.outliers_b))
    return Ta[valid], Tb_at_a[valid], clean[valid]


def park_baseline(rec: Recording, oracle_inliers: bool = False) -> np.ndarray:
    """OpenCV PARK (``cv2.calibrateHandEye``) given the true offset and reading, on at most
    :data:`PARK_MAX_POSES` synchronised poses (evenly subsampled; all i<j pairs). No outlier
    rejection, unless ``oracle_inliers``: then only the instants that use no outlier pose
    (the TRUE masks; for reference only). Returns ``X = T_a_b``."""
    import cv2
    if not hasattr(cv2, "calibrateHandEye"):
        raise RuntimeError(f"OpenCV {cv2.__version__} has no calibrateHandEye; install "
                           "opencv-python-headless>=4.10,<5")
    Ta, Tb, clean = synchronised_truth(rec)
    if oracle_inliers:
        Ta, Tb = Ta[clean], Tb[clean]
    if Ta.shape[0] < 3:
        raise ValueError(f"only {Ta.shape[0]} synchronised poses for Park")
    idx = np.unique(np.round(np.linspace(0, Ta.shape[0] - 1,
                                         min(PARK_MAX_POSES, Ta.shape[0]))).astype(int))
    Ta, Tb_inv = Ta[idx], invert_transform(Tb[idx])     # gripper2base, target2cam
    R, t = cv2.calibrateHandEye(list(Ta[:, :3, :3]), list(Ta[:, :3, 3:]),
                                list(Tb_inv[:, :3, :3]), list(Tb_inv[:, :3, 3:]),
                                method=cv2.CALIB_HAND_EYE_PARK)
    return transform_from_rotation_translation(np.asarray(R), np.asarray(t).reshape(3))


# -------------------------------------------------------------------------- evaluate
def translation_error_determined(X, rec: Recording) -> float:
    """Translation error (m), without the component along ``rec.undetermined_a``."""
    d = np.asarray(X)[:3, 3] - rec.X_true[:3, 3]
    if rec.undetermined_a is not None:
        d = d - (d @ rec.undetermined_a) * rec.undetermined_a
    return float(np.linalg.norm(d))


def _contaminated(t_query, t_stream, bad) -> np.ndarray:
    """Instants whose pose of a stream uses an outlier sample (the sample itself, or one
    of the two that bracket the instant when it is interpolated)."""
    if not bad.any():
        return np.zeros(t_query.shape, dtype=bool)
    k = np.clip(np.searchsorted(t_stream, t_query), 0, t_stream.size - 1)
    exact = np.abs(t_stream[k] - t_query) < 1e-6
    prev = np.clip(k - 1, 0, t_stream.size - 1)
    exact_prev = np.abs(t_stream[prev] - t_query) < 1e-6
    return np.where(exact, bad[k], np.where(exact_prev, bad[prev], bad[k] | bad[prev]))


def motion_outliers(rec: Recording, synced_time_s, index_start, index_end, offset_s,
                    drift=0.0, t_ref_s=0.0) -> np.ndarray:
    """Bool per motion: the motion (synchronised instants ``index_start`` -> ``index_end``
    at clock-a times ``synced_time_s``, synchronised with the given offset model) touches
    an outlier pose of either stream."""
    t = np.asarray(synced_time_s, dtype=np.float64)
    tb = t + offset_s + drift * (t - t_ref_s)
    bad = (_contaminated(t, rec.stream_a.timestamps_s, rec.outliers_a)
           | _contaminated(tb, rec.stream_b.timestamps_s, rec.outliers_b))
    return bad[np.asarray(index_start)] | bad[np.asarray(index_end)]


@dataclass(frozen=True)
class Outcome:
    """One calibration of one recording by the ``calibrate`` command (defaults) and the
    Park baseline (``park_oracle_*``: Park on the outlier-free instants, for kinds with
    outliers; a reference only). Errors in degrees / millimetres (translation without the
    undetermined direction, if any); NaN where there is no estimate. ``reading_ok``: the
    detected reading (invert, scalar order of both files) is the true one (None without a
    calibration);
    ``offset_error_ms``: estimated minus true offset at the recording's ``t_ref_s`` (NaN
    when the data do not determine the offset); ``precision`` / ``recall``: of the
    calibration's inlier motions against the motions that touch no outlier pose;
    ``undetermined_dirs_a``: the translation directions (frame a) the calibration reported
    as undetermined / poorly determined, ``undetermined_flagged``: one of them is within
    25 deg of the recording's undetermined direction; ``message``: the command's error line."""
    kind: str
    seed: int
    exit_code: int
    runtime_s: float
    rot_error_deg: float = math.nan
    trans_error_mm: float = math.nan
    park_rot_error_deg: float = math.nan
    park_trans_error_mm: float = math.nan
    park_oracle_rot_error_deg: float = math.nan
    park_oracle_trans_error_mm: float = math.nan
    offset_error_ms: float = math.nan
    reading_ok: bool | None = None
    precision: float = math.nan
    recall: float = math.nan
    undetermined_dirs_a: tuple = ()
    undetermined_flagged: bool = False
    message: str = ""


def _run_cli(paths: dict, out: Path) -> tuple[int, str]:
    from simcalib.cli import main as cli_main
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = cli_main(["calibrate", f"a={paths['a']}", f"b={paths['b']}",
                         f"output={out}", "recording=false", "overwrite=true"])
    lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error:" in ln] or lines
    return int(code), (errors[-1].replace(str(out.parent), "<dir>") if errors else "")


def _inlier_scores(rec, report, motions) -> tuple[float, float]:
    off = report["time_offset"]
    bad = motion_outliers(rec, motions["synced_time_s"], motions["index_start"],
                          motions["index_end"], off["offset_s"], off["drift"] or 0.0,
                          off["t_ref_s"] or 0.0)
    inl = np.asarray(motions["inlier"], dtype=bool)
    good = ~bad
    precision = float((inl & good).sum() / inl.sum()) if inl.any() else math.nan
    recall = float((inl & good).sum() / good.sum()) if good.any() else math.nan
    return precision, recall


def _reported_directions(report) -> tuple:
    unc = (report.get("solution") or {}).get("uncertainty") or {}
    return tuple(tuple(d["translation_dir_a"]) for d in unc.get("directions", [])
                 if any(abs(x) > 0 for x in d["translation_dir_a"]))


def _park_errors(rec: Recording, oracle_inliers: bool) -> tuple[float, float]:
    """(rotation deg, translation mm) errors of :func:`park_baseline`; NaN for bad-input
    kinds or when OpenCV fails."""
    if rec.expect == "data_error":
        return math.nan, math.nan
    try:
        X = park_baseline(rec, oracle_inliers)
    except Exception:       # noqa: BLE001 - a failed baseline is reported as NaN
        return math.nan, math.nan
    return (math.degrees(float(rotation_error_rad(X, rec.X_true))),
            1e3 * translation_error_determined(X, rec))


def evaluate(rec: Recording, workdir) -> Outcome:
    """Write ``rec`` as TUM files into ``workdir``, calibrate them with the ``calibrate``
    COMMAND (its defaults; ``recording=false``) and compare with the truth and with
    :func:`park_baseline`."""
    work = Path(workdir)
    paths = write_tum(rec, work)
    park_err = _park_errors(rec, False)
    oracle = (_park_errors(rec, True) if rec.outliers_a.any() or rec.outliers_b.any()
              else (math.nan, math.nan))
    t0 = time.perf_counter()
    code, message = _run_cli(paths, work / "out")
    runtime = time.perf_counter() - t0
    base = Outcome(rec.kind, rec.seed, code, runtime, park_rot_error_deg=park_err[0],
                   park_trans_error_mm=park_err[1], park_oracle_rot_error_deg=oracle[0],
                   park_oracle_trans_error_mm=oracle[1], message=message)
    cal = work / "out" / "calibration.json"
    if code not in (0, 5, 6) or not cal.is_file():
        return base
    report = json.loads(cal.read_text())
    with np.load(work / "out" / "motions.npz") as z:
        motions = {k: z[k] for k in z.files}
    X = np.asarray(report["X"]["T_a_b"])
    conv, off = report["conventions"], report["time_offset"]
    reading_ok = (conv["invert_a"] == rec.invert_a and conv["invert_b"] == rec.invert_b
                  and conv["swap_scalar_a"] == rec.scalar_first_a
                  and conv["swap_scalar_b"] == rec.scalar_first_b)
    off_err = math.nan
    if rec.offset_determined:
        est = off["offset_s"] + (off["drift"] or 0.0) * (rec.t_ref_s - (off["t_ref_s"] or 0.0))
        off_err = 1e3 * (est - float(rec.offset_at(rec.t_ref_s)))
    precision, recall = _inlier_scores(rec, report, motions)
    dirs = _reported_directions(report)
    return replace(base, rot_error_deg=math.degrees(float(rotation_error_rad(X, rec.X_true))),
                   trans_error_mm=1e3 * translation_error_determined(X, rec),
                   offset_error_ms=off_err, reading_ok=bool(reading_ok),
                   precision=precision, recall=recall, undetermined_dirs_a=dirs,
                   undetermined_flagged=rec.undetermined_a is not None and any(
                       abs(float(np.dot(d, rec.undetermined_a))) > 0.9 for d in dirs))


# ----------------------------------------------------------------------------- table
def _failure_counts(outcomes) -> str:
    counts: dict = {}
    for o in outcomes:
        for f in acceptance_failures(o):
            counts[f] = counts.get(f, 0) + 1
    return ", ".join(f"{k} {v}/{len(outcomes)}" for k, v in counts.items()) or "pass"


def _stat(values, how) -> float:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    return float(how(v)) if v.size else math.nan


def _fmt(x, digits=3) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def acceptance_failures(o: Outcome) -> list[str]:
    """The acceptance criteria that ``o`` fails (the same as the tests):
    ``exit`` (0 or 6 for valid data, 6 for degenerate kinds, 3 for bad input), ``accuracy``
    (vs Park), ``accuracy vs inlier Park`` (kinds with outliers: vs Park on the outlier-free
    instants, since Park without rejection is no bar there), ``offset``, ``reading``,
    ``flag`` (undetermined direction reported), ``inliers`` (outlier kinds)."""
    kind = KINDS[o.kind]
    if kind.expect == "data_error":
        return [] if o.exit_code == 3 else ["exit"]
    if o.exit_code not in (0, 6) or not math.isfinite(o.rot_error_deg):
        return ["exit"]
    out = [] if (o.exit_code == 6 or kind.expect != "degenerate") else ["exit"]
    if not (o.rot_error_deg <= max(PARK_FACTOR * o.park_rot_error_deg, ROT_FLOOR_DEG)
            and o.trans_error_mm <= max(PARK_FACTOR * o.park_trans_error_mm, TRANS_FLOOR_MM)):
        out.append("accuracy")
    if math.isfinite(o.park_oracle_rot_error_deg) and not (
            o.rot_error_deg <= max(PARK_FACTOR * o.park_oracle_rot_error_deg, ROT_FLOOR_DEG)
            and o.trans_error_mm <= max(PARK_FACTOR * o.park_oracle_trans_error_mm,
                                        TRANS_FLOOR_MM)):
        out.append("accuracy vs inlier Park")
    if kind.offset_determined and not abs(o.offset_error_ms) <= OFFSET_TOL_MS:
        out.append("offset")
    if not o.reading_ok:
        out.append("reading")
    if kind.expect == "degenerate" and not o.undetermined_flagged:
        out.append("flag")
    if kind.make is _kind_outliers and not (o.precision >= MIN_PRECISION
                                           and o.recall >= MIN_RECALL):
        out.append("inliers")
    return out


def summarise(outcomes: list[Outcome]) -> list[dict]:
    """One row per kind: median / max errors of the calibration and of Park, offset
    error, share of seeds read right, mean inlier precision / recall, exit codes, time."""
    rows = []
    for kind in dict.fromkeys(o.kind for o in outcomes):
        os_ = [o for o in outcomes if o.kind == kind]
        codes = {}
        for o in os_:
            codes[o.exit_code] = codes.get(o.exit_code, 0) + 1
        read = [o.reading_ok for o in os_ if o.reading_ok is not None]
        rows.append({
            "kind": kind, "runs": len(os_),
            "exit_codes": ", ".join(f"{c}:{n}" for c, n in sorted(codes.items())),
            "rot_med_deg": _stat([o.rot_error_deg for o in os_], np.median),
            "rot_max_deg": _stat([o.rot_error_deg for o in os_], np.max),
            "trans_med_mm": _stat([o.trans_error_mm for o in os_], np.median),
            "trans_max_mm": _stat([o.trans_error_mm for o in os_], np.max),
            "park_rot_med_deg": _stat([o.park_rot_error_deg for o in os_], np.median),
            "park_rot_max_deg": _stat([o.park_rot_error_deg for o in os_], np.max),
            "park_trans_med_mm": _stat([o.park_trans_error_mm for o in os_], np.median),
            "park_trans_max_mm": _stat([o.park_trans_error_mm for o in os_], np.max),
            "oracle_rot_med_deg": _stat([o.park_oracle_rot_error_deg for o in os_],
                                        np.median),
            "oracle_trans_med_mm": _stat([o.park_oracle_trans_error_mm for o in os_],
                                         np.median),
            "offset_med_ms": _stat([abs(o.offset_error_ms) for o in os_], np.median),
            "offset_max_ms": _stat([abs(o.offset_error_ms) for o in os_], np.max),
            "reading_ok": ("n/a" if KINDS[kind].expect == "data_error"
                           else f"{sum(read)}/{len(os_)}"),
            "precision": _stat([o.precision for o in os_], np.mean),
            "recall": _stat([o.recall for o in os_], np.mean),
            "time_med_s": _stat([o.runtime_s for o in os_], np.median),
            "acceptance": _failure_counts(os_),
        })
    return rows


def markdown(rows: list[dict], outcomes: list[Outcome], command: str) -> str:
    """The markdown report: the per-kind table, then the failed runs' messages."""
    head = ["kind", "runs", "exit codes (code:count)", "rot med / max (deg)",
            "trans med / max (mm)", "Park rot med / max (deg)", "Park trans med / max (mm)",
            "Park on inlier poses rot / trans med (deg / mm)",
            "|offset err| med / max (ms)", "reading right (seeds)", "inlier precision",
            "inlier recall",
            "time med (s)", "acceptance fails (seeds)"]
    lines = [
        "# Benchmark recordings: calibrate defaults vs OpenCV Park",
        "",
        f"Generated by `{command}` (simcalib/studies/experiments/recordings.py). "
        "Every kind x seed is written as TUM files and calibrated by the `calibrate` "
        "command with its defaults (offset estimated, reading detected, RANSAC). Park is "
        "OpenCV's `calibrateHandEye(..., CALIB_HAND_EYE_PARK)` given the TRUE clock offset "
        "and the TRUE reading on the synchronised poses (continuous kinds: b interpolated at "
        f"a's shifted stamps, subsampled to <= {PARK_MAX_POSES} poses, all i<j pairs); Park "
        "gets NO outlier rejection. 'Park on inlier poses' is Park on the instants that use "
        "no outlier pose, by the TRUE masks: Park without rejection is no bar for the "
        "outlier kinds, so they are also held to this one. Errors are against the true X; "
        "for planar / scara the translation error leaves out the undetermined direction. "
        "Offset error only where the data determine the offset (continuous kinds). Inlier "
        "precision / recall (means over seeds): the calibration's inlier motions against "
        "the motions that touch no outlier pose. Exit codes: 0 determined, 6 degenerate, "
        "3 data error, 5 solver failed, 1 crash; errors are over the runs that gave an "
        "estimate.",
        "",
        f"Acceptance (tests/test_studies_experiments_recordings.py): errors <= max({PARK_FACTOR:g} x Park's, "
        f"{ROT_FLOOR_DEG:g} deg / {TRANS_FLOOR_MM:g} mm) (kinds with outliers: also vs Park "
        f"on the inlier poses), |offset error| <= {OFFSET_TOL_MS:g} ms, the right reading, "
        "exit 0 or 6 (6 and the undetermined direction flagged for planar / scara; exit 3 "
        f"for no_motion_b), inlier precision >= {MIN_PRECISION:g} and recall >= "
        f"{MIN_RECALL:g} for outliers. With rotations about one axis only (scara, planar) "
        "Park's rotation step is rank-deficient and its translation solve ill-conditioned, "
        "so the Park bar is loose there.",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in rows:
        lines.append("| " + " | ".join([
            r["kind"], str(r["runs"]), r["exit_codes"],
            f"{_fmt(r['rot_med_deg'])} / {_fmt(r['rot_max_deg'])}",
            f"{_fmt(r['trans_med_mm'])} / {_fmt(r['trans_max_mm'])}",
            f"{_fmt(r['park_rot_med_deg'])} / {_fmt(r['park_rot_max_deg'])}",
            f"{_fmt(r['park_trans_med_mm'])} / {_fmt(r['park_trans_max_mm'])}",
            f"{_fmt(r['oracle_rot_med_deg'])} / {_fmt(r['oracle_trans_med_mm'])}",
            f"{_fmt(r['offset_med_ms'])} / {_fmt(r['offset_max_ms'])}",
            r["reading_ok"], _fmt(r["precision"]), _fmt(r["recall"]),
            _fmt(r["time_med_s"], 2), r["acceptance"]]) + " |")
    lines += ["", "Kinds:", ""]
    for name in dict.fromkeys(o.kind for o in outcomes):
        lines.append(f"* `{name}`: {KINDS[name].description} (expected: "
                     f"{KINDS[name].expect})")
    failed = [o for o in outcomes if o.exit_code not in (0, 6)]
    if failed:
        lines += ["", "Runs without an estimate (exit code: the command's error; `<dir>` is the "
                  "run's folder):", ""]
        lines += [f"* {o.kind} seed {o.seed}: exit {o.exit_code}: {o.message}" for o in failed]
    return "\n".join(lines) + "\n"


def run_all(kinds, seeds: int, workdir=None, log=None) -> list[Outcome]:
    """:func:`evaluate` for every kind x seed ``0..seeds-1`` (outputs in ``workdir`` or a
    temporary directory)."""
    outcomes = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(workdir) if workdir is not None else Path(tmp)
        for kind in kinds:
            for seed in range(seeds):
                o = evaluate(generate(kind, seed), root / kind / str(seed))
                if log is not None:
                    log(f"{kind} seed {seed}: exit {o.exit_code}, rot {_fmt(o.rot_error_deg)}"
                        f" deg, trans {_fmt(o.trans_error_mm)} mm (Park "
                        f"{_fmt(o.park_rot_error_deg)} / {_fmt(o.park_trans_error_mm)}), "
                        f"offset err {_fmt(o.offset_error_ms)} ms, {o.runtime_s:.1f} s"
                        + (f": {o.message}" if o.message else ""))
                outcomes.append(o)
    return outcomes


# -------------------------------------------------------------------- experiment API
@dataclass(frozen=True)
class RecordingsConfig:
    """``python -m simcalib experiment recordings kinds=[...] seeds=N output=DIR``."""
    kinds: tuple[str, ...] = tuple(KINDS)
    seeds: int = 3
    output: str = "results/recordings"

    def __post_init__(self):
        from simcalib.config.checks import check_int, check_names, set_fields
        set_fields(self, kinds=check_names("kinds", self.kinds, tuple(KINDS)),
                   seeds=check_int("seeds", self.seeds, lo=1))


@experiment('recordings', config=RecordingsConfig,
            description='benchmark recordings calibrate has never seen, defaults vs a classic solver')
def run(cfg: RecordingsConfig):
    """Run the comparison; writes ``recordings.md`` and ``recordings.csv`` into
    ``cfg.output``."""
    from simcalib.studies.experiments import common
    t0 = time.perf_counter()
    out = common.output_dir(cfg.output)
    outcomes = run_all(cfg.kinds, cfg.seeds, workdir=out / "runs")
    rows = summarise(outcomes)
    md = out / "recordings.md"
    md.write_text(markdown(rows, outcomes, "python -m simcalib experiment recordings "
                           f"kinds=[{','.join(cfg.kinds)}] seeds={cfg.seeds}"))
    csv = common.write_csv(out / "recordings.csv", rows, list(rows[0]))
    return common.ExperimentResult("recordings", out, {"md": md, "csv": csv}, rows,
                                   time.perf_counter() - t0)


def main(argv=None) -> int:
    """``python -m simcalib.studies.experiments.recordings [--kinds K ...] [--seeds N]
    [--output FILE.md]``: print (and write) the table. Returns 0, or 2 for bad arguments."""
    p = argparse.ArgumentParser(prog="python -m simcalib.studies.experiments.recordings",
                                description="calibrate defaults vs OpenCV Park on generated "
                                "recordings of many kinds")
    p.add_argument("--kinds", nargs="+", default=list(KINDS), metavar="KIND",
                   help="kinds to run (default: all): " + ", ".join(KINDS))
    p.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 per kind (default 3)")
    p.add_argument("--output", type=Path, default=None, help="also write the markdown here")
    p.add_argument("--workdir", type=Path, default=None,
                   help="keep the TUM files and outputs here (default: a temporary folder)")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    bad = [k for k in args.kinds if k not in KINDS]
    if bad or args.seeds < 1:
        print(f"error: unknown kind(s) {', '.join(bad)}; valid: {', '.join(KINDS)}" if bad
              else f"error: --seeds must be >= 1; received {args.seeds}", file=sys.stderr)
        return 2
    outcomes = run_all(args.kinds, args.seeds, args.workdir,
                       log=lambda s: print(s, file=sys.stderr, flush=True))
    argv_shown = " ".join(sys.argv[1:] if argv is None else list(argv))
    text = markdown(summarise(outcomes), outcomes,
                    f"python -m simcalib.studies.experiments.recordings {argv_shown}".strip())
    print(text)
    if args.output is not None:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
