"""Registry of scripted paths (pure numpy, no MuJoCo).

A path moves the platform's *target frame* — the cart's base (mocap body) or the arm's
flange / rig mount — smoothly in time. Every path is written relative to the platform's
home pose ``T_world_home`` whose forward direction is world +x::

    T_world_target(t) = Trans(p_home + dp(t)) · Rz(yaw(t)) · Rx(roll(t)) · Ry(pitch(t)) · R_home

(rotations about world axes through the target, x = forward at yaw 0). Frequencies are
given in cycles per run, so a path's shape does not depend on ``duration_s``.
Names: ``3d``, ``planar``, ``linear``, ``circular``, ``rotation`` (the paper's real-data
motion types) and ``scara`` (arm: 3D translation, yaw only). Unknown names and senseless platform/path pairings raise ``ValueError``
listing what is allowed.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Callable, Mapping

import numpy as np

from simcalib.errors import ConfigError, did_you_mean, unknown_choice
from simcalib.registry import Registry

__all__ = ["PATHS", "PathInfo", "PathSample", "available_paths", "combinations", "get_path",
           "resolve_platform", "sample_path", "perturbation_sample", "compose_path"]


@dataclass(frozen=True)
class PathSample:
    """Offsets of a path at times ``t``: ``dp`` ``(N, 3)`` world-frame translation of the
    target from its home position, ``yaw``/``roll``/``pitch`` ``(N,)`` radians."""
    dp: np.ndarray
    yaw: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray


@dataclass(frozen=True)
class PathInfo:
    """A registered path: ``defaults`` maps each platform that can drive it to its default
    parameters (the allowed override keys) — the keys ARE the platforms the path supports
    (names of :mod:`simcalib.world.platforms`): those the path was written for, then
    those a platform adds (``PlatformInfo.paths``); ``fn(t, duration_s, params) ->
    PathSample``."""
    name: str
    description: str
    defaults: Mapping[str, Mapping[str, float]]
    fn: Callable = field(repr=False)
    degenerate: str = ""

    @property
    def platforms(self) -> tuple[str, ...]:
        return tuple(self.defaults)

    def params_for(self, platform: str, overrides: Mapping | None = None) -> dict:
        """Defaults for ``platform`` updated with ``overrides`` (validated)."""
        if platform not in self.defaults:
            _pairing_error(self, platform)
        params = dict(self.defaults[platform])
        for key, value in dict(overrides or {}).items():
            if key not in params:
                hint = did_you_mean(key, params)
                raise ConfigError(f"path {self.name!r} on {platform!r}: unknown parameter "
                                 f"{key!r}{hint}; allowed: {sorted(params)}")
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer,
                                                                 np.floating)):
                raise TypeError(f"path {self.name!r}: parameter {key!r} must be a number; "
                                f"received {value!r}")
            if not np.isfinite(value):
                raise ValueError(f"path {self.name!r}: parameter {key!r} must be finite; "
                                 f"received {value!r}")
            params[key] = float(value)
        return params


def _path_info(name: str, fn: Callable, *, description: str,
               defaults: Mapping[str, Mapping[str, float]], degenerate: str = "") -> PathInfo:
    return PathInfo(name, description, defaults, fn, degenerate)


#: name -> path function (info: :class:`PathInfo`); the paths are the functions below.
PATHS = Registry("path", key="world.path", info=_path_info)


def _register(name, description, defaults, degenerate=""):
    return PATHS.register(name, description=description, defaults=defaults,
                          degenerate=degenerate)


def available_paths() -> dict[str, PathInfo]:
    """All registered paths by name (metadata: platforms, description, default params)."""
    return dict(_merged())


def get_path(name: str) -> PathInfo:
    """The :class:`PathInfo` of ``name`` (unknown names: a ConfigError listing the valid
    ones, sorted)."""
    if isinstance(name, str) and name not in PATHS:
        raise unknown_choice("path", name, sorted(PATHS.names()), key="world.path")
    return _merged()[name]


#: (the registered paths and platforms) -> their merged PathInfos: rebuilt when an entry
#: is added or removed, so a lookup returns the same object while nothing changed
_MERGED: dict = {}


def _merged() -> dict[str, PathInfo]:
    from simcalib.world.platforms.registry import PLATFORM_REGISTRY
    key = (tuple((n, id(o)) for n, o in PATHS.items()),
           tuple((n, id(o)) for n, o in PLATFORM_REGISTRY.items()))
    if _MERGED.get("key") != key:
        extra = _platform_defaults()
        _MERGED.update(key=key, infos={name: _with(info, extra.get(name))
                                        for name, info in PATHS.available().items()})
    return _MERGED["infos"]


def combinations() -> dict[str, tuple[str, ...]]:
    """path name -> the registered platforms it supports."""
    from simcalib.world.platforms.registry import PLATFORM_REGISTRY
    registered = PLATFORM_REGISTRY.names()
    return {name: tuple(p for p in info.platforms if p in registered)
            for name, info in available_paths().items()}


def _with(info: PathInfo, extra: Mapping | None) -> PathInfo:
    return info if not extra else replace(info, defaults={**info.defaults, **extra})


def _platform_defaults() -> dict[str, dict[str, Mapping[str, float]]]:
    """path -> {platform: default parameters} that the registered platforms declare for
    the paths they drive (``PlatformInfo.paths``), checked: a registered path that does not
    name the platform itself, and exactly the path's parameters."""
    from simcalib.world.platforms.registry import available_platforms
    out: dict[str, dict[str, Mapping[str, float]]] = {}
    for platform, pinfo in available_platforms().items():
        for path, defaults in dict(pinfo.paths).items():
            if path not in PATHS:
                raise unknown_choice("path", path, sorted(PATHS.names()),
                                     key=f"platform {platform!r} paths")
            own = PATHS.info(path).defaults
            if platform in own:
                raise ValueError(f"platform {platform!r} declares defaults for path {path!r}, "
                                 "which names that platform itself; declare them once")
            params = sorted(next(iter(own.values())))
            if sorted(defaults) != params:
                raise ValueError(f"platform {platform!r}: defaults for path {path!r} must "
                                 f"give its parameters {params}; received {sorted(defaults)}")
            out.setdefault(path, {})[platform] = MappingProxyType(
                {k: float(v) for k, v in defaults.items()})
    return out


