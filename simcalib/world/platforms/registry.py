"""Registry of platforms (unknown names list the valid ones) and the valid
platform x path combinations."""

from __future__ import annotations

from simcalib.errors import unknown_choice
from simcalib.world.platforms.base import Platform, PlatformInfo

__all__ = ["register", "get_platform", "available_platforms", "combinations"]

_PLATFORMS: dict[str, Platform] = {}


def register(platform: Platform) -> Platform:
    info = getattr(platform, "info", None)
    if not isinstance(info, PlatformInfo) or not all(
            callable(getattr(platform, m, None)) for m in ("attach", "home", "drive")):
        raise TypeError("a platform needs info: PlatformInfo and attach/home/drive methods; "
                        f"received {type(platform).__name__}")
    if info.name in _PLATFORMS and _PLATFORMS[info.name] is not platform:
        raise ValueError(f"platform {info.name!r} is already registered")
    _PLATFORMS[info.name] = platform
    return platform


def available_platforms() -> dict[str, PlatformInfo]:
    """name -> :class:`PlatformInfo`, in registration order."""
    return {name: p.info for name, p in _PLATFORMS.items()}


def combinations() -> dict[str, tuple[str, ...]]:
    """path name -> the registered platforms it supports."""
    from simcalib.world.paths import available_paths
    return {name: tuple(p for p in info.platforms if p in _PLATFORMS)
            for name, info in available_paths().items()}


def get_platform(name: str) -> Platform:
    if not isinstance(name, str):
        raise TypeError(f"platform name must be a string; received {type(name).__name__}")
    try:
        return _PLATFORMS[name]
    except KeyError:
        raise unknown_choice("platform", name, _PLATFORMS, key="world.platform") from None
