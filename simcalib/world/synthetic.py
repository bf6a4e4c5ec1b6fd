"""Synthetic relative-motion source of the paper's appendix D.2 (Dekel et al., CVPR 2020).

Three motions of the *first* sensor (the paper's ΔP_1, our ``H``; the sensor called ``b``):

* ``random`` — every relative pose drawn independently: rotation uniform on SO(3),
  translation uniform in ``U(0, 1)^3`` metres. Well-conditioned 3D motion.
* ``line`` — an absolute trajectory moving at constant velocity along the world x axis
  from x = 0 to x = ``line_length_m`` with constant orientation. The relative poses between
  consecutive frames are pure translations along one direction: the rotation of X is not
  determined by them (degenerate).
* ``circle`` — one revolution of a circle of radius ``circle_radius_m`` in the world xy
  plane, heading along the tangent. The relative poses between consecutive frames are planar
  motions, rotations about one axis (the body z axis): the translation of X along that axis
  is not determined (degenerate).

As in D.2, ``line`` and ``circle`` get a symmetry-breaking jitter: each relative pose
ΔP_1 is perturbed by eq. 38 noise with ``jitter_sigma_r_rad`` / ``jitter_sigma_t_m``
(paper: 0.57° and 0.01 m) *before* the second sensor's motion is computed, simulating a
slight wobble of the platform. The second sensor (``a``) then moves by
``C = X H X^-1`` (eq. 37; ``X = T_a_b``, so ``C_i X = X H_i`` holds exactly), and both
streams are measured with eq. 38 noise (``sigma_r_rad``, ``sigma_t_m``; paper: 0.57°,
0.01 m) — see :func:`simcalib.geometry.perturb_transforms`.

Sampling follows appendix D: from one noisy data set of ``num_motions`` relative poses,
``N`` samples of ``n = 100`` relative poses are drawn at random from the whole trajectory
(distinct within a sample, with replacement between samples), giving batched arrays
``(N, n, 4, 4)`` ready for :func:`simcalib.solve_batch`.

Typical use::

    rng = np.random.default_rng(0)
    ds = generate_dataset(SyntheticConfig(motion="circle"), rng)
    C, H, idx = sample_problems(ds, num_samples=1000, n=100, rng=rng)   # (1000,100,4,4)
    sol = simcalib.solve_batch(C, H, method="dqopt", alpha=1.0)

    # one (C, H) problem, e.g. for ``python -m simcalib run scenario=circle``
    prob = synthetic_problem(SyntheticConfig(motion="circle"), n=100, rng=rng)
    prob.C, prob.H, prob.X
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from simcalib.geometry import (
    check_transforms,
    invert_transform,
    matrix_from_rotvec,
    perturb_transforms,
    random_rotation_matrices,
    transform_from_rotation_translation,
)

__all__ = [
    "MOTIONS",
    "PAPER_X_TRANSLATION_M",
    "PAPER_X_ROTVEC_RAD",
    "paper_rig_X",
    "SyntheticConfig",
    "SyntheticDataset",
    "SyntheticProblem",
    "config_from_dict",
    "scripted_trajectory",
    "generate_dataset",
    "sample_indices",
    "sample_problems",
    "synthetic_problem",
    "generate_batch",
]

MOTIONS = ("random", "line", "circle")

# The real rig of the paper (paper appendix D.1): translation [-0.7, 28.1, -0.1] cm,
# axis-angle [2.35, -0.92, -48.93] deg.
PAPER_X_TRANSLATION_M = (-0.007, 0.281, -0.001)
PAPER_X_ROTVEC_RAD = tuple(math.radians(v) for v in (2.35, -0.92, -48.93))

_SIGMA_R_PAPER_RAD = math.radians(0.57)
_SIGMA_T_PAPER_M = 0.01


def paper_rig_X() -> np.ndarray:
    """The paper's real two-camera extrinsic ``X = T_a_b`` as a 4x4 float64 array."""
    return transform_from_rotation_translation(
        matrix_from_rotvec(np.array(PAPER_X_ROTVEC_RAD)), np.array(PAPER_X_TRANSLATION_M))


