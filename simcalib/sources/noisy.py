"""Source ``noisy``: ground truth corrupted by the paper's eq. 38 noise (``cfg.noise``)."""

from __future__ import annotations

import numpy as np

from simcalib.sources.base import CAMERAS, GroundTruth, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["NoisySource"]


class NoisySource:
    info = SourceInfo(name="noisy", kinds=("sim",), rng_stream="noise",
                      description="ground truth with Gaussian pose noise (paper eq. 38; "
                                  "noise.sigma_r_deg, noise.sigma_t_m)")

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        from simcalib.world.sensors import noisy_stream
        rngs = dict(zip(CAMERAS, rng.spawn(len(CAMERAS))))
        return SourceOutput(streams={
            cam: noisy_stream(truth.world.frames(cam), np.deg2rad(cfg.noise.sigma_r_deg),
                              cfg.noise.sigma_t_m, rngs[cam]) for cam in cameras})


register(NoisySource())