def _pairing_error(info: PathInfo, platform: str):
    paths = sorted(available_paths().items())
    valid = [n for n, p in paths if platform in p.defaults]
    combos = "; ".join(f"{n}: {list(p.platforms)}" for n, p in paths)
    raise ValueError(f"path {info.name!r} is not available on platform {platform!r}; "
                     f"platforms for {info.name!r}: {list(info.platforms)}; paths for "
                     f"{platform!r}: {valid}; valid path: [platforms] combinations: {combos}")


def resolve_platform(info: PathInfo, platform: str | None) -> str:
    """``platform`` validated against the path (``None`` -> the path's first platform)."""
    if platform is None:
        return info.platforms[0]
    if platform not in info.defaults:
        _pairing_error(info, platform)
    return platform


# ------------------------------------------------------------------------------- paths
def _w(t, duration_s, cycles):
    return 2.0 * np.pi * cycles * t / duration_s


def _zeros(t):
    return np.zeros_like(t)


@_register(
    "3d", "general smooth 6-DoF motion (Lissajous translation and roll/pitch/yaw; arm)",
    {"arm": {"amp_x_m": 0.10, "amp_y_m": 0.15, "amp_z_m": 0.12,
             "amp_roll_deg": 20.0, "amp_pitch_deg": 15.0, "amp_yaw_deg": 25.0,
             "cycles": 1.0}})