@dataclass(frozen=True)
class SyntheticConfig:
    """Settings of one synthetic data set (appendix D.2). Metres and radians.

    motion:              ``"random"``, ``"line"`` or ``"circle"``.
    num_motions:         relative poses in the data set (``line``/``circle``: the scripted
                         trajectory has ``num_motions + 1`` frames; relative poses are
                         between consecutive frames).
    sigma_r_rad:         eq. 38 measurement noise, rotation angle std (paper 0.57°).
    sigma_t_m:           eq. 38 measurement noise, translation std per axis (paper 0.01 m).
    jitter_sigma_r_rad:  symmetry-breaking jitter of ``line``/``circle`` motions, rotation
                         (paper 0.57°); ignored for ``random``.
    jitter_sigma_t_m:    same, translation (paper 0.01 m).
    line_length_m:       length of the ``line`` path (paper 2 m).
    circle_radius_m:     radius of the ``circle`` path (paper 2 m).
    random_translation_max_m: ``random`` translations are ``U(0, max)^3`` (paper 1 m).
    X_translation_m, X_rotvec_rad: the true extrinsic ``X = T_a_b`` (default: the paper's
                         real rig, paper appendix D.1).
    """
    motion: str = "random"
    num_motions: int = 1000
    sigma_r_rad: float = _SIGMA_R_PAPER_RAD
    sigma_t_m: float = _SIGMA_T_PAPER_M
    jitter_sigma_r_rad: float = _SIGMA_R_PAPER_RAD
    jitter_sigma_t_m: float = _SIGMA_T_PAPER_M
    line_length_m: float = 2.0
    circle_radius_m: float = 2.0
    random_translation_max_m: float = 1.0
    X_translation_m: tuple[float, float, float] = PAPER_X_TRANSLATION_M
    X_rotvec_rad: tuple[float, float, float] = PAPER_X_ROTVEC_RAD

    def __post_init__(self):
        from simcalib.config.checks import check_in, check_int, check_positive, check_vector, set_fields
        set_fields(
            self,
            motion=check_in("motion", self.motion, MOTIONS),
            num_motions=check_int("num_motions", self.num_motions, lo=2),
            **{name: check_positive(name, getattr(self, name), allow_zero=True)
               for name in ("sigma_r_rad", "sigma_t_m", "jitter_sigma_r_rad",
                            "jitter_sigma_t_m")},
            **{name: check_positive(name, getattr(self, name))
               for name in ("line_length_m", "circle_radius_m", "random_translation_max_m")},
            **{name: check_vector(name, getattr(self, name))
               for name in ("X_translation_m", "X_rotvec_rad")})

    @property
    def X(self) -> np.ndarray:
        """The true extrinsic ``X = T_a_b`` (4x4)."""
        return transform_from_rotation_translation(
            matrix_from_rotvec(np.array(self.X_rotvec_rad)), np.array(self.X_translation_m))

    def replace(self, **changes) -> "SyntheticConfig":
        return config_from_dict({**dataclasses.asdict(self), **changes})


def config_from_dict(values: dict) -> SyntheticConfig:
    """Build a :class:`SyntheticConfig` from a mapping; unknown keys are rejected by name."""
    if not isinstance(values, dict):
        raise TypeError(f"synthetic config must be a mapping; received {type(values).__name__}")
    fields = [f.name for f in dataclasses.fields(SyntheticConfig)]
    for key in values:
        if key not in fields:
            from simcalib.errors import ConfigError, did_you_mean
            raise ConfigError(f"unknown synthetic config key {key!r}"
                              f"{did_you_mean(key, fields)}; allowed: {', '.join(fields)}",
                              key=str(key))
    return SyntheticConfig(**values)


