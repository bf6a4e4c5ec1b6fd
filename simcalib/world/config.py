"""Typed, validated configuration of a simulated world (frozen dataclasses).

Every field has a documented default; bad values raise :class:`~simcalib.errors.ConfigError`
(a ``ValueError``; :class:`~simcalib.errors.ConfigTypeError`, also a ``TypeError``, for a
wrong type) naming the field, the received value and what is allowed (checks written with
:mod:`simcalib.config.checks`). Nested dataclasses group the settings::

    WorldConfig(platform="cart", path="planar", duration_s=20.0, fps=10.0,
                path_params={}, perturbation=PerturbationConfig(),
                rig=RigConfig(), cam_a=CameraConfig(), cam_b=CameraConfig(),
                room=RoomConfig(), markers=MarkerFieldConfig(), ik=IKConfig(),
                vehicle=VehicleConfig(), arm=ArmControlConfig())
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Mapping

import numpy as np

from simcalib.config.checks import (check_in, check_int, check_range, check_that,
                             check_vector, fail, set_fields)
from simcalib.errors import ConfigError, did_you_mean
from simcalib.world.synthetic import PAPER_X_ROTVEC_RAD, PAPER_X_TRANSLATION_M
from simcalib.world.vehicle_config import VehicleConfig
from simcalib.targets.boards import BoardConfig, board_for_target, check_target

#: The paper's X rotation in degrees (rounded back to the published decimals).
PAPER_X_ROTVEC_DEG = tuple(round(math.degrees(v), 10) for v in PAPER_X_ROTVEC_RAD)

__all__ = ["CameraConfig", "IKConfig", "MarkerFieldConfig", "PerturbationConfig",
           "RigConfig", "RoomConfig", "WorldConfig", "ArmControlConfig", "VehicleConfig"]

#: what ``world.arm.motions`` may say the arm stands for (:class:`ArmControlConfig`)
ARM_MOTIONS = ("6dof", "scara")


# ----------------------------------------------------------------------------- helpers
def _nested(name: str, value, cls):
    """Accept an instance of ``cls`` or a mapping of its fields (unknown keys rejected)."""
    if isinstance(value, cls):
        return value
    if isinstance(value, Mapping):
        allowed = [f.name for f in fields(cls)]
        for key in value:
            if key not in allowed:
                raise ConfigError(f"{name}: unknown key {key!r}"
                                  f"{did_you_mean(key, allowed, prefix=name + '.')}; "
                                  f"allowed: {', '.join(allowed)}", key=f"{name}.{key}")
        try:
            return cls(**value)
        except ConfigError as exc:
            raise exc.at(name) from None
        except (ValueError, TypeError) as exc:   # a section with its own checks (vehicle)
            raise ConfigError(f"{name}: {exc}", key=name) from None
    raise fail(name, type(value).__name__, f"a {cls.__name__} or a mapping of its fields",
               type_error=True)


# ----------------------------------------------------------------------------- configs
@dataclass(frozen=True)
class CameraConfig:
    """One camera of the rig: image size, field of view and timing/drop knobs.

    * ``width``, ``height`` (px, default 640x480, at most 1920x1080 = the offscreen buffer),
      ``fovy_deg`` (vertical field of view, default 60°). Intrinsics follow
      ``CameraIntrinsics.from_fovy``.
    * ``capture_offset_s``: the camera truly captures frame ``k`` at ``k / fps + offset``
      (the paper's real cameras were ~0.05 s apart). Default 0.
    * ``capture_jitter_s``: std of Gaussian jitter on the true capture time per frame
      (must stay below a quarter of the frame period). Default 0.
    * ``clock_offset_s``, ``clock_drift_ppm``, ``stamp_jitter_s``: the camera's clock; the
      reported timestamp is ``t_cap * (1 + drift_ppm * 1e-6) + clock_offset_s + jitter``
      (true capture time ``t_cap``; Gaussian jitter of std ``stamp_jitter_s``), i.e. what the
      sensor's own clock says. Ground truth keeps ``t_cap``. Defaults 0.
    * ``fps``: this camera's frame rate (Hz); ``None`` (default): the world's ``fps``. Frame
      ``k`` is then nominally at ``k / fps`` for ``k = 0 .. floor(duration_s * fps)``, so two
      cameras may run at e.g. 30 Hz and 20 Hz.
    * ``drop_prob``: probability that a frame is never delivered (i.i.d., seeded); dropped
      frames are counted in every ``PoseStream`` of the camera, never filled in. Default 0.
    """
    width: int = 640
    height: int = 480
    fovy_deg: float = 60.0
    capture_offset_s: float = 0.0
    capture_jitter_s: float = 0.0
    clock_offset_s: float = 0.0
    stamp_jitter_s: float = 0.0
    drop_prob: float = 0.0
    fps: float | None = None
    clock_drift_ppm: float = 0.0

    def __post_init__(self):
        set_fields(
            self,
            width=check_int("width", self.width, lo=16, hi=1920),
            height=check_int("height", self.height, lo=16, hi=1080),
            fovy_deg=check_range("fovy_deg", self.fovy_deg, lo=5.0, hi=150.0),
            capture_offset_s=check_range("capture_offset_s", self.capture_offset_s,
                                         lo=-10.0, hi=10.0),
            capture_jitter_s=check_range("capture_jitter_s", self.capture_jitter_s, lo=0.0),
            clock_offset_s=check_range("clock_offset_s", self.clock_offset_s,
                                       lo=-1e6, hi=1e6),
            stamp_jitter_s=check_range("stamp_jitter_s", self.stamp_jitter_s, lo=0.0),
            drop_prob=check_range("drop_prob", self.drop_prob, lo=0.0, hi=1.0, hi_open=True),
            fps=check_range("fps", self.fps, lo=0.0, hi=1000.0, lo_open=True, optional=True),
            clock_drift_ppm=check_range("clock_drift_ppm", self.clock_drift_ppm,
                                        lo=-1e5, hi=1e5))


@dataclass(frozen=True)
class RigConfig:
    """The two-camera rig. ``X = T_a_b`` (pose of cam_b's OpenCV frame in cam_a's) from a
    translation (m) and an axis-angle rotation vector (deg); default the paper's real rig:
    ``[-0.7, 28.1, -0.1]`` cm and ``[2.35, -0.92, -48.93]`` deg
    (:func:`simcalib.world.synthetic.paper_rig_X`, the one place it is written).
    ``rig_cam_a_*``: pose of cam_a's OpenCV frame in the rig frame (+z forward = viewing
    direction, +y down, +x right at the platform's mount). Default: cam_a upright, looking
    forward, 14 cm above and 5 cm in front of the mount, so that cam_b (28 cm below cam_a
    along its +y) sits symmetrically below it."""
    a_b_translation_m: tuple = PAPER_X_TRANSLATION_M
    a_b_rotvec_deg: tuple = PAPER_X_ROTVEC_DEG
    rig_cam_a_translation_m: tuple = (0.0, -0.14, 0.05)
    rig_cam_a_rotvec_deg: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        set_fields(
            self,
            a_b_translation_m=check_vector("a_b_translation_m", self.a_b_translation_m,
                                           max_norm=2.0, what="a rig, not a building"),
            a_b_rotvec_deg=check_vector("a_b_rotvec_deg", self.a_b_rotvec_deg),
            rig_cam_a_translation_m=check_vector("rig_cam_a_translation_m",
                                                 self.rig_cam_a_translation_m, max_norm=1.0,
                                                 what="metres from the mount"),
            rig_cam_a_rotvec_deg=check_vector("rig_cam_a_rotvec_deg", self.rig_cam_a_rotvec_deg))

    def T_a_b(self) -> np.ndarray:
        from simcalib.geometry import matrix_from_rotvec, transform_from_rotation_translation
        R = matrix_from_rotvec(np.deg2rad(np.asarray(self.a_b_rotvec_deg)))
        return transform_from_rotation_translation(R, np.asarray(self.a_b_translation_m))

    def T_rig_cam_a(self) -> np.ndarray:
        from simcalib.geometry import matrix_from_rotvec, transform_from_rotation_translation
        R = matrix_from_rotvec(np.deg2rad(np.asarray(self.rig_cam_a_rotvec_deg)))
        return transform_from_rotation_translation(R, np.asarray(self.rig_cam_a_translation_m))


@dataclass(frozen=True)
class RoomConfig:
    """Box-shaped room centred on the world origin, floor at z = 0: inner size
    ``size_m = (x, y, z)`` in metres (default 4.4 x 4.4 x 2.6)."""
    size_m: tuple = (4.4, 4.4, 2.6)

    def __post_init__(self):
        v = check_vector("size_m", self.size_m)
        check_that(2.5 <= min(v[:2]) and max(v[:2]) <= 30.0 and 2.0 <= v[2] <= 10.0,
                   "size_m", self.size_m,
                   "x, y in [2.5, 30] m and z in [2, 10] m (the platforms need space)")
        set_fields(self, size_m=v)


@dataclass(frozen=True)
class MarkerFieldConfig:
    """ArUco marker field in the room.

    * ``dictionary``: OpenCV predefined dictionary name (default ``DICT_4X4_250``).
    * ``side_m``: edge of the black marker square (default 0.20 m); each marker geom adds a
      white quiet zone of one cell on every side.
    * ``pitch_m``: centre-to-centre spacing of the grid on every surface (default 0.40 m).
    * ``surfaces``: any of ``walls``, ``floor``, ``ceiling`` (default walls only).
    * ``margin_m``: free band along every edge of a surface (default 0.25 m).
    * ``texture_cell_px``: texture pixels per marker cell (default 24).
    """
    dictionary: str = "DICT_4X4_250"
    side_m: float = 0.20
    pitch_m: float = 0.40
    surfaces: tuple = ("walls",)
    margin_m: float = 0.25
    texture_cell_px: int = 24

    def __post_init__(self):
        check_that(isinstance(self.dictionary, str) and self.dictionary.startswith("DICT_"),
                   "dictionary", self.dictionary,
                   "an OpenCV predefined ArUco dictionary name such as 'DICT_4X4_250'")
        surfaces = (self.surfaces,) if isinstance(self.surfaces, str) else self.surfaces
        allowed = ("walls", "floor", "ceiling")
        check_that(isinstance(surfaces, (tuple, list)) and bool(surfaces)
                   and set(surfaces) <= set(allowed) and len(set(surfaces)) == len(surfaces),
                   "surfaces", self.surfaces, f"distinct names from {allowed}")
        set_fields(
            self,
            side_m=check_range("side_m", self.side_m, lo=0.02, hi=1.0),
            pitch_m=check_range("pitch_m", self.pitch_m, lo=0.02, hi=5.0),
            margin_m=check_range("margin_m", self.margin_m, lo=0.0, hi=2.0),
            texture_cell_px=check_int("texture_cell_px", self.texture_cell_px, lo=2, hi=128),
            surfaces=tuple(surfaces))
        check_that(self.pitch_m >= self.side_m * 8.0 / 6.0, "pitch_m", self.pitch_m,
                   f">= side_m * 4/3 = {self.side_m * 4 / 3:.3f} (room for the marker and its "
                   "quiet zone)")


@dataclass(frozen=True)
class PerturbationConfig:
    """Optional small smooth 3D perturbations on top of any path (seeded): peak roll and
    pitch (deg, about the platform's heading axes) and peak height change (m). Each is a
    sum of three sinusoids of random frequency in [``min_freq_hz``, ``max_freq_hz``] and
    random phase, bounded by the given peak. Defaults: off (planar paths stay planar)."""
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    height_m: float = 0.0
    min_freq_hz: float = 0.1
    max_freq_hz: float = 0.5

    def __post_init__(self):
        set_fields(
            self,
            roll_deg=check_range("roll_deg", self.roll_deg, lo=0.0, hi=20.0),
            pitch_deg=check_range("pitch_deg", self.pitch_deg, lo=0.0, hi=20.0),
            height_m=check_range("height_m", self.height_m, lo=0.0, hi=0.3),
            min_freq_hz=check_range("min_freq_hz", self.min_freq_hz, lo=0.0, lo_open=True),
            max_freq_hz=check_range("max_freq_hz", self.max_freq_hz, lo=0.0, lo_open=True))
        check_that(self.max_freq_hz >= self.min_freq_hz, "max_freq_hz", self.max_freq_hz,
                   f">= min_freq_hz ({self.min_freq_hz:g})")

    @property
    def active(self) -> bool:
        return self.roll_deg > 0 or self.pitch_deg > 0 or self.height_m > 0


@dataclass(frozen=True)
class IKConfig:
    """Damped-least-squares IK (arm paths): damping ``damping`` (λ), at most ``max_iter``
    iterations per waypoint, success when the position error <= ``tol_pos_m`` and the
    rotation error <= ``tol_rot_rad``; a waypoint that misses by more than
    ``fail_pos_m`` / ``fail_rot_rad`` is an unreachable path (ValueError)."""
    damping: float = 1e-4
    max_iter: int = 200
    tol_pos_m: float = 1e-9
    tol_rot_rad: float = 1e-9
    fail_pos_m: float = 1e-4
    fail_rot_rad: float = 1e-4

    def __post_init__(self):
        set_fields(
            self,
            damping=check_range("damping", self.damping, lo=0.0, hi=1.0, lo_open=True),
            max_iter=check_int("max_iter", self.max_iter, lo=1, hi=100000),
            **{name: check_range(name, getattr(self, name), lo=0.0, lo_open=True)
               for name in ("tol_pos_m", "tol_rot_rad", "fail_pos_m", "fail_rot_rad")})


@dataclass(frozen=True)
class ArmControlConfig:
    """How the ``arm`` platform executes its path (``world.arm.*``).

    * ``control``: ``"kinematic"`` (default: posed joint by joint from IK, the flange is
      exactly on the path) or ``"physics"`` (the IK joint path is executed by torque-limited
      PD servos in MuJoCo physics, :func:`simcalib.world.arm_control.track_joint_path`:
      the flange lags, overshoots and settles; the cameras see where it really is).
    * ``capture`` (physics only): ``"continuous"`` (frames at ``k / fps`` while moving) or
      ``"stop_and_go"`` (the path stops at every frame, the arm settles, then captures;
      the frames' times are the path clock, the robot's wall clock is longer).
    * ``gain_scale``: multiplies the default servo stiffness ``kp`` (``kd`` by its square
      root, keeping the damping ratio); ``settle_tol_rad`` / ``settle_max_s``: when a
      stop-and-go capture is taken (every joint within the tolerance of its target and
      slower than 1e-3 rad/s, or after ``settle_max_s``).
    * ``mount``: ``"eye_in_hand"`` (default: the rig's cameras on the flange) or
      ``"eye_to_hand"`` (a camera on a stand sees a board on the flange; cam_a = the flange,
      cam_b = the board in the fixed camera's frame: :mod:`simcalib.world.eyetohand`).
    * ``motions``: the motions the arm stands for: ``"6dof"`` (default: any flange pose the
      UR5e reaches) or ``"scara"`` (a 4-DoF SCARA: the flange translates and rotates about
      the vertical axis only; the path and the perturbation must not roll or pitch it, and
      motion advice proposes only such stops; the UR5e executes them)."""
    control: str = "kinematic"
    capture: str = "continuous"
    gain_scale: float = 1.0
    settle_tol_rad: float = 1e-4
    settle_max_s: float = 3.0
    mount: str = "eye_in_hand"
    motions: str = "6dof"

    def __post_init__(self):
        from simcalib.world.eyetohand import MOUNTS
        check_in("control", self.control, ("kinematic", "physics"))
        check_in("motions", self.motions, ARM_MOTIONS)
        check_in("mount", self.mount, MOUNTS)
        check_in("capture", self.capture, ("continuous", "stop_and_go"))
        set_fields(self,
                   gain_scale=check_range("gain_scale", self.gain_scale, lo=0.01, hi=100.0),
                   settle_tol_rad=check_range("settle_tol_rad", self.settle_tol_rad,
                                              lo=1e-9, hi=1.0),
                   settle_max_s=check_range("settle_max_s", self.settle_max_s, lo=0.0,
                                            hi=60.0))


@dataclass(frozen=True)
class WorldConfig:
    """A simulated run.

    * ``platform``: a registered platform (:mod:`simcalib.world.platforms`: ``cart``,
      ``arm``, ``car``, ...); ``None`` (default) picks the path's natural platform (its
      first: ``3d`` -> arm, the others -> cart).
    * ``path``: a name from :func:`simcalib.world.paths.available_paths` (default ``planar``).
    * ``duration_s`` (default 20 s), ``fps`` (default 10 Hz): frame ``k`` is nominally at
      ``k / fps`` for ``k = 0 .. floor(duration_s * fps)``.
    * ``path_params``: overrides of the path's per-platform defaults (unknown keys rejected).
    * ``perturbation``, ``rig``, ``cam_a``, ``cam_b``, ``room``, ``markers``, ``ik``: nested
      configs (instances or mappings of their fields).
    * ``arm_model``: ``"builtin"`` (default: models/ur5e.xml, UR5e DH kinematics, primitive
      geoms) or ``"menagerie"`` (the Menagerie UR5e with meshes from ``$MENAGERIE_ROOT``).
    * ``arm_dh_error``: ``None`` (default) or the true arm's deviation from the nominal UR5e
      DH table, 6 rows ``(theta_rad, d_m, a_m, alpha_rad)`` (built-in arm only; the run
      draws it from ``robot.kinematic_error``, see :mod:`simcalib.world.robot_error`).
    * ``vehicle``: the physics car of platform ``car`` (``world.vehicle.*``: the fields and
      checks of :class:`simcalib.world.vehicle_config.VehicleConfig`, reused as they are).
    * ``arm``: how the arm executes its path (:class:`ArmControlConfig`).
    * ``target``: what the cameras see: ``"marker_wall"`` (default: the ArUco marker field
      of ``markers``) or one board, ``"charuco"`` / ``"apriltag_grid"``
      (:mod:`simcalib.targets.boards`), on the wall given by ``board`` (no marker field then).
    * ``board``: the board's :class:`simcalib.targets.boards.BoardConfig` (its kind follows
      ``target``).
    """
    platform: str | None = None
    path: str = "planar"
    duration_s: float = 20.0
    fps: float = 10.0
    path_params: Mapping[str, Any] = field(default_factory=dict)
    perturbation: PerturbationConfig = field(default_factory=PerturbationConfig)
    rig: RigConfig = field(default_factory=RigConfig)
    cam_a: CameraConfig = field(default_factory=CameraConfig)
    cam_b: CameraConfig = field(default_factory=CameraConfig)
    room: RoomConfig = field(default_factory=RoomConfig)
    markers: MarkerFieldConfig = field(default_factory=MarkerFieldConfig)
    ik: IKConfig = field(default_factory=IKConfig)
    arm_model: str = "builtin"
    arm_dh_error: tuple | None = None
    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    arm: ArmControlConfig = field(default_factory=ArmControlConfig)
    target: str = "marker_wall"
    board: BoardConfig = field(default_factory=BoardConfig)

    def __post_init__(self):
        from simcalib.world.paths import get_path, resolve_platform
        check_target(self.target)
        set_fields(self, board=board_for_target(self.board, self.target))
        from simcalib.world.platforms import available_platforms
        check_in("platform", self.platform, list(available_platforms()), optional=True)
        check_that(self.arm_model in ("builtin", "menagerie"), "arm_model", self.arm_model,
                   "'builtin' (models/ur5e.xml) or 'menagerie' (UR5e from $MENAGERIE_ROOT)")
        try:
            info = get_path(self.path)        # unknown name -> ValueError listing valid ones
            set_fields(self, platform=resolve_platform(info, self.platform))
        except ValueError as exc:
            raise ConfigError(str(exc), key="path", value=self.path) from None
        from simcalib.world.robot_error import check_dh_error
        set_fields(self, arm_dh_error=check_dh_error(self.arm_dh_error))
        check_that(self.arm_dh_error is None or (self.platform == "arm"
                                                 and self.arm_model == "builtin"),
                   "arm_dh_error", "(a 6x4 table)",
                   f"only set with platform='arm' and arm_model='builtin' (a DH model); "
                   f"here platform={self.platform!r}, arm_model={self.arm_model!r}")
        set_fields(self,
                   duration_s=check_range("duration_s", self.duration_s, lo=0.0, hi=3600.0,
                                          lo_open=True),
                   fps=check_range("fps", self.fps, lo=0.0, hi=1000.0, lo_open=True))
        check_that(3 <= self.n_frames <= 200000, "duration_s", self.duration_s,
                   f"such that duration_s * fps gives at least 3 frames and at most 200000 "
                   f"(fps={self.fps:g} gives {self.n_frames})")
        if not isinstance(self.path_params, Mapping):
            raise fail("path_params", self.path_params, "a mapping", type_error=True)
        set_fields(self, path_params=dict(self.path_params))
        info.params_for(self.platform, self.path_params)   # validates the overrides
        set_fields(self, **{name: _nested(name, getattr(self, name), cls) for name, cls in (
            ("perturbation", PerturbationConfig), ("rig", RigConfig), ("cam_a", CameraConfig),
            ("cam_b", CameraConfig), ("room", RoomConfig), ("markers", MarkerFieldConfig),
            ("ik", IKConfig), ("vehicle", VehicleConfig), ("arm", ArmControlConfig))})
        if self.arm.motions == "scara":
            self._check_scara_motion()
        if self.platform == "car":
            check_that(not self.perturbation.active, "perturbation", self.perturbation,
                       "off with platform 'car' (its roll, pitch and heave come from the "
                       "physics: suspension and ground)")
        for cam in ("cam_a", "cam_b"):
            c = getattr(self, cam)
            period = 1.0 / self.camera_fps(cam)
            check_that(3 <= self.n_frames_of(cam) <= 200000, f"{cam}.fps", c.fps,
                       f"such that duration_s * fps gives 3 to 200000 frames (gives "
                       f"{self.n_frames_of(cam)})")
            check_that(c.capture_jitter_s <= 0.25 * period, f"{cam}.capture_jitter_s",
                       c.capture_jitter_s, f"<= a quarter of the frame period "
                       f"({0.25 * period:.4g} s) so capture times stay ordered")
        self._check_platform()

    def _check_platform(self) -> None:
        """The platform's own check of the configuration (``check_config``, optional:
        e.g. a path it cannot follow), before any work."""
        from simcalib.world.platforms import get_platform
        check = getattr(get_platform(self.platform), "check_config", None)
        if check is None:
            return
        try:
            check(self)
        except ConfigError:
            raise
        except ValueError as exc:
            raise ConfigError(str(exc), key="path", value=self.path) from None

    def _check_scara_motion(self) -> None:
        """``arm.motions='scara'``: an arm whose path never rolls or pitches the flange."""
        from simcalib.world.paths import sample_path
        check_that(self.platform == "arm", "arm.motions", self.arm.motions,
                   f"only set with platform 'arm'; here platform={self.platform!r}")
        s = sample_path(self.path, self.platform, self.nominal_times_s(), self.duration_s,
                        self.path_params)
        tilt = float(np.degrees(np.max(np.abs(np.concatenate([s.roll, s.pitch])))))
        pert = self.perturbation
        check_that(tilt == 0.0 and not (pert.roll_deg or pert.pitch_deg), "arm.motions",
                   self.arm.motions,
                   f"'6dof' with this motion: 'scara' needs a path without roll or pitch (a "
                   f"SCARA rotates about the vertical only); path {self.path!r} tilts the "
                   f"flange by up to {tilt:.3g} deg, the perturbation by roll "
                   f"{pert.roll_deg:g} / pitch {pert.pitch_deg:g} deg")

    @property
    def n_frames(self) -> int:
        return int(math.floor(self.duration_s * self.fps + 1e-9)) + 1

    def nominal_times_s(self, camera: str | None = None) -> np.ndarray:
        """Nominal frame times ``k / fps`` of the world (or of ``camera``, its own fps)."""
        if camera is None:
            return np.arange(self.n_frames, dtype=np.float64) / self.fps
        return np.arange(self.n_frames_of(camera), dtype=np.float64) / self.camera_fps(camera)

    def camera_fps(self, camera: str) -> float:
        """Frame rate of ``camera`` (its ``fps``, else the world's)."""
        if camera not in ("cam_a", "cam_b"):
            raise ValueError(f"unknown camera {camera!r}; valid: ['cam_a', 'cam_b']")
        f = getattr(self, camera).fps
        return self.fps if f is None else f

    def n_frames_of(self, camera: str) -> int:
        """Number of frames of ``camera`` (``floor(duration_s * fps) + 1``)."""
        return int(math.floor(self.duration_s * self.camera_fps(camera) + 1e-9)) + 1
