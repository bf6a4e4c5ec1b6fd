"""The platform protocol: what carries the camera rig through a path.

A platform adds its bodies to the scene, says where the rig is mounted and where its
*target frame* (the frame a path moves: cart base, arm flange) sits at home, and turns the
path's target poses into MuJoCo states: kinematically (``drive``: the target frame is put
exactly on the path) or by a physics simulation that follows the path (``simulate``: the
states are where the simulated platform really is at the capture times). One file per
platform under ``simcalib/world/platforms/``; each registers itself (``register``). A
path states the platforms it was written for (:class:`simcalib.world.paths.PathInfo`
``defaults``); a platform adds the existing paths it drives (``PlatformInfo.paths``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Protocol, runtime_checkable

import numpy as np

__all__ = ["PlatformInfo", "PlatformMotion", "Platform"]


@dataclass(frozen=True)
class PlatformInfo:
    """``name`` (``world.platform=<name>``) and a one-line ``description``.
    ``outdoor``: the platform needs more space than a room (car scale): its scene has no
    walls, no ceiling and no marker field (so no ArUco source), and cameras may go
    anywhere.
    Facts the config's feasibility check predicts the cameras' paths from (no scene):
    ``clocked_by_path``: the scripted path's clock sets the motion (False: physics sets the
    speed, e.g. the car; no prediction is made); ``rig_mount_m``: the rig mount in the
    target frame, metres, rig +z = forward (cart: ``models/cart.xml`` site ``rig_mount``),
    or ``None`` when the target frame IS the rig mount and its home pose faces forward
    (the arm's flange).
    ``paths``: the registered paths it drives beyond those that name it themselves
    (:class:`simcalib.world.paths.PathInfo` ``defaults``), each with its default
    parameters on this platform (the path's parameter names, the platform's scale), so a
    new platform file runs existing paths without editing them."""
    name: str
    description: str
    outdoor: bool = False
    clocked_by_path: bool = True
    rig_mount_m: tuple[float, float, float] | None = None
    paths: Mapping[str, Mapping[str, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class PlatformMotion:
    """MuJoCo state of the platform at ``N`` times: ``qpos`` ``(N, nq)``, ``mocap_pos``
    ``(N, nmocap, 3)``, ``mocap_quat_wxyz`` ``(N, nmocap, 4)`` (MuJoCo order); ``stats``
    platform diagnostics for ``World.ik``/results (e.g. IK errors), or ``None``;
    ``record``: a simulated platform's full physics record (``VehicleTrajectory``,
    ``ArmTrajectory``), kept as ``World.platform_record``, or ``None``."""
    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat_wxyz: np.ndarray
    stats: dict | None = None
    record: object = None


@runtime_checkable
class Platform(Protocol):
    """A platform.

    * ``attach(spec, cfg) -> str``: add the platform to the room's ``mujoco.MjSpec``
      ``spec`` for ``cfg`` (:class:`~simcalib.world.config.WorldConfig`); return the full
      name of the site the rig is attached to.
    * ``home(model, data, mount_site, cfg) -> (T_world_home (4, 4), home_qpos (nq,))``:
      the target frame's home pose and the matching joint state of the compiled model.
    * ``drive(scene, T_world_target, t, cfg) -> PlatformMotion``: the states that put the
      target frame at ``T_world_target`` ``(N, 4, 4)`` at times ``t`` ``(N,)`` (seconds,
      increasing); raise ``ValueError`` naming the time when the path cannot be followed.

    Optional, for platforms driven by physics:

    * ``simulates(cfg) -> bool``: True when this configuration is simulated (then
      ``simulate`` is called instead of ``drive``).
    * ``simulate(scene, target_fn, t, cfg, rng) -> PlatformMotion``: the states at the
      capture times ``t`` of a simulation that follows the path; ``target_fn(tt)`` gives
      the target frame's path poses ``(M, 4, 4)`` at any times ``tt`` (the same path
      ``drive`` gets, sampled where the simulation needs it); ``rng`` a generator of its
      own (e.g. uneven ground). The states need not put the target frame on the path.
    """
    info: PlatformInfo

    def attach(self, spec, cfg) -> str: ...

    def home(self, model, data, mount_site: str, cfg) -> tuple[np.ndarray, np.ndarray]: ...

    def drive(self, scene, T_world_target: np.ndarray, t: np.ndarray,
              cfg) -> PlatformMotion: ...