@dataclass(frozen=True)
class SyntheticDataset:
    """One noisy data set of relative motions (``C_i X = X H_i`` before noise).

    ``H_true`` (M,4,4): motions of the scripted sensor b (jitter included); ``C_true``:
    motions of sensor a, ``X H_true X^-1``; ``H``, ``C``: the same with eq. 38 noise.
    ``T_world_b`` (M+1,4,4): the scripted absolute trajectory of sensor b without jitter
    (``random``: the chain of the relative poses), for plotting.
    """
    config: SyntheticConfig
    X: np.ndarray
    C: np.ndarray
    H: np.ndarray
    C_true: np.ndarray
    H_true: np.ndarray
    T_world_b: np.ndarray

    @property
    def num_motions(self) -> int:
        return self.C.shape[0]


@dataclass(frozen=True)
class SyntheticProblem:
    """One calibration problem: ``n`` noisy motions ``C``, ``H`` (n,4,4) and the true ``X``."""
    C: np.ndarray
    H: np.ndarray
    X: np.ndarray
    indices: np.ndarray
    dataset: SyntheticDataset


def _check_rng(rng) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise TypeError("rng must be a numpy.random.Generator (np.random.default_rng(seed)); "
                        f"received {type(rng).__name__}")
    return rng


def scripted_trajectory(cfg: SyntheticConfig) -> np.ndarray:
    """Absolute poses ``T_world_b`` (num_motions+1, 4, 4) of the ``line`` / ``circle`` path
    (no jitter). ``line``: x from 0 to ``line_length_m`` at constant velocity, identity
    orientation. ``circle``: one revolution of radius ``circle_radius_m`` about the world
    z axis, the body x axis along the tangent (heading), body z along world z."""
    if cfg.motion not in ("line", "circle"):
        raise ValueError(f"scripted_trajectory needs motion 'line' or 'circle'; "
                         f"received {cfg.motion!r} (random motions have no scripted path)")
    frames = cfg.num_motions + 1
    s = np.linspace(0.0, 1.0, frames)
    if cfg.motion == "line":
        R = np.broadcast_to(np.eye(3), (frames, 3, 3))
        t = np.zeros((frames, 3))
        t[:, 0] = cfg.line_length_m * s
        return transform_from_rotation_translation(R, t)
    theta = 2.0 * np.pi * s
    r = cfg.circle_radius_m
    t = np.stack([r * np.cos(theta), r * np.sin(theta), np.zeros(frames)], axis=-1)
    heading = theta + 0.5 * np.pi
    rotvec = np.zeros((frames, 3))
    rotvec[:, 2] = heading
    return transform_from_rotation_translation(matrix_from_rotvec(rotvec), t)


def _chain(T_rel: np.ndarray) -> np.ndarray:
    """Absolute poses from relative ones (first pose identity). Display only."""
    out = np.empty((T_rel.shape[0] + 1, 4, 4))
    out[0] = np.eye(4)
    for k in range(T_rel.shape[0]):
        out[k + 1] = out[k] @ T_rel[k]
    return out


def generate_dataset(cfg: SyntheticConfig, rng: np.random.Generator) -> SyntheticDataset:
    """One noisy data set of ``cfg.num_motions`` relative motions (appendix D.2).

    Draws, in this order from child generators of ``rng``: the motion (``random``) or the
    jitter (``line``/``circle``), then the measurement noise of H, then that of C.
    """
    if not isinstance(cfg, SyntheticConfig):
        raise TypeError(f"cfg must be a SyntheticConfig; received {type(cfg).__name__}")
    rng = _check_rng(rng)
    motion_rng, noise_h_rng, noise_c_rng = rng.spawn(3)
    M = cfg.num_motions
    if cfg.motion == "random":
        R = random_rotation_matrices(motion_rng, (M,))
        t = motion_rng.uniform(0.0, cfg.random_translation_max_m, size=(M, 3))
        H_true = transform_from_rotation_translation(R, t)
        T_world_b = _chain(H_true)
    else:
        T_world_b = scripted_trajectory(cfg)
        H_path = invert_transform(T_world_b[:-1]) @ T_world_b[1:]
        H_true = perturb_transforms(H_path, cfg.jitter_sigma_r_rad, cfg.jitter_sigma_t_m,
                                    motion_rng)
    X = cfg.X
    C_true = X @ H_true @ invert_transform(X)
    H = perturb_transforms(H_true, cfg.sigma_r_rad, cfg.sigma_t_m, noise_h_rng)
    C = perturb_transforms(C_true, cfg.sigma_r_rad, cfg.sigma_t_m, noise_c_rng)
    return SyntheticDataset(cfg, X, C, H, C_true, H_true, T_world_b)