def _path_3d(t, T, p):
    c = p["cycles"]
    dp = np.stack([p["amp_x_m"] * np.sin(_w(t, T, 2 * c)),
                   p["amp_y_m"] * np.sin(_w(t, T, c) + 0.3),
                   p["amp_z_m"] * np.sin(_w(t, T, 3 * c) + 1.1)], axis=-1)
    return PathSample(dp,
                      np.deg2rad(p["amp_yaw_deg"]) * np.sin(_w(t, T, 2 * c) + 0.7),
                      np.deg2rad(p["amp_roll_deg"]) * np.sin(_w(t, T, 3 * c) + 2.0),
                      np.deg2rad(p["amp_pitch_deg"]) * np.sin(_w(t, T, c) + 0.4))


@_register(
    "scara", "SCARA-like motion: 3D translation (Lissajous) with rotation only about the "
             "vertical axis (yaw), no roll or pitch (arm)",
    {"arm": {"amp_x_m": 0.10, "amp_y_m": 0.15, "amp_z_m": 0.10, "amp_yaw_deg": 40.0,
             "cycles": 1.0}},
    degenerate="every rotation about the vertical axis (the classic SCARA degeneracy): "
               "translation of X along it is unobservable")
def _path_scara(t, T, p):
    c = p["cycles"]
    dp = np.stack([p["amp_x_m"] * np.sin(_w(t, T, 2 * c)),
                   p["amp_y_m"] * np.sin(_w(t, T, c) + 0.3),
                   p["amp_z_m"] * np.sin(_w(t, T, 3 * c) + 1.1)], axis=-1)
    return PathSample(dp, np.deg2rad(p["amp_yaw_deg"]) * np.sin(_w(t, T, 2 * c) + 0.7),
                      _zeros(t), _zeros(t))


@_register(
    "planar", "general planar motion: figure-eight translation with turning (x, y, yaw)",
    {"cart": {"amp_x_m": 0.6, "amp_y_m": 0.6, "yaw_turns": 1.0, "amp_yaw_deg": 30.0,
              "cycles": 1.0},
     "arm": {"amp_x_m": 0.10, "amp_y_m": 0.15, "yaw_turns": 0.0, "amp_yaw_deg": 30.0,
             "cycles": 1.0},
     # car: a 60 m x 24 m figure-eight (the physics car follows the geometry; its heading
     # is the path tangent, so the yaw parameters are ignored)
     "car": {"amp_x_m": 30.0, "amp_y_m": 12.0, "yaw_turns": 0.0, "amp_yaw_deg": 0.0,
             "cycles": 1.0}},
    degenerate="all rotations about the vertical axis: translation of X along it is "
               "unobservable")
def _path_planar(t, T, p):
    c = p["cycles"]
    dp = np.stack([p["amp_x_m"] * np.sin(_w(t, T, c)),
                   p["amp_y_m"] * np.sin(_w(t, T, 2 * c)),
                   _zeros(t)], axis=-1)
    yaw = _w(t, T, p["yaw_turns"]) + np.deg2rad(p["amp_yaw_deg"]) * np.sin(_w(t, T, 3 * c))
    return PathSample(dp, yaw, _zeros(t), _zeros(t))


@_register(
    "linear", "straight line back and forth, constant orientation",
    {"cart": {"amp_m": 1.0, "direction_deg": 90.0, "cycles": 1.0},
     "arm": {"amp_m": 0.2, "direction_deg": 90.0, "cycles": 1.0},
     "car": {"amp_m": 25.0, "direction_deg": 0.0, "cycles": 0.5}},   # one pass, forward
    degenerate="no rotation: X's translation is unobservable")
def _path_linear(t, T, p):
    s = -p["amp_m"] * np.cos(_w(t, T, p["cycles"]))
    d = np.deg2rad(p["direction_deg"])
    dp = np.stack([s * np.cos(d), s * np.sin(d), _zeros(t)], axis=-1)
    return PathSample(dp, _zeros(t), _zeros(t), _zeros(t))


