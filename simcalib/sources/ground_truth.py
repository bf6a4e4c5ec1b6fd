"""Source ``ground_truth``: the exact camera poses (delivered frames only)."""

from __future__ import annotations

from simcalib.sources.base import GroundTruth, SourceHooks, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["GroundTruthSource"]


class GroundTruthSource(SourceHooks):
    info = SourceInfo(name="ground_truth", synthetic_stand_in=True, kinds=("sim",), rng_stream="noise", exact=True,
                      description="the exact poses of the simulated cameras (no noise)")

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        return SourceOutput(streams={cam: truth.streams[cam] for cam in cameras})


register(GroundTruthSource())
