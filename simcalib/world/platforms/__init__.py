"""Platforms that carry the rig: one file per platform, a registry, the protocol.

    from simcalib.world.platforms import available_platforms, combinations, get_platform

The platforms are whatever files of this folder registered themselves
(``available_platforms()``, ``python -m simcalib list``): e.g. ``cart`` (kinematic mocap
cart), ``arm`` (UR5e posed by IK, or executing the IK path under joint control in physics),
``car`` (car-scale vehicle in physics, outdoors), ``pan_tilt`` (rotation only). Each module
is light (MuJoCo is imported inside the methods). See :mod:`simcalib.world.platforms.base`.
"""

from simcalib.world.platforms.base import Platform, PlatformInfo, PlatformMotion
# the platform files register themselves when the first lookup imports every module of
# this folder (PLATFORM_REGISTRY.load())
from simcalib.world.platforms.registry import (PLATFORM_REGISTRY, available_platforms,
                                               get_platform, register)
from simcalib.world.paths import combinations  # noqa: E402

__all__ = ["PLATFORM_REGISTRY", "Platform", "PlatformInfo", "PlatformMotion", "available_platforms",
           "combinations", "get_platform", "register"]
