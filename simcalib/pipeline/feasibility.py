"""Feasibility of a simulated scenario, checked before any work: a source the platform
cannot carry (no marker field outdoors) and a path that moves too far between frames for
the pairing pre-filter. The facts come from their owners: the pose source's margins
(``source.pose_margins(cfg)``) and the platform's mount and clock (``PlatformInfo``).
"""

from __future__ import annotations

import math

from simcalib.errors import ConfigError

__all__ = ["check_outdoor_source", "check_path_feasible"]


def check_outdoor_source(cfg) -> None:
    """An outdoor platform (``car``) has no marker field: no source that measures against
    one (``SourceInfo.needs_markers``, e.g. ArUco)."""
    from simcalib.sources import get_source
    if not get_source(cfg.source, cfg.kind).info.needs_markers:
        return
    from simcalib.world.platforms import get_platform
    if get_platform(cfg.world.platform).info.outdoor:
        raise ConfigError(f"source={cfg.source} needs a marker field, and platform "
                          f"{cfg.world.platform!r} drives outdoors at car scale where the "
                          "simulated world has none; use source=noisy (realistic pose noise "
                          "via noise.*) or source=ground_truth", key="source",
                          value=cfg.source)


def check_path_feasible(cfg) -> None:
    """Reject, before any work, a world whose path moves too far between frames for the
    pairing pre-filter to keep two motions.

    Paths are defined in cycles per run, so a shorter ``world.duration_s`` (or a lower
    ``fps``) compresses the whole path: the motion between paired frames grows as
    ``cycles / (duration_s * fps)``. Both cameras' paths are predicted from the scripted
    path (:func:`_surviving_pairs`) and the pairs within ``pairing.max_rotation_deg`` /
    ``pairing.max_translation_m`` counted, allowing for the pose source's errors (a
    measured motion may look smaller than the true one): only a configuration that
    surely fails is rejected; a marginal one still runs.
    The message names the shortest duration that passes."""
    world, pairing = cfg.world, cfg.pairing
    if not pairing.prefilter:
        return
    from simcalib.world.platforms import get_platform
    if not get_platform(world.platform).info.clocked_by_path:   # physics sets the speed
        return
    if math.isinf(pairing.max_translation_m) and math.isinf(pairing.max_rotation_deg):
        return
    import numpy as np
    margins = _pose_margins(cfg)
    survivors = _surviving_pairs(world, pairing, world.duration_s, margins)
    if survivors >= 2:
        return
    duration = math.nan
    for k in range(1, 40):   # the shortest whole number of seconds found to work
        candidate = float(math.ceil(world.duration_s * 1.25 ** k))
        if candidate <= 3600.0 and _surviving_pairs(world, pairing, candidate, margins) >= 2:
            duration = candidate
            break
    suggestion = (f"world.duration_s >= {duration:g} at fps={world.fps:g}"
                  if np.isfinite(duration) else "a slower path")
    raise ConfigError(
        f"world.duration_s={world.duration_s:g} (fps={world.fps:g}) compresses path "
        f"{world.path!r} (defined in cycles per run) so much that at most {survivors} frame "
        f"pair(s) can stay within pairing.max_translation_m={pairing.max_translation_m:g} and "
        f"pairing.max_rotation_deg={pairing.max_rotation_deg:g}; at least 2 are needed. "
        f"Use {suggestion}, fewer world.path_params.cycles, or relax pairing.*",
        key="world.duration_s", value=world.duration_s)


#: Rig frame in the world at yaw 0: +z = world +x, +y = world -z, +x = world -y
#: (scene.R_WORLD_RIG_FORWARD).
_R_FORWARD = ((0.0, 0.0, 1.0), (-1.0, 0.0, 0.0), (0.0, -1.0, 0.0))


def _pose_margins(cfg) -> tuple[float, float]:
    """How far a measured relative motion may fall below the true one (m, deg): the
    run's pose source owns them (``source.pose_margins(cfg)``)."""
    from simcalib.sources import get_source
    return get_source(cfg.source, cfg.kind).pose_margins(cfg)


def _surviving_pairs(world, pairing, duration_s: float, margins=(0.0, 0.0)) -> int:
    """Pairs of frames ``pairing.step`` apart that the pre-filter may keep, predicted
    from the scripted path (pure numpy, no scene): both cameras' poses are the target
    path composed with the rig mount and the rig; perturbations and timing jitter are
    left out. ``margins`` (m, deg) widen the thresholds by what pose errors can take off
    a measured motion, so only pairs that are surely dropped are not counted."""
    import numpy as np
    from simcalib.world.paths import compose_path, sample_path
    n = min(int(math.floor(duration_s * world.fps + 1e-9)) + 1, 20001)
    s = pairing.step
    if n <= s:
        return 0
    t = np.arange(n, dtype=np.float64) / world.fps
    R_fwd = np.array(_R_FORWARD)
    from simcalib.world.platforms import get_platform
    mount = get_platform(world.platform).info.rig_mount_m
    T_home, T_target_mount = np.eye(4), np.eye(4)
    if mount is None:
        T_home[:3, :3] = R_fwd
    else:
        T_target_mount[:3, :3] = R_fwd
        T_target_mount[:3, 3] = mount
    T_target = compose_path(T_home, sample_path(world.path, world.platform, t, duration_s,
                                                world.path_params))
    T_cam_a = T_target @ T_target_mount @ world.rig.T_rig_cam_a()
    keep = np.ones(n - s, dtype=bool)
    for T in (T_cam_a, T_cam_a @ world.rig.T_a_b()):
        T0, T1 = T[:-s], T[s:]
        R_rel = np.einsum("nji,njk->nik", T0[:, :3, :3], T1[:, :3, :3])
        cos = np.clip((np.trace(R_rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
        keep &= np.degrees(np.arccos(cos)) <= pairing.max_rotation_deg + margins[1]
        keep &= (np.linalg.norm(T1[:, :3, 3] - T0[:, :3, 3], axis=1)
                 <= pairing.max_translation_m + margins[0])
    return int(keep.sum())


