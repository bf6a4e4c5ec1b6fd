"""Source ``aruco``: render each camera, detect the marker field, PnP (``cfg.vision``)."""

from __future__ import annotations

from simcalib.sources.base import GroundTruth, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["ArucoSource"]


class ArucoSource:
    info = SourceInfo(name="aruco", kinds=("sim",), rng_stream="vision", renders=True,
                      description="rendered images -> ArUco detection -> camera pose by PnP "
                                  "against the known marker map (vision.*)")

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        from simcalib.vision import visual_streams  # heavy (cv2, mujoco rendering): lazy
        streams, log = visual_streams(truth.world, cfg.vision, rng, workers=cfg.workers)
        return SourceOutput(streams={cam: streams[cam] for cam in cameras}, log=log)


register(ArucoSource())
