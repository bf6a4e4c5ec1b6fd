"""The ``world`` stage: build the ground truth a run measures (:class:`GroundTruth`).

``kind=sim``: a MuJoCo world (``simcalib.world.build_world``: platform, path, rig, marker
field) and each camera's exact pose stream. ``kind=synthetic``: a paper appendix D.2 problem
(``simcalib.world.synthetic.synthetic_problem``) and the absolute poses it was drawn from."""

from __future__ import annotations

import numpy as np

from simcalib.sources.base import GroundTruth

__all__ = ["KINDS", "build_truth"]

KINDS = ("sim", "synthetic")


def build_truth(cfg, rngs: dict) -> GroundTruth:
    """Ground truth of ``cfg`` (a ScenarioConfig); ``rngs``: the run's named generators
    (``"world"`` for a simulated world, ``"synthetic"`` for a synthetic problem)."""
    if cfg.kind == "sim":
        return _sim_truth(cfg, rngs["world"], rngs.get("robot"))
    if cfg.kind == "synthetic":
        return _synthetic_truth(cfg, rngs["synthetic"])
    raise ValueError(f"kind must be one of {list(KINDS)}; received {cfg.kind!r}")


def _sim_truth(cfg, rng, rng_robot=None) -> GroundTruth:
    from simcalib.world import build_world, ground_truth_stream
    world = build_world(_true_world_config(cfg, rng_robot), rng)
    return GroundTruth(kind="sim", X_true=np.asarray(world.trajectory.T_a_b, dtype=np.float64),
                       streams={c: ground_truth_stream(world.frames(c))
                                for c in world.camera_names},
                       world=world, intrinsics=dict(world.intrinsics),
                       marker_field=world.marker_field)


def _true_world_config(cfg, rng_robot):
    """``cfg.world`` with the true arm: when ``robot.kinematic_error`` is set, the arm is
    built from the nominal DH table plus a deviation drawn from the run's ``robot``
    generator (``world.arm_dh_error``, unless the config gives one explicitly)."""
    import dataclasses
    w = cfg.world
    robot = getattr(cfg, "robot", None)
    if (robot is None or not robot.kinematic_error.active or w.platform != "arm"
            or w.arm_model != "builtin" or w.arm_dh_error is not None):
        return w
    if rng_robot is None:
        raise ValueError("robot.kinematic_error needs the run's 'robot' generator "
                         "(rngs['robot'])")
    from simcalib.world.robot_error import draw_dh_error
    return dataclasses.replace(w, arm_dh_error=draw_dh_error(robot.kinematic_error,
                                                             rng_robot))


def _synthetic_truth(cfg, rng) -> GroundTruth:
    from simcalib.geometry import invert_transform
    from simcalib.streams import PoseStream
    from simcalib.world.synthetic import synthetic_problem
    syn = cfg.synthetic  # measurement noise already synced with noise.* by the config
    if cfg.pairing.n_pairs > syn.num_motions:
        raise ValueError(f"pairing.n_pairs={cfg.pairing.n_pairs} exceeds "
                         f"synthetic.num_motions={syn.num_motions}")
    problem = synthetic_problem(syn, n=cfg.pairing.n_pairs, rng=rng)
    X = np.asarray(problem.X, dtype=np.float64)
    T_w_b = np.asarray(problem.dataset.T_world_b)
    T_w_a = T_w_b @ invert_transform(X)
    n = T_w_b.shape[0]
    t = np.arange(n, dtype=np.float64)
    streams = {cam: PoseStream(camera=cam, source="ground_truth", frame_index=np.arange(n),
                               timestamp_s=t, T_world_cam=T, n_frames=n)
               for cam, T in (("cam_a", T_w_a), ("cam_b", T_w_b))}
    return GroundTruth(kind="synthetic", X_true=X, streams=streams, synthetic=problem)
