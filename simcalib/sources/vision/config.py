"""Configuration of the visual pose source (:class:`VisionConfig`): the section ``vision``
of a scenario. Config only: it imports neither OpenCV nor MuJoCo nor the rendering (the
stack that uses it is :mod:`simcalib.sources.vision.stream`)."""

from __future__ import annotations

from dataclasses import dataclass, fields

from simcalib.targets.marker_pnp import PnPSettings
from simcalib.targets.markers import CORNER_REFINEMENTS, DetectorSettings

__all__ = ["VisionConfig"]


@dataclass(frozen=True)
class VisionConfig:
    """Settings of the visual pose stage (defaults: the accuracy/speed of docs/vision.md).

    Camera: ``width``/``height``/``fovy_deg`` override the world's camera (``None`` keeps
    it; intrinsics follow docs/platform.md). Image realism: ``blur_sigma_px`` (Gaussian defocus
    blur, pixels; 0 = sharp), ``noise_std`` (Gaussian pixel noise, grey levels of 255;
    0 = none). Rendering: ``msaa_samples`` (0 = fastest; markers are textures, MSAA does
    not change their corners). Detection: ``corner_refinement`` (OpenCV's, one of
    ``none|subpix|contour|apriltag``), ``edge_refinement`` (edge-line corner refinement).
    Pose: ``min_markers``, ``max_reproj_rmse_px``, ``max_marker_reproj_px``,
    ``ambiguity_ratio``, ``refine`` (see :class:`simcalib.targets.marker_pnp.PnPSettings`).
    Log: ``log_every`` (keep the JPEG image of every n-th frame per camera; 0 = none),
    ``jpeg_quality`` (1–100).
    Camera effects (:mod:`simcalib.sources.vision.camera_effects`): ``preset`` (``ideal`` — every effect
    off — ``realistic`` or ``harsh``) and per-effect overrides, ``None`` keeping the
    preset's value: ``distortion`` (k1, k2, p1, p2, k3), ``intrinsics_error`` (focal
    fraction, principal point px, distortion fraction: sizes of the estimator's calibration
    error), ``read_noise_dn``, ``shot_noise_dn``, ``gain_log_std``, ``compression_quality``
    (camera JPEG, 0 = none), ``exposure_s`` (motion blur), ``readout_s`` (rolling shutter),
    ``subframes`` (renders per frame for both), ``light_variation``, ``light_motion_deg``,
    ``map_position_std_m`` / ``map_rotation_std_deg`` (error of the marker map the
    estimator uses; the renderer keeps the true markers).
    ``count_occlusion``: count markers in view whose line of sight is blocked (robot,
    cart) per frame.
    """
    width: int | None = None
    height: int | None = None
    fovy_deg: float | None = None
    blur_sigma_px: float = 0.0
    noise_std: float = 0.0
    msaa_samples: int = 0
    corner_refinement: str = "subpix"
    edge_refinement: bool = True
    min_markers: int = 1
    max_reproj_rmse_px: float = 1.0
    max_marker_reproj_px: float = 2.0
    ambiguity_ratio: float = 2.0
    refine: bool = True
    log_every: int = 10
    jpeg_quality: int = 80
    preset: str = "ideal"
    distortion: tuple | None = None
    intrinsics_error: tuple | None = None
    read_noise_dn: float | None = None
    shot_noise_dn: float | None = None
    gain_log_std: float | None = None
    compression_quality: int | None = None
    exposure_s: float | None = None
    readout_s: float | None = None
    subframes: int | None = None
    light_variation: float | None = None
    light_motion_deg: float | None = None
    map_position_std_m: float | None = None
    map_rotation_std_deg: float | None = None
    count_occlusion: bool = True

    def __post_init__(self):
        from simcalib.config.checks import (check_bool, check_in, check_int, check_range,
                                     set_fields)
        set_fields(
            self,
            width=check_int("width", self.width, lo=8, hi=8192, optional=True),
            height=check_int("height", self.height, lo=8, hi=8192, optional=True),
            fovy_deg=check_range("fovy_deg", self.fovy_deg, lo=0.0, hi=179.0, lo_open=True,
                                 optional=True),
            blur_sigma_px=check_range("blur_sigma_px", self.blur_sigma_px, lo=0.0, hi=50.0),
            noise_std=check_range("noise_std", self.noise_std, lo=0.0, hi=255.0),
            msaa_samples=check_int("msaa_samples", self.msaa_samples, lo=0, hi=16),
            corner_refinement=check_in("corner_refinement", self.corner_refinement,
                                       sorted(CORNER_REFINEMENTS)),
            edge_refinement=check_bool("edge_refinement", self.edge_refinement),
            refine=check_bool("refine", self.refine),
            log_every=check_int("log_every", self.log_every, lo=0, hi=10**9),
            jpeg_quality=check_int("jpeg_quality", self.jpeg_quality, lo=1, hi=100),
            count_occlusion=check_bool("count_occlusion", self.count_occlusion))
        self.pnp_settings()  # validates the PnP fields with their own messages
        self.effects()       # validates preset and camera-effect fields

    #: VisionConfig field -> CameraEffects field (``None`` in VisionConfig: the preset's).
    EFFECT_FIELDS = {"distortion": "distortion", "intrinsics_error": "intrinsics_error",
                     "read_noise_dn": "read_noise_dn", "shot_noise_dn": "shot_noise_dn",
                     "gain_log_std": "gain_log_std", "compression_quality": "jpeg_quality",
                     "exposure_s": "exposure_s", "readout_s": "readout_s",
                     "subframes": "subframes", "light_variation": "light_variation",
                     "light_motion_deg": "light_motion_deg",
                     "map_position_std_m": "map_position_std_m",
                     "map_rotation_std_deg": "map_rotation_std_deg"}

    def effects(self):
        """The camera effects in force: :attr:`preset` with the fields set here replacing
        the preset's (:class:`simcalib.sources.vision.camera_effects.CameraEffects`)."""
        from simcalib.sources.vision.camera_effects import PRESETS, preset  # noqa: PLC0415
        from simcalib.config.checks import check_in  # noqa: PLC0415
        check_in("preset", self.preset, sorted(PRESETS))
        over = {eff: getattr(self, mine) for mine, eff in self.EFFECT_FIELDS.items()
                if getattr(self, mine) is not None}
        try:
            return preset(self.preset, **over)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"VisionConfig: {exc} (camera-effect fields: "
                             f"{sorted(self.EFFECT_FIELDS)})") from None

    def detector_settings(self, dictionary: str) -> DetectorSettings:
        return DetectorSettings(dictionary=dictionary, corner_refinement=self.corner_refinement,
                                edge_refinement=self.edge_refinement)

    def pnp_settings(self) -> PnPSettings:
        return PnPSettings(min_markers=self.min_markers,
                           max_reproj_rmse_px=self.max_reproj_rmse_px,
                           max_marker_reproj_px=self.max_marker_reproj_px,
                           ambiguity_ratio=self.ambiguity_ratio, refine=self.refine)

    @classmethod
    def from_dict(cls, values: dict) -> "VisionConfig":
        """Build from a mapping; unknown keys are rejected, naming the valid ones."""
        if not isinstance(values, dict):
            raise TypeError(f"VisionConfig.from_dict needs a dict; received {type(values).__name__}")
        from simcalib.errors import ConfigError, did_you_mean
        valid = [f.name for f in fields(cls)]
        unknown = sorted(set(values) - set(valid))
        if unknown:
            raise ConfigError(f"unknown VisionConfig keys {unknown}"
                              f"{did_you_mean(unknown[0], valid)}; valid keys: {valid}",
                              key=unknown[0])
        return cls(**values)
