"""Registry of platforms (unknown names list the valid ones); the valid platform x path
combinations are :func:`simcalib.world.paths.combinations`.

:data:`PLATFORM_REGISTRY` is a :class:`simcalib.registry.Registry` over the package
``simcalib.world.platforms``: the first lookup imports every module of that folder, so a
new platform file that calls :func:`register` at import is found with no import list to
edit."""

from __future__ import annotations

from simcalib.registry import Registry
from simcalib.world.platforms.base import Platform, PlatformInfo

__all__ = ["PLATFORM_REGISTRY", "register", "get_platform", "available_platforms"]


def _check_platform(name: str, platform) -> None:
    info = getattr(platform, "info", None)
    if not isinstance(info, PlatformInfo) or not all(
            callable(getattr(platform, m, None)) for m in ("attach", "home", "drive")):
        raise TypeError("a platform needs info: PlatformInfo and attach/home/drive methods; "
                        f"received {type(platform).__name__}")


PLATFORM_REGISTRY: Registry[Platform] = Registry(
    "platform", key="world.platform", package="simcalib.world.platforms",
    check=_check_platform)


def register(platform: Platform) -> Platform:
    """Add ``platform`` under ``platform.info.name``; a second one of that name is
    refused."""
    _check_platform("", platform)
    return PLATFORM_REGISTRY.register(platform.info.name, platform)


def available_platforms() -> dict[str, PlatformInfo]:
    """name -> :class:`PlatformInfo`, in registration order."""
    return PLATFORM_REGISTRY.available()


def get_platform(name: str) -> Platform:
    """The platform ``name`` (unknown names: a ConfigError listing the valid ones)."""
    return PLATFORM_REGISTRY.get(name)
