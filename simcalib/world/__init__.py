"""Simulated world: scene (room, cart/arm, two-camera rig, ArUco marker field), scripted
paths, IK, simulation to per-camera ground truth, and ground-truth / noisy pose streams.

Public API::

    from simcalib.world import WorldConfig, build_world, ground_truth_stream, noisy_stream
    world = build_world(WorldConfig(path="planar"), np.random.default_rng(0))
    gt_a = ground_truth_stream(world.trajectory.cam_a)
    noisy_b = noisy_stream(world.trajectory.cam_b, sigma_r_rad=0.01, sigma_t_m=0.01, rng=rng)

MuJoCo is imported when a scene is built (``simcalib.render.import_mujoco``), not here.
"""

from __future__ import annotations

from simcalib.world.config import (PLATFORMS, ArmControlConfig, CameraConfig, IKConfig,
                                   MarkerFieldConfig, PerturbationConfig, RigConfig,
                                   RoomConfig, VehicleConfig, WorldConfig)
from simcalib.world.paths import PathInfo, available_paths, get_path, sample_path
from simcalib.world.sensors import delivered_mask, ground_truth_stream, noisy_stream
from simcalib.world.ik import solve_ik, solve_ik_path
from simcalib.world.layout import marker_layout, project_points, visible_markers
from simcalib.world.scene import Scene, build_model, build_scene
from simcalib.world.simulate import SimCameraFrames, World, build_world, camera_poses_from_state

__all__ = sorted(["PLATFORMS", "ArmControlConfig", "VehicleConfig", "CameraConfig", "IKConfig", "MarkerFieldConfig",
                  "PerturbationConfig", "RigConfig", "RoomConfig", "WorldConfig", "PathInfo",
                  "available_paths", "get_path", "sample_path", "delivered_mask",
                  "ground_truth_stream", "noisy_stream", "World", "SimCameraFrames", "build_world",
                  "camera_poses_from_state", "Scene", "build_scene", "build_model",
                  "marker_layout", "visible_markers", "project_points", "solve_ik",
                  "solve_ik_path"])

