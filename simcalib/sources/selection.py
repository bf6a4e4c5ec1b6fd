"""Per-stream source selection (``streams.a.source``, ``streams.b.source``).

Stream ``a`` is camera ``cam_a``, stream ``b`` is ``cam_b``. ``None`` (default) uses the
run's ``source``. Eye-in-hand (``scenarios/handeye.yaml``): ``streams.a.source=robot_fk``
makes stream ``a`` the arm's flange as the robot reports it (cam_a's frame is placed on the
flange, ``world.rig.rig_cam_a_* = 0``), ``streams.b.source=aruco`` the wrist camera, so the
estimated ``X = T_a_b = T_flange_cam``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from simcalib.config.checks import check_that
from simcalib.sources.base import CAMERAS

__all__ = ["StreamSourceConfig", "StreamsConfig", "STREAM_CAMERAS"]

#: stream key -> camera name (``a`` -> ``cam_a``: the key is the camera's suffix)
STREAM_CAMERAS = {cam.removeprefix("cam_"): cam for cam in CAMERAS}


@dataclass(frozen=True)
class StreamSourceConfig:
    """One stream's pose source (a registered source name; ``None``: the run's
    ``source``)."""
    source: str | None = field(default=None, metadata={"help": (
        "pose source of this stream (a registered source: python -m simcalib list); null: "
        "the run's source")})

    def __post_init__(self):
        check_that(self.source is None or isinstance(self.source, str), "source",
                   self.source, "a source name or null")


@dataclass(frozen=True)
class StreamsConfig:
    """Per-stream settings: ``a`` (cam_a) and ``b`` (cam_b)."""
    a: StreamSourceConfig = field(default_factory=StreamSourceConfig)
    b: StreamSourceConfig = field(default_factory=StreamSourceConfig)

    def source_of(self, camera: str, default: str) -> str:
        for key, cam in STREAM_CAMERAS.items():
            if cam == camera:
                s = getattr(self, key).source
                return default if s is None else s
        raise ValueError(f"unknown camera {camera!r}; valid: {list(STREAM_CAMERAS.values())}")

    @property
    def any_set(self) -> bool:
        return self.a.source is not None or self.b.source is not None
