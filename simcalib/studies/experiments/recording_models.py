"""The building blocks of the generated recordings: what a recording holds
(:class:`Recording`: both streams in their files' form and the truth), its
:class:`Settings`, a kind's definition (:class:`Kind`), the hand-camera rig, sampling,
clocks, noise and the motion models (stations, smooth hand motion, continuous streams).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field, fields
from typing import Callable

import numpy as np

from simcalib.geometry import (invert_transform, matrix_from_rotvec, perturb_transforms,
                               rotvec_from_matrix, transform_from_rotation_translation)
from simcalib.importers import PoseStreamData

__all__ = ["R_DOWN", "WORKSPACE_CENTRE", "R_FORWARD", "Recording", "Settings", "Kind"]



#: hand orientation looking straight down (camera towards the table): Rx(pi)
R_DOWN = np.diag([1.0, -1.0, -1.0])
#: centre of the hand's workspace in the robot base frame (m)
WORKSPACE_CENTRE = np.array([0.5, 0.0, 0.45])
#: camera axes (x right, y down, z forward) in a vehicle frame (x forward, y left, z up)
R_FORWARD = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
_RNG_STREAMS = ("rig", "motion", "noise_a", "noise_b", "clock", "events", "workspace")


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
    ``undetermined_a``, unit rows ``(k, 3)`` in frame a, span the directions of X's
    translation the motion cannot determine: one for planar / SCARA motion, all three for
    pure translation) or ``data_error`` (the calibration must refuse it).
    ``X_workspace`` (kinds with systematic error, else None): the X that the hand's REPORTED
    poses and the camera's biased poses imply over the whole workspace, free of noise (a
    dense solve, :func:`simcalib.studies.experiments.recording_kinds.workspace_X`): what an
    unlimited number of error-free stations would return. It differs from ``X_true`` by the
    errors' part common to every pose, which no recording of this rig can reveal.
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
    X_workspace: np.ndarray | None = None
    #: the robot's accuracy its maker would state (kinds with systematic robot error):
    #: ``(rms rotation deg, rms translation m)`` of its error over the workspace, else None
    accuracy_a: tuple | None = None
    #: the unit each FILE writes its stamps in (``s``, ``ms``, ``us``, ``ns``); the truth
    #: (offset, ``t_ref_s``) is in seconds of those stamps read in their unit
    stamps_unit_a: str = "s"
    stamps_unit_b: str = "s"
    #: b's FILE holds its translations times this (a monocular SLAM track, a wrong target
    #: size); X_true is in a's unit (metres)
    scale_b: float = 1.0
    #: a sensor moved on its mount (a bumped camera): X was ``X_before_change`` on the
    #: station rows before ``change_row`` and ``X_true`` from it on (None: X never changed)
    X_before_change: np.ndarray | None = None
    change_row: int | None = None
    #: b's clock stepped once by ``step_s`` (an NTP correction, a logger restarted): from
    #: clock-a time ``step_at_s`` on (b's first pose after the step; None: it never
    #: stepped), the offset is ``step_s`` more
    step_s: float = 0.0
    step_at_s: float | None = None

    def offset_at(self, t_a) -> np.ndarray:
        """The true offset ``t_b - t_a`` at clock-a times ``t_a``."""
        t_a = np.asarray(t_a, dtype=np.float64)
        off = self.offset_s + self.drift * (t_a - self.t_ref_s)
        return off if self.step_at_s is None else off + self.step_s * (t_a >= self.step_at_s)

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
                else self.undetermined_a.tolist(),
                "X_workspace": None if self.X_workspace is None else self.X_workspace.tolist(),
                "accuracy_a": None if self.accuracy_a is None else list(self.accuracy_a),
                "stamps_unit_a": self.stamps_unit_a, "stamps_unit_b": self.stamps_unit_b,
                "scale_b": self.scale_b,
                "X_before_change": None if self.X_before_change is None
                else self.X_before_change.tolist(), "change_row": self.change_row,
                "step_s": self.step_s, "step_at_s": self.step_at_s}


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
    Y: np.ndarray | None = None   # T_wa_wb, world b in world a (stations: T_base_target)
    X_workspace: np.ndarray | None = None
    accuracy_a: tuple | None = None
    stamps_unit_a: str = "s"    # the unit the file writes the stamps in (t_a, t_b: seconds)
    stamps_unit_b: str = "s"
    scale_b: float = 1.0        # b's file holds its translations times this
    X_before_change: np.ndarray | None = None   # X on the rows before change_row
    change_row: int | None = None
    step_s: float = 0.0                 # b's clock steps by this from clock-a step_at_s
    step_at_s: float | None = None


@dataclass(frozen=True)
class Kind:
    """A registered kind: ``make(rngs, settings) -> _Draft``, one line of description,
    whether the data determine the clock offset, and what the calibration should do."""
    make: Callable
    description: str
    offset_determined: bool
    expect: str = "determined"
    extra: tuple = ()           # kind-specific Settings it reads (offset_s, ...)
    #: the kind's own values of :class:`Settings` fields (overrides still win)
    defaults: dict = field(default_factory=dict)
    #: how close the offset must be found (ms; None: the acceptance's OFFSET_TOL_MS where
    #: the data determine it, else not checked)
    offset_tol_ms: float | None = None

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


def _min_jerk(u: np.ndarray) -> np.ndarray:
    return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)


def _stop_and_go_motion(rng, k) -> tuple[Callable, float, np.ndarray]:
    """``(tau -> T_base_hand(tau), duration_s, still)``: the hand stands 1..4 s at each of
    ``k`` stations (:func:`_station_poses`) and moves between them in 1.5..3 s
    (minimum-jerk in position and about the rotation's axis); ``still`` (k, 2) the
    instants it stands still, from 0.3 s after arriving (settled) to leaving."""
    P = _station_poses(rng, k)
    move = rng.uniform(1.5, 3.0, k - 1)
    dwell = rng.uniform(1.0, 4.0, k)
    arrive = np.concatenate([[0.0], np.cumsum(dwell[:-1] + move)])   # at station i
    leave = arrive + dwell
    rel = rotvec_from_matrix(np.swapaxes(P[:-1, :3, :3], 1, 2) @ P[1:, :3, :3])

    def poses(tau):
        tau = np.asarray(tau, dtype=np.float64)
        i = np.clip(np.searchsorted(leave, tau, side="right") - 1, 0, k - 2)
        u = np.clip((tau - leave[i]) / move[i], 0.0, 1.0)
        i = np.where(tau < leave[0], 0, i)
        u = np.where(tau < leave[0], 0.0, u)
        s = _min_jerk(u)
        R = P[i, :3, :3] @ matrix_from_rotvec(rel[i] * s[:, None])
        p = P[i, :3, 3] + s[:, None] * (P[i + 1, :3, 3] - P[i, :3, 3])
        return transform_from_rotation_translation(R, p)
    return poses, float(leave[-1]), np.stack([arrive + 0.3, leave], axis=1)


@dataclass(frozen=True, eq=False)
class _Clock:
    """Clock b against clock a: ``t_b = t_a + offset_s + drift (t_a - t_ref_s)``."""
    t0: float
    offset_s: float
    drift: float
    t_ref_s: float


def _small_offset(rngs, s) -> float:
    """The clock offset of the kinds about something else (gaps, readings, planar): uniform
    in +-50 ms (a real recording never has exactly 0), unless ``offset_s`` is given."""
    drawn = float(rngs["clock"].uniform(-0.05, 0.05))     # always drawn: same arrays
    return drawn if s.offset_s is None else float(s.offset_s)


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
                  "(b = T_target_cam)", 0.0, 0.0, float(t[0]), Y=Y)
