"""Simulated world: scene (room, cart/arm, two-camera rig, ArUco marker field), scripted
paths, IK, simulation to per-camera ground truth, and ground-truth / noisy pose streams.

Public API::

    from simcalib.world import WorldConfig, build_world, ground_truth_stream, noisy_stream
    world = build_world(WorldConfig(path="planar"), np.random.default_rng(0))
    gt_a = ground_truth_stream(world.trajectory.cam_a)
    noisy_b = noisy_stream(world.trajectory.cam_b, sigma_r_rad=0.01, sigma_t_m=0.01, rng=rng)

MuJoCo is imported when a scene is built (``simcalib.world.render_backend.import_mujoco``),
not here; the names below are looked up in their module at first use (PEP 562), so importing
a config-only module (``simcalib.world.config``) loads neither the scene nor the rendering.
"""

from __future__ import annotations

import importlib

#: public name -> the module of this package that defines it
_FACE = {
    **{n: "config" for n in ("ArmControlConfig", "CameraConfig", "IKConfig",
                             "MarkerFieldConfig", "PerturbationConfig", "RigConfig",
                             "RoomConfig", "VehicleConfig", "WorldConfig")},
    **{n: "paths" for n in ("PathInfo", "available_paths", "get_path", "sample_path")},
    **{n: "sensors" for n in ("delivered_mask", "ground_truth_stream", "noisy_stream")},
    **{n: "ik" for n in ("solve_ik", "solve_ik_path")},
    **{n: "layout" for n in ("marker_layout", "project_points", "visible_markers")},
    **{n: "scene" for n in ("Scene", "build_model", "build_scene")},
    **{n: "simulate" for n in ("SimCameraFrames", "World", "build_world",
                               "camera_poses_from_state")},
}

__all__ = sorted(_FACE)


def __getattr__(name: str):
    module = _FACE.get(name)
    if module is None:
        raise AttributeError(f"module 'simcalib.world' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"simcalib.world.{module}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_FACE))
