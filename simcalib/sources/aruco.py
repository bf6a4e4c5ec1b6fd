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
        import dataclasses
        from simcalib.vision import visual_streams  # heavy (cv2, mujoco rendering): lazy
        world = truth.world
        if set(cameras) != set(world.camera_names):   # per-stream selection: render only these
            world = dataclasses.replace(world, camera_names=tuple(
                c for c in world.camera_names if c in cameras))
        streams, log = visual_streams(world, cfg.vision, rng, workers=cfg.workers,
                                      rig_entropy=truth.rig_entropy.get(self.info.rng_stream))
        return SourceOutput(streams={cam: streams[cam] for cam in cameras}, log=log)


register(ArucoSource())