def sample_indices(num_motions: int, num_samples: int, n: int,
                   rng: np.random.Generator) -> np.ndarray:
    """``(num_samples, n)`` indices into a data set of ``num_motions`` motions: each row holds
    ``n`` distinct indices (a uniformly random subset); rows are drawn independently (with
    replacement between samples, as in appendix D)."""
    rng = _check_rng(rng)
    for name, val, lo in (("num_samples", num_samples, 1), ("n", n, 2),
                          ("num_motions", num_motions, 2)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < lo:
            raise ValueError(f"{name} must be an integer >= {lo}; received {val!r}")
    if n > num_motions:
        raise ValueError(f"cannot draw n={n} distinct motions from a data set of "
                         f"{num_motions}; use n <= num_motions or a larger num_motions")
    keys = rng.random((int(num_samples), int(num_motions)))
    return np.argpartition(keys, int(n) - 1, axis=1)[:, :int(n)] if n < num_motions \
        else np.argsort(keys, axis=1)


def sample_problems(dataset: SyntheticDataset, num_samples: int, n: int,
                    rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bootstrap ``num_samples`` problems of ``n`` motions from ``dataset``:
    returns ``C (num_samples, n, 4, 4)``, ``H`` (same) and the indices ``(num_samples, n)``."""
    if not isinstance(dataset, SyntheticDataset):
        raise TypeError(f"dataset must be a SyntheticDataset; received {type(dataset).__name__}")
    idx = sample_indices(dataset.num_motions, num_samples, n, rng)
    return dataset.C[idx], dataset.H[idx], idx


def generate_batch(cfg: SyntheticConfig, num_samples: int, n: int, rng: np.random.Generator
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Data set + bootstrap in one call: ``(C, H, X)`` with ``C, H (num_samples, n, 4, 4)``."""
    rng = _check_rng(rng)
    data_rng, sample_rng = rng.spawn(2)
    ds = generate_dataset(cfg, data_rng)
    C, H, _ = sample_problems(ds, num_samples, n, sample_rng)
    return C, H, ds.X


def synthetic_problem(cfg: SyntheticConfig | str = "random", n: int = 100,
                      rng: np.random.Generator | None = None) -> SyntheticProblem:
    """One calibration problem of ``n`` noisy relative motions (``C_i X ≈ X H_i``) drawn from a
    D.2 data set — what ``scenario=random|line|circle`` of the pipeline uses.

    ``cfg`` may be a :class:`SyntheticConfig` or just the motion name. ``rng`` is required
    (explicit randomness); it is split into a data-set and a sampling generator.
    """
    if isinstance(cfg, str):
        cfg = SyntheticConfig(motion=cfg)
    if not isinstance(cfg, SyntheticConfig):
        raise TypeError(f"cfg must be a SyntheticConfig or a motion name; "
                        f"received {type(cfg).__name__}")
    if rng is None:
        raise TypeError("rng is required: pass np.random.default_rng(seed)")
    rng = _check_rng(rng)
    data_rng, sample_rng = rng.spawn(2)
    ds = generate_dataset(cfg, data_rng)
    idx = sample_indices(ds.num_motions, 1, n, sample_rng)[0]
    C = check_transforms(ds.C[idx], "C")
    return SyntheticProblem(C, ds.H[idx], ds.X, idx, ds)
