"""Synthetic pose streams of a rigid two-sensor rig, for validating time alignment,
convention detection and outlier rejection where the truth is known.

:func:`rig_streams` samples a smooth trajectory of sensor a at ``rate_a_hz`` and of sensor b
(``T_wb_b = T_wb_wa T_wa_a X``, ``X = T_a_b``) at ``rate_b_hz`` with its own phase, stamps b
with a clock ``t_b = (1 + drift) t + offset_s``, adds paper eq. 38 pose noise and, optionally,
gross outlier poses. Paths: ``3d`` (rotation about all axes, translation in 3D) and
``planar`` (rotation about the vertical only, translation in a plane: X's vertical
translation is then unobservable).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcalib.geometry import (matrix_from_rotvec, perturb_transforms, random_rotation_matrices,
                               transform_from_rotation_translation)

__all__ = ["RigStreams", "rig_path", "rig_streams", "PATHS"]

PATHS = ("3d", "planar")


def rig_path(t_s: np.ndarray, path: str = "3d") -> np.ndarray:
    """Poses ``T_world_a`` (N, 4, 4) of a smooth path at times ``t_s`` (sums of sinusoids;
    rotation up to ~1 rad, translation ~0.5 m)."""
    if path not in PATHS:
        from simcalib.errors import unknown_choice
        raise unknown_choice("path", path, PATHS, key="path")
    t = np.asarray(t_s, dtype=np.float64)[:, None]
    f = np.array([0.23, 0.37, 0.51])
    ph = np.array([0.3, 1.1, 2.0])
    if path == "3d":
        rv = 0.7 * np.sin(2 * np.pi * f * t + ph) + 0.3 * np.sin(2 * np.pi * 1.3 * f * t)
        p = 0.5 * np.sin(2 * np.pi * 0.8 * f * t + ph[::-1])
    else:
        rv = np.zeros((t.shape[0], 3))
        rv[:, 2] = (1.2 * np.sin(2 * np.pi * 0.3 * t) + 0.4 * np.sin(2 * np.pi * 0.71 * t))[:, 0]
        p = np.concatenate([0.8 * np.sin(2 * np.pi * 0.2 * t),
                            0.6 * np.sin(2 * np.pi * 0.33 * t + 1), 0 * t], axis=1)
    return transform_from_rotation_translation(matrix_from_rotvec(rv), p)


@dataclass(frozen=True)
class RigStreams:
    """``(t_a, T_a)`` and ``(t_b, T_b)`` stamped by their own clocks; ``X`` the truth;
    ``offset_s``/``drift`` the clock model ``t_b = (1 + drift) t + offset_s``;
    ``outlier_b`` (N_b,) marks poses of b replaced by gross outliers."""
    t_a: np.ndarray
    T_a: np.ndarray
    t_b: np.ndarray
    T_b: np.ndarray
    X: np.ndarray
    offset_s: float
    drift: float
    outlier_b: np.ndarray

    @property
    def a(self):
        return (self.t_a, self.T_a)

    @property
    def b(self):
        return (self.t_b, self.T_b)


def rig_streams(*, offset_s: float = 0.0, drift: float = 0.0, path: str = "3d",
                duration_s: float = 30.0, rate_a_hz: float = 30.0, rate_b_hz: float = 20.0,
                sigma_r_rad: float = np.radians(0.1), sigma_t_m: float = 0.001,
                outlier_fraction: float = 0.0, X: np.ndarray | None = None,
                rng: np.random.Generator | None = None) -> RigStreams:
    """Two streams of a rigid rig (see the module docstring). ``X`` defaults to the paper's
    rig (``simcalib.world.synthetic.paper_rig_X``). ``rng`` is required for noise / outliers."""
    from simcalib.world.synthetic import paper_rig_X
    if rng is None:
        raise TypeError("rng is required: pass np.random.default_rng(seed)")
    X = paper_rig_X() if X is None else np.asarray(X, dtype=np.float64)
    T_wb_wa = transform_from_rotation_translation(matrix_from_rotvec([0.1, -0.4, 0.3]),
                                                  np.array([1.0, 2.0, 0.5]))
    t_a = np.arange(0.0, duration_s, 1.0 / rate_a_hz)
    s_b = np.arange(0.0, duration_s, 1.0 / rate_b_hz) + 0.37 / rate_b_hz
    T_a = rig_path(t_a, path)
    T_b = T_wb_wa @ rig_path(s_b, path) @ X
    noise_a, noise_b, out_rng = rng.spawn(3)
    T_a = perturb_transforms(T_a, sigma_r_rad, sigma_t_m, noise_a)
    T_b = perturb_transforms(T_b, sigma_r_rad, sigma_t_m, noise_b)
    outlier = np.zeros(s_b.size, dtype=bool)
    if outlier_fraction > 0:
        k = int(round(outlier_fraction * s_b.size))
        idx = out_rng.choice(s_b.size, k, replace=False)
        outlier[idx] = True
        T_b = T_b.copy()
        T_b[idx] = T_b[idx] @ transform_from_rotation_translation(
            random_rotation_matrices(out_rng, (k,)), out_rng.uniform(-0.3, 0.3, (k, 3)))
    t_b = (1.0 + drift) * s_b + offset_s
    return RigStreams(t_a, T_a, t_b, T_b, X, float(offset_s), float(drift), outlier)
