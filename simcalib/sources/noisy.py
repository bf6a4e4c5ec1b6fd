"""Source ``noisy``: ground truth corrupted by the paper's eq. 38 noise (``cfg.noise``)."""

from __future__ import annotations

import math

import numpy as np

from simcalib.sources.base import CAMERAS, GroundTruth, SourceHooks, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["NoisySource"]


class NoisySource(SourceHooks):
    info = SourceInfo(name="noisy", synthetic_stand_in=True, kinds=("sim",), rng_stream="noise",
                      description="ground truth with Gaussian pose noise (paper eq. 38; "
                                  "noise.sigma_r_deg, noise.sigma_t_m)")

    def pose_margins(self, cfg) -> tuple[float, float]:
        """4 sigma of the difference of two noisy poses (translation m, rotation deg)."""
        k = 4.0 * math.sqrt(2.0)
        return k * cfg.noise.sigma_t_m * math.sqrt(3.0), k * cfg.noise.sigma_r_deg

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        from simcalib.world.sensors import noisy_stream
        rngs = dict(zip(CAMERAS, rng.spawn(len(CAMERAS))))
        return SourceOutput(streams={
            cam: noisy_stream(truth.world.frames(cam), np.deg2rad(cfg.noise.sigma_r_deg),
                              cfg.noise.sigma_t_m, rngs[cam]) for cam in cameras})


register(NoisySource())
