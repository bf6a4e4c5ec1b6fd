"""Source ``synthetic``: the noisy relative motions of a paper appendix D.2 problem.

The synthetic generator measures relative motions ``(C_i, H_i)`` directly (its noise is
``synthetic.sigma_*``, synced with ``noise.*``), so this source returns motions, not pose
streams, and the errors of those motions against the true ones."""

from __future__ import annotations

import numpy as np

from simcalib.sources.base import GroundTruth, SourceHooks, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["SyntheticSource"]


class SyntheticSource(SourceHooks):
    # draws nothing: the motions' noise was drawn with the problem (world stage)
    info = SourceInfo(name="synthetic", kinds=("synthetic",), rng_stream="noise",
                      example=("random",),
                      description="relative motions of a paper appendix D.2 problem "
                                  "(random / line / circle), noise from noise.*")

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        from simcalib.evaluation import PoseErrors
        from simcalib.geometry import rotation_error_rad
        from simcalib.estimation.pairing import pairs_from_motions
        syn = truth.synthetic
        ds = syn.dataset
        idx = np.asarray(syn.indices)
        measured = {"cam_a": (syn.C, ds.C_true[idx]), "cam_b": (syn.H, ds.H_true[idx])}
        errors = {}
        for cam in cameras:
            M, M_true = measured[cam]
            errors[cam] = PoseErrors(
                camera=cam, source=f"{cfg.source} (relative motions)", frame_index=idx,
                rotation_deg=np.rad2deg(rotation_error_rad(M, M_true)),
                translation_m=np.linalg.norm(M[:, :3, 3] - M_true[:, :3, 3], axis=-1))
        frames = {"rendered": 0, "generated_motions": int(ds.num_motions)}
        frames |= {cam: {"used": int(idx.size), "dropped": 0, "drop_reasons": {}}
                   for cam in cameras}
        return SourceOutput(motions=pairs_from_motions(syn.C, syn.H), pose_errors=errors,
                            frames=frames, pairing_mode="random (appendix D sampling)")


register(SyntheticSource())
