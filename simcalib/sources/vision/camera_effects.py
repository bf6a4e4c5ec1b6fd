"""Camera effects of simcalib's visual stage: pure image-space and timing models.

Everything here is numpy/OpenCV on arrays (no MuJoCo): the renderer (:mod:`simcalib.world.render`)
renders the sub-frames these functions ask for, :mod:`simcalib.sources.vision.stream` chains the effects.
Each effect is off in preset ``ideal`` and on in ``realistic`` and ``harsh``
(:data:`PRESETS`; docs/vision.md tabulates what each costs and does to pose accuracy).

Models and units (the fields of :class:`CameraEffects`):

- ``distortion`` ``(k1, k2, p1, p2, k3)``: Brown–Conrady lens distortion (OpenCV's
  model). The scene is rendered as an ideal pinhole with the same focal length on a larger
  image (a margin all round, :func:`render_margin_px`) and warped with ``cv2.remap`` so the
  distorted image has no black borders.
- ``intrinsics_error`` ``(focal_fraction, principal_point_px, distortion_fraction)``:
  sizes of the error of the calibration the estimator uses (the commonest real cause of
  hand-eye bias): ``f_est = f (1 +- e_f)``, principal point moved ``e_c`` px in a random
  direction, ``k_est = k (1 +- e_k)`` per coefficient; directions/signs drawn once per
  camera and run (:func:`perturbed_calibration`).
- ``map_position_std_m``, ``map_rotation_std_deg``: error of the marker map the estimator
  uses (a surveyed room is never exactly where the map says): every marker's mapped pose
  is its true pose composed with a random ``[dR | dt]`` in the marker's own frame, ``dt ~
  N(0, map_position_std_m^2 I)`` (in-plane placement and out-of-plane wall unevenness) and
  ``dR`` about a uniform random axis by an angle ``~ N(0, map_rotation_std_deg^2)`` (in-plane
  rotation and tilt of the printed sheet), drawn once per run and shared by the cameras
  (:func:`perturbed_map`). The renderer keeps the true markers.
- ``read_noise_dn`` (grey levels of 255, Gaussian), ``shot_noise_dn`` (noise std at full
  white; std grows as the square root of the signal: ``shot_noise_dn * sqrt(I / 255)``).
- ``gain_log_std``: per-frame exposure/gain change, ``I *= exp(N(0, gain_log_std))``,
  plus a slow auto-exposure drift of the same size (sinusoid, 0.07 Hz).
- ``jpeg_quality``: the camera's JPEG compression (1–100; 0 = none) applied to the image
  the detector sees.
- ``exposure_s``: motion blur — each row integrates the scene over this exposure time.
- ``readout_s``: rolling shutter — row ``r`` of ``H`` starts its exposure
  ``(r / (H - 1) - 1/2) readout_s`` after the frame time (the middle row is exposed at the
  frame's time, which keeps the ground-truth pose the frame's pose).
- ``subframes``: renders per frame. Motion blur and rolling shutter are made from
  ``subframes`` renders at the centres of equal time bins covering
  ``[t - readout/2 - exposure/2, t + readout/2 + exposure/2]``; each output row is the
  average of the bins weighted by how much of the row's exposure window falls in each
  (:func:`row_weights`). Without rolling shutter this is exactly the average of the
  ``subframes`` renders over the exposure; with it, rows are bands rendered at their times.
- ``light_variation``: relative change of the lights' intensity (slow sinusoid at
  0.11 Hz plus 20 % of it as per-frame flicker); ``light_motion_deg``: the directional
  light's azimuth swings by this amplitude (0.05 Hz).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from simcalib.targets.marker_pnp import undistort_points

__all__ = ["CameraEffects", "PRESETS", "preset", "distortion_maps", "render_margin_px",
           "subframe_offsets_s", "row_weights", "combine_subframes", "apply_sensor",
           "jpeg_roundtrip", "perturbed_calibration", "perturbed_map", "light_state"]


@dataclass(frozen=True)
class CameraEffects:
    """Concrete settings of every camera effect (see the module docstring for units)."""
    distortion: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    intrinsics_error: tuple = (0.0, 0.0, 0.0)
    read_noise_dn: float = 0.0
    shot_noise_dn: float = 0.0
    gain_log_std: float = 0.0
    jpeg_quality: int = 0
    exposure_s: float = 0.0
    readout_s: float = 0.0
    subframes: int = 1
    light_variation: float = 0.0
    light_motion_deg: float = 0.0
    map_position_std_m: float = 0.0
    map_rotation_std_deg: float = 0.0

    def __post_init__(self):
        d = tuple(float(v) for v in np.ravel(np.asarray(self.distortion, dtype=np.float64)))
        if len(d) != 5 or not np.all(np.isfinite(d)) or max(abs(v) for v in d) > 2.0:
            raise ValueError("distortion must be 5 finite numbers (k1, k2, p1, p2, k3), each "
                             f"in [-2, 2]; received {self.distortion!r}")
        object.__setattr__(self, "distortion", d)
        e = tuple(float(v) for v in np.ravel(np.asarray(self.intrinsics_error,
                                                        dtype=np.float64)))
        if len(e) != 3 or not all(np.isfinite(v) and 0 <= v for v in e) or e[0] > 0.2 \
                or e[1] > 100 or e[2] > 1.0:
            raise ValueError(
                "intrinsics_error must be 3 non-negative numbers (focal_fraction <= 0.2, "
                f"principal_point_px <= 100, distortion_fraction <= 1); received "
                f"{self.intrinsics_error!r}")
        object.__setattr__(self, "intrinsics_error", e)
        for name, hi in (("read_noise_dn", 255.0), ("shot_noise_dn", 255.0),
                         ("gain_log_std", 2.0), ("exposure_s", 1.0), ("readout_s", 1.0),
                         ("light_variation", 0.9), ("light_motion_deg", 180.0),
                         ("map_position_std_m", 0.1), ("map_rotation_std_deg", 10.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating)) \
                    or not np.isfinite(v) or not 0.0 <= v <= hi:
                raise ValueError(f"{name} must be a number in [0, {hi}]; received {v!r}")
        for name, lo, hi in (("jpeg_quality", 0, 100), ("subframes", 1, 64)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ValueError(f"{name} must be an integer in [{lo}, {hi}]; received {v!r}")

    @property
    def has_distortion(self) -> bool:
        return any(v != 0.0 for v in self.distortion)

    @property
    def has_map_error(self) -> bool:
        return self.map_position_std_m > 0 or self.map_rotation_std_deg > 0

    @property
    def timed(self) -> bool:
        """Whether frames need sub-frame renders (motion blur or rolling shutter)."""
        return self.subframes > 1 and (self.exposure_s > 0 or self.readout_s > 0)


#: The presets of ``vision.preset``; ``ideal`` has every effect off.
PRESETS: dict[str, CameraEffects] = {
    "ideal": CameraEffects(),
    "realistic": CameraEffects(
        distortion=(-0.12, 0.06, 4e-4, -3e-4, 0.0), intrinsics_error=(0.0005, 0.5, 0.01),
        read_noise_dn=2.0, shot_noise_dn=4.0, gain_log_std=0.08, jpeg_quality=85,
        exposure_s=0.008, readout_s=0.005, subframes=3, light_variation=0.25,
        light_motion_deg=30.0, map_position_std_m=0.0015, map_rotation_std_deg=0.4),
    "harsh": CameraEffects(
        distortion=(-0.28, 0.12, 1e-3, -8e-4, -0.02), intrinsics_error=(0.004, 3.0, 0.08),
        read_noise_dn=4.0, shot_noise_dn=8.0, gain_log_std=0.2, jpeg_quality=60,
        exposure_s=0.02, readout_s=0.033, subframes=5, light_variation=0.5,
        light_motion_deg=60.0, map_position_std_m=0.0015, map_rotation_std_deg=0.4),
}


def preset(name: str, **overrides) -> CameraEffects:
    """The preset ``name`` with some fields replaced; an unknown name lists the valid ones."""
    if name not in PRESETS:
        raise ValueError(f"unknown vision preset {name!r}; valid: {sorted(PRESETS)}")
    valid = [f.name for f in fields(CameraEffects)]
    bad = sorted(set(overrides) - set(valid))
    if bad:
        raise ValueError(f"unknown camera effect(s) {bad}; valid: {valid}")
    return replace(PRESETS[name], **overrides)


# --------------------------------------------------------------------------- distortion
def _pixel_grid(width: int, height: int) -> np.ndarray:
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    return np.stack([u, v], axis=-1)




def render_margin_px(K: np.ndarray, dist, width: int, height: int) -> tuple[int, int]:
    """Margins ``(mx, my)`` in pixels the pinhole render needs on each side so every pixel
    of the distorted ``width x height`` image samples inside it (plus 2 px for
    interpolation)."""
    if not any(float(v) != 0.0 for v in dist):
        return 0, 0
    grid = _pixel_grid(width, height)
    border = np.concatenate([grid[0], grid[-1], grid[:, 0], grid[:, -1]])
    und = undistort_points(border, K, dist)
    mx = max(0.0, -und[:, 0].min(), und[:, 0].max() - (width - 1))
    my = max(0.0, -und[:, 1].min(), und[:, 1].max() - (height - 1))
    return int(np.ceil(mx)) + 2, int(np.ceil(my)) + 2


def distortion_maps(K: np.ndarray, dist, width: int, height: int,
                    margin: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """``cv2.remap`` maps: for each pixel of the distorted image, where to sample the
    pinhole render of size ``(width + 2 mx, height + 2 my)`` (same focal length)."""
    mx, my = margin
    und = undistort_points(_pixel_grid(width, height), K, dist)
    return ((und[..., 0] + mx).astype(np.float32), (und[..., 1] + my).astype(np.float32))


# ----------------------------------------------------------------- blur, rolling shutter
def _span_s(eff: CameraEffects) -> float:
    return float(eff.readout_s + eff.exposure_s)


def subframe_offsets_s(eff: CameraEffects) -> np.ndarray:
    """Times of the sub-frame renders relative to the frame time, ``(subframes,)``; ``[0]``
    when the frame is a single instantaneous render."""
    if not eff.timed:
        return np.zeros(1)
    n, span = eff.subframes, _span_s(eff)
    return (np.arange(n) + 0.5) / n * span - span / 2


def row_weights(eff: CameraEffects, rows: int, first_row: float = 0.0,
                height: int | None = None) -> np.ndarray:
    """``(rows, subframes)`` weights (each row sums to 1) mixing the sub-frame renders.

    Row ``i`` of the rendered image is output row ``first_row + i`` of an image of
    ``height`` rows (the margin rows of a distortion render lie outside ``[0, height)``;
    they take the nearest row's time). Its exposure window is centred at
    ``(r / (height - 1) - 1/2) readout_s``; sub-frame ``s`` stands for time bin ``s``; the
    weight is the fraction of the window inside the bin (the bin containing the centre
    when the exposure is 0).
    """
    if not eff.timed:
        return np.ones((rows, 1))
    height = rows if height is None else height
    n, span = eff.subframes, _span_s(eff)
    r = np.clip(first_row + np.arange(rows, dtype=np.float64), 0, height - 1)
    centre = (r / max(height - 1, 1) - 0.5) * eff.readout_s
    edges = np.linspace(-span / 2, span / 2, n + 1)
    if eff.exposure_s <= 0:
        idx = np.clip(np.searchsorted(edges, centre, side="right") - 1, 0, n - 1)
        w = np.zeros((rows, n))
        w[np.arange(rows), idx] = 1.0
        return w
    lo = centre[:, None] - eff.exposure_s / 2
    hi = centre[:, None] + eff.exposure_s / 2
    overlap = np.clip(np.minimum(hi, edges[None, 1:]) - np.maximum(lo, edges[None, :-1]), 0, None)
    return overlap / overlap.sum(axis=1, keepdims=True)


def combine_subframes(images: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(S, H, W)`` images and ``(H, S)`` row weights -> ``(H, W)`` float32 image."""
    images = np.asarray(images)
    if images.shape[0] == 1:
        return images[0].astype(np.float32)
    w = np.asarray(weights, dtype=np.float32)
    out = np.zeros(images.shape[1:], dtype=np.float32)
    for s in range(images.shape[0]):
        ws = w[:, s]
        if np.any(ws > 0):
            out += images[s].astype(np.float32) * ws.reshape((-1,) + (1,) * (images.ndim - 2))
    return out


# ------------------------------------------------------------------------ sensor, JPEG
def apply_sensor(gray: np.ndarray, eff: CameraEffects, rng: np.random.Generator,
                 time_s: float = 0.0, phase: float = 0.0) -> np.ndarray:
    """Exposure/gain change, shot and read noise, quantisation: float image -> uint8."""
    img = np.asarray(gray, dtype=np.float32)
    if eff.gain_log_std > 0:
        drift = eff.gain_log_std * np.sin(2 * np.pi * 0.07 * time_s + phase)
        img = img * np.float32(np.exp(drift + eff.gain_log_std * rng.standard_normal()))
    if eff.read_noise_dn > 0 or eff.shot_noise_dn > 0:
        var = np.float32(eff.read_noise_dn ** 2) + np.float32(eff.shot_noise_dn ** 2 / 255.0) \
            * np.clip(img, 0, 255)
        img = img + np.sqrt(var) * rng.standard_normal(img.shape, dtype=np.float32)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def jpeg_roundtrip(gray: np.ndarray, quality: int) -> np.ndarray:
    """Encode and decode at ``quality`` (1–100); 0 returns the image unchanged."""
    if not quality:
        return gray
    import cv2  # noqa: PLC0415
    ok, buf = cv2.imencode(".jpg", gray, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:  # pragma: no cover - OpenCV always encodes uint8 grey
        raise RuntimeError("OpenCV failed to JPEG-encode the camera image")
    return cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)


# -------------------------------------------------------------------- calibration, light
def perturbed_calibration(K: np.ndarray, dist, eff: CameraEffects,
                          rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The calibration the estimator believes: ``(K_est, dist_est)``, the true ``(K, dist)``
    off by exactly the sizes of :attr:`CameraEffects.intrinsics_error` in random
    directions: focal length scaled by ``1 +- e_f`` (fx and fy together), principal point
    moved by ``e_c`` pixels in a random direction, each distortion coefficient scaled by
    ``1 +- e_k``. Fixed sizes (not standard deviations) keep the bias a run gets the one
    configured, whatever the seed."""
    ef, ec, ek = eff.intrinsics_error
    sign = rng.choice([-1.0, 1.0], size=6)
    phi = rng.uniform(0.0, 2.0 * np.pi)
    K_est = np.array(K, dtype=np.float64, copy=True)
    K_est[0, 0] *= 1.0 + ef * sign[0]
    K_est[1, 1] *= 1.0 + ef * sign[0]
    K_est[0, 2] += ec * np.cos(phi)
    K_est[1, 2] += ec * np.sin(phi)
    d_est = np.asarray(dist, dtype=np.float64) * (1.0 + ek * sign[1:6])
    return K_est, d_est


def perturbed_map(T_world_marker: np.ndarray, eff: CameraEffects,
                  rng: np.random.Generator) -> np.ndarray:
    """The marker poses the estimator's map holds, ``(M, 4, 4)``: each true
    ``T_world_marker`` composed with ``[dR | dt]`` in the marker's frame (paper eq. 38,
    :func:`simcalib.geometry.perturb_transforms`): ``dt ~ N(0, map_position_std_m^2 I)``,
    ``dR`` by an angle ``~ N(0, map_rotation_std_deg^2)`` about a uniform axis. Unchanged
    (a copy) when both are 0."""
    from simcalib.geometry import perturb_transforms  # noqa: PLC0415
    T = np.array(T_world_marker, dtype=np.float64, copy=True)
    if not eff.has_map_error or T.shape[0] == 0:
        return T
    return perturb_transforms(T, float(np.deg2rad(eff.map_rotation_std_deg)),
                              float(eff.map_position_std_m), rng)


def light_state(time_s: float, eff: CameraEffects, phase: float, flicker: float
                ) -> tuple[float, float]:
    """``(intensity scale, azimuth offset rad)`` of the scene lights at ``time_s``;
    ``flicker`` is a per-frame standard normal draw."""
    scale = 1.0 + eff.light_variation * (np.sin(2 * np.pi * 0.11 * time_s + phase)
                                         + 0.2 * flicker)
    yaw = np.deg2rad(eff.light_motion_deg) * np.sin(2 * np.pi * 0.05 * time_s + 2 * phase)
    return float(max(scale, 0.05)), float(yaw)
