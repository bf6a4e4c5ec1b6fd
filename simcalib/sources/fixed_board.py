"""Source ``fixed_board``: eye-to-hand's board stream (``world.arm.mount=eye_to_hand``).

The fixed camera on the stand (:data:`simcalib.world.eyetohand.FIXED_CAMERA`) is rendered
at every delivered frame of cam_b (cam_b's frame is the board frame on the flange), the
image goes through the camera effects of ``vision.preset`` (noise, blur, distortion,
calibration error; :class:`simcalib.sources.vision.frame.FrameProcessor`), the board on the
flange is detected and its pose ``T_cam_board`` estimated by PnP
(:mod:`simcalib.targets.boards`). The
stream reports ``T_world_board = T_world_cam · T_cam_board`` in the room like every other
source; the pipeline re-expresses cam_b in the fixed camera's frame
(:func:`simcalib.world.eyetohand.express_in_fixed_camera`), so the solvers see
``T_cam_board``. The fixed camera has cam_b's intrinsics (``world.cam_b``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from simcalib.sources.base import GroundTruth, SourceHooks, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["FixedBoardSource"]


def _check(world, cameras) -> None:
    cfg = world.config
    if cfg.platform != "arm" or cfg.arm.mount != "eye_to_hand" or cfg.target == "marker_wall":
        raise ValueError("source fixed_board needs world.platform='arm', "
                         "world.arm.mount='eye_to_hand' and a board target (world.target "
                         f"charuco or apriltag_grid); received platform={cfg.platform!r}, "
                         f"mount={cfg.arm.mount!r}, target={cfg.target!r}")
    if tuple(cameras) != ("cam_b",):
        raise ValueError("source fixed_board measures the board (cam_b) only; use it as "
                         f"streams.b.source; it was asked for {list(cameras)}")


class FixedBoardSource(SourceHooks):
    info = SourceInfo(name="fixed_board", kinds=("sim",), rng_stream="vision", renders=True,
                      cameras=("cam_b",), example=("eyetohand",),
                      description="eye-to-hand: the fixed stand camera's rendered images -> "
                                  "detection of the board on the flange -> its pose by PnP")

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        from simcalib.sources.vision import stream as V
        from simcalib.sources.vision.frame import FrameProcessor, camera_optics
        from simcalib.progress import frame_progress
        from simcalib.geometry import invert_transform
        from simcalib.world.eyetohand import FIXED_CAMERA, T_world_fixed_camera
        world = truth.world
        _check(world, cameras)
        vcfg = cfg.vision
        entropy = int(rng.integers(0, 2**63 - 1))
        intr = {FIXED_CAMERA: world.intrinsics["cam_b"]}
        eff = vcfg.effects()
        optics = camera_optics((FIXED_CAMERA,), intr, eff, entropy)
        proc = FrameProcessor(None, {FIXED_CAMERA: intr[FIXED_CAMERA].K}, {FIXED_CAMERA: 0},
                              vcfg, entropy, optics, world.config.board, np.eye(4))
        fr = world.frames("cam_b")
        light_phase = float(np.random.default_rng(np.random.SeedSequence(
            entropy, spawn_key=(10**6,))).uniform(0, 2 * np.pi))
        jobs = [dataclasses.replace(j, camera=FIXED_CAMERA, check_points=None) for j in
                V._camera_jobs(world, "cam_b", fr, intr[FIXED_CAMERA],
                               dataclasses.replace(vcfg, count_occlusion=False), eff,
                               V._subframe_offsets(eff), light_phase, {})]
        (w, h), = V._render_sizes((FIXED_CAMERA,), intr, optics)
        settings = V._render_settings(w, h, (FIXED_CAMERA,), intr, vcfg)
        results, _, interrupted = V._render_pass(world.model, settings, jobs, proc,
                                                 cfg.workers, frame_progress(), 0, len(jobs))
        if interrupted is not None:
            raise interrupted
        T_world_cam = T_world_fixed_camera(world.config)
        fixed = [dataclasses.replace(r, T_world_cam=T_world_cam @ invert_transform(
            r.T_world_cam)) if r.T_world_cam is not None else r for r in results]
        stream, _, _ = V._camera_outputs("cam_b", fr, fixed, {})
        stream = dataclasses.replace(stream, source="fixed_board")
        log = {"camera": FIXED_CAMERA, "used": int(stream.n_used),
               "drop_reasons": dict(stream.drop_reasons),
               "reproj_rmse_px_median": float(np.median(stream.info["reproj_rmse_px"]))
               if stream.n_used else None}
        return SourceOutput(streams={"cam_b": stream}, log=log)


register(FixedBoardSource())
