"""Source ``aruco``: render each camera, detect the marker field, PnP (``cfg.vision``)."""

from __future__ import annotations

import numpy as np

from simcalib.sources.base import GroundTruth, SourceHooks, SourceInfo, SourceOutput
from simcalib.sources.registry import register

__all__ = ["ArucoSource"]


class ArucoSource(SourceHooks):
    info = SourceInfo(name="aruco", kinds=("sim",), rng_stream="vision", renders=True,
                      needs_markers=True,
                      description="rendered images -> ArUco detection -> camera pose by PnP "
                                  "against the known marker map (vision.*)")

    def pose_margins(self, cfg) -> tuple[float, float]:
        """1 cm / 0.5 deg: about twice the p95 visual pose error of the default world
        (docs/vision.md)."""
        return 0.01, 0.5

    def error_basis(self, world, cfg, cam, T_world_cam, layout, qpos=None, visible=None):
        """The marker map's and the camera's calibration errors
        (:func:`simcalib.sources.vision.error_model.pose_error_basis`; ``visible`` the markers each
        pose rests on, default the layout's) in the ``map`` and ``cal_a`` / ``cal_b`` columns."""
        if world.marker_field is None:
            return None
        from simcalib.sources.vision.error_model import pose_error_basis as vision_basis
        T = np.asarray(T_world_cam, dtype=np.float64)
        V = vision_basis(world, cam, T, cfg.vision, visible=visible)
        if not V.any():
            return None
        B = np.zeros((T.shape[0], 6, layout["P"]))
        B[:, :, layout["map"]] = V[:, :, :layout["map"].stop]
        B[:, :, layout["cal_a" if cam == "cam_a" else "cal_b"]] = V[:, :, layout["map"].stop:]
        return B

    def datapoint_error_basis(self, st, world, cam, T_world_cam, frame_index, layout):
        """:meth:`error_basis` with the markers the PnP rested on at each datapoint."""
        return self.error_basis(world, st.cfg, cam, T_world_cam, layout,
                                visible=self._markers_used(st, world, cam, frame_index))

    def _markers_used(self, st, world, cam, frame_index):
        """``(F, M)`` bool: the map markers the PnP of ``cam`` rested on at each frame (the
        visual log's ``ids_used``), or None without a visual log for the camera."""
        log = st.source_logs.get(self.info.name)
        frames = getattr(log, "frames", {}).get(cam) if log is not None else None
        field = world.marker_field
        if not frames or field is None or field.T_world_marker.shape[0] == 0:
            return None                     # no marker map (a board target)
        vis = np.zeros((len(frame_index), field.T_world_marker.shape[0]), dtype=bool)
        for k, f in enumerate(frame_index):
            rows = field.index_of(np.asarray(frames[int(f)].ids_used))
            vis[k, rows[rows >= 0]] = True
        return vis

    def calibration_bias(self, world, cfg, cameras) -> dict:
        """What ``vision.intrinsics_error`` and the marker map's error cause
        (:func:`simcalib.sources.vision.error_model.calibration_pose_bias`, no rendering)."""
        from simcalib.sources.vision.error_model import calibration_pose_bias
        cams = [c for c in cameras if c in world.camera_names]
        return calibration_pose_bias(world, cfg.vision, cameras=cams) if cams else {}

    def measure(self, truth: GroundTruth, cfg, rng, cameras) -> SourceOutput:
        import dataclasses
        from simcalib.sources.vision.stream import visual_streams  # heavy (cv2, mujoco rendering): lazy
        world = truth.world
        if set(cameras) != set(world.camera_names):   # per-stream selection: render only these
            world = dataclasses.replace(world, camera_names=tuple(
                c for c in world.camera_names if c in cameras))
        from simcalib.progress import frame_progress
        streams, log = visual_streams(world, cfg.vision, rng, workers=cfg.workers,
                                      progress=frame_progress(),
                                      rig_entropy=truth.rig_entropy.get(self.info.rng_stream))
        return SourceOutput(streams={cam: streams[cam] for cam in cameras}, log=log)


register(ArucoSource())