@_register(
    "circular", "a circle in the horizontal plane, facing outwards (rotation about a fixed "
                "vertical axis); full turns, or a back-and-forth arc when arc_deg > 0",
    {"cart": {"radius_m": 0.8, "turns": 1.0, "arc_deg": 0.0, "centre_back_m": 0.0},
     "arm": {"radius_m": 0.2, "turns": 0.0, "arc_deg": 70.0, "centre_back_m": 0.2},
     "car": {"radius_m": 15.0, "turns": 1.0, "arc_deg": 0.0, "centre_back_m": 0.0}},
    degenerate="one fixed rotation axis: translation of X along it is unobservable")
def _path_circular(t, T, p):
    theta = _sweep(t, T, p)
    # circle centre = home - centre_back_m * forward; target starts at centre + r * forward
    cx = -p["centre_back_m"]
    r = p["radius_m"]
    dp = np.stack([cx + r * np.cos(theta), r * np.sin(theta), _zeros(t)], axis=-1)
    return PathSample(dp, theta, _zeros(t), _zeros(t))


@_register(
    "rotation", "rotation in place about the vertical axis through the target; full turns, "
                "or a back-and-forth sweep when arc_deg > 0",
    {"cart": {"turns": 1.0, "arc_deg": 0.0},
     "arm": {"turns": 0.0, "arc_deg": 90.0}},
    degenerate="one fixed rotation axis: translation of X along it is unobservable")
def _path_rotation(t, T, p):
    return PathSample(np.zeros(t.shape + (3,)), _sweep(t, T, p), _zeros(t), _zeros(t))


def _sweep(t, T, p):
    if p.get("arc_deg", 0.0) > 0:
        return 0.5 * np.deg2rad(p["arc_deg"]) * np.sin(_w(t, T, 1.0))
    return _w(t, T, p["turns"])


# ------------------------------------------------------------------------ evaluation
def sample_path(name: str, platform: str, t, duration_s: float,
                overrides: Mapping | None = None) -> PathSample:
    """Evaluate path ``name`` for ``platform`` at times ``t`` (s)."""
    info = get_path(name)
    params = info.params_for(platform, overrides)
    t = np.asarray(t, dtype=np.float64)
    return info.fn(t, float(duration_s), params)


def perturbation_sample(t, cfg, rng: np.random.Generator) -> PathSample:
    """Smooth random roll/pitch/height perturbation (``PerturbationConfig``), seeded."""
    t = np.asarray(t, dtype=np.float64)
    out = []
    for amp in (cfg.roll_deg, cfg.pitch_deg, cfg.height_m):
        f = rng.uniform(cfg.min_freq_hz, cfg.max_freq_hz, size=3)
        ph = rng.uniform(0.0, 2.0 * np.pi, size=3)
        s = np.sin(2.0 * np.pi * f[None, :] * t[:, None] + ph[None, :]).sum(axis=1) / 3.0
        out.append(amp * s)
    roll, pitch, height = out
    dp = np.zeros(t.shape + (3,))
    dp[..., 2] = height
    return PathSample(dp, np.zeros_like(t), np.deg2rad(roll), np.deg2rad(pitch))


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(angle.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def compose_path(T_world_home: np.ndarray, *samples: PathSample) -> np.ndarray:
    """``(N, 4, 4)`` target poses from the home pose and summed path samples."""
    dp = sum(s.dp for s in samples)
    yaw = sum(s.yaw for s in samples)
    roll = sum(s.roll for s in samples)
    pitch = sum(s.pitch for s in samples)
    R = _rot(2, yaw) @ _rot(0, roll) @ _rot(1, pitch) @ T_world_home[:3, :3]
    out = np.zeros(yaw.shape + (4, 4))
    out[..., :3, :3] = R
    out[..., :3, 3] = T_world_home[:3, 3] + dp
    out[..., 3, 3] = 1.0
    return out
