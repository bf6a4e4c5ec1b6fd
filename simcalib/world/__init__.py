"""Simulated world: scene (room, cart/arm, two-camera rig, ArUco marker field), scripted
paths, IK, simulation to per-camera ground truth, and ground-truth / noisy pose streams.

Public API::

    from simcalib.world import WorldConfig, build_world, ground_truth_stream, noisy_stream
    world = build_world(WorldConfig(path="planar"), np.random.default_rng(0))
    gt_a = ground_truth_stream(world.trajectory.cam_a)
    noisy_b = noisy_stream(world.trajectory.cam_b, sigma_r_rad=0.01, sigma_t_m=0.01, rng=rng)

MuJoCo is imported lazily (only when a scene is built); configs and paths are light.
"""

from __future__ import annotations

import importlib

from simcalib.world.config import (PLATFORMS, ArmControlConfig, CameraConfig, IKConfig,
                                   MarkerFieldConfig, PerturbationConfig, RigConfig,
                                   RoomConfig, VehicleConfig, WorldConfig)
from simcalib.world.paths import PathInfo, available_paths, get_path, sample_path
from simcalib.world.sensors import delivered_mask, ground_truth_stream, noisy_stream

_LAZY = {
    "World": "simcalib.world.simulate",
    "SimCameraFrames": "simcalib.world.simulate",
    "build_world": "simcalib.world.simulate",
    "camera_poses_from_state": "simcalib.world.simulate",
    "Scene": "simcalib.world.scene",
    "build_scene": "simcalib.world.scene",
    "build_model": "simcalib.world.scene",
    "marker_layout": "simcalib.world.layout",
    "visible_markers": "simcalib.world.layout",
    "project_points": "simcalib.world.layout",
    "solve_ik": "simcalib.world.ik",
    "solve_ik_path": "simcalib.world.ik",
}

__all__ = sorted(["PLATFORMS", "ArmControlConfig", "VehicleConfig", "CameraConfig", "IKConfig", "MarkerFieldConfig",
                  "PerturbationConfig", "RigConfig", "RoomConfig", "WorldConfig", "PathInfo",
                  "available_paths", "get_path", "sample_path", "delivered_mask",
                  "ground_truth_stream", "noisy_stream", *_LAZY])


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'simcalib.world' has no attribute {name!r}")
