"""The robot's and the camera's systematic errors: a smooth kinematic error field over the
workspace, a camera whose depth reads long and whose noise grows with the distance; the X
they imply over the whole workspace (:func:`workspace_X`), and the ``robot_error`` kind.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import numpy as np

from simcalib.geometry import (invert_transform, matrix_from_rotvec, rotvec_from_matrix,
                               transform_from_rotation_translation)
from simcalib.studies.experiments.recording_models import (R_DOWN, WORKSPACE_CENTRE,
                                                           _camera_poses, _station_poses,
                                                           _stations_draft, _unit)

__all__ = ["WORKSPACE_STATIONS", "workspace_X"]


def _robot_error_field(rng) -> tuple[Callable, tuple[float, float]]:
    """A systematic, pose-dependent kinematic error: three random low-order (sinusoidal)
    functions of the pose (position and rotation vector) with an rms of 0.1..0.5 deg /
    1..3 mm over the workspace (correlated between nearby poses, not white). Returns
    ``(T_true_hand -> E, (rms deg, rms m))``: the error in the hand frame (the robot
    REPORTS ``T_true_hand @ E``) and the rms its maker would state as its accuracy."""
    w = rng.normal(0.0, 1.0, (3, 6))
    ph = rng.uniform(0.0, 2 * np.pi, 3)
    # each sin term has mean square ~1/2, three terms along unit vectors: rms ~ amp
    rms_deg, rms_m = rng.uniform(0.1, 0.5), rng.uniform(0.001, 0.003)
    amp_r = math.radians(rms_deg) / math.sqrt(1.5)
    amp_t = rms_m / math.sqrt(1.5)
    dirs_r = _unit(rng, 3) * amp_r
    dirs_t = _unit(rng, 3) * amp_t

    def error(A):
        f = np.concatenate([(A[:, :3, 3] - WORKSPACE_CENTRE) / 0.25,
                            rotvec_from_matrix(R_DOWN.T[None] @ A[:, :3, :3])], axis=1)
        basis = np.sin(f @ w.T + ph)                               # (N, 3)
        return transform_from_rotation_translation(matrix_from_rotvec(basis @ dirs_r),
                                                   basis @ dirs_t)
    return error, (float(rms_deg), float(rms_m))


def _depth_biased(B, bias: float) -> np.ndarray:
    """Camera poses ``T_target_cam`` whose camera-to-target distance d reads
    ``(1 + bias d / 0.5 m)`` times too long (a depth-scale bias growing with d)."""
    T_cam_target = invert_transform(B)
    p = T_cam_target[:, :3, 3]
    d = np.linalg.norm(p, axis=1)
    T_cam_target[:, :3, 3] = p * (1.0 + bias * d / 0.5)[:, None]
    return invert_transform(T_cam_target)


def _camera_error(rng, B, on: bool, sigma_rot_deg: float, sigma_trans_m: float
                  ) -> tuple[np.ndarray, float]:
    """Camera poses (``T_target_cam``) with errors that grow with the viewing distance d:
    a depth-scale bias of 0.2..0.8 % x (d / 0.5 m) along the line of sight and noise of
    sigma (default 0.1 deg / 1 mm) x (d / 0.5 m)^2. Returns (poses, bias)."""
    d = np.linalg.norm(invert_transform(B)[:, :3, 3], axis=1)
    bias = rng.uniform(0.002, 0.008)
    n = B.shape[0]
    rot = _unit(rng, n) * (rng.normal(0.0, math.radians(sigma_rot_deg), n)
                           * (d / 0.5) ** 2)[:, None]
    dt = rng.normal(0.0, sigma_trans_m, (n, 3)) * ((d / 0.5)[:, None] ** 2)
    if not on:
        return B, bias
    return _depth_biased(B, bias) @ transform_from_rotation_translation(
        matrix_from_rotvec(rot), dt), bias


#: stations of the dense, noise-free solve that gives a recording's X_workspace
WORKSPACE_STATIONS = 2000


def workspace_X(rng, X, Y, error, bias: float, stations: int = WORKSPACE_STATIONS
                ) -> np.ndarray:
    """The X that a robot reporting ``T_hand @ error(T_hand)`` and a camera with the depth
    ``bias`` imply over the workspace: dqopt on the motions between ``stations`` random
    stations (consecutive in draw order), free of noise. (A constant error ``E0`` in the
    hand frame gives exactly ``E0^-1 X`` with zero residual: no recording can tell it.)"""
    from simcalib.solvers.api import solve_batch
    A = _station_poses(rng, stations)
    B = _depth_biased(_camera_poses(A, X, Y), bias)
    A = A @ error(A)
    C = invert_transform(A[:-1]) @ A[1:]
    H = invert_transform(B[:-1]) @ B[1:]
    return np.asarray(solve_batch(C[None], H[None], method="dqopt").X[0])


def _kind_robot_error(rngs, s):
    clean = replace(s, sigma_rot_b_deg=0.0, sigma_trans_b_m=0.0)
    d = _stations_draft(rngs, clean, (10, 40), "robot_error")
    r = rngs["events"]
    error, accuracy = _robot_error_field(r)
    A = d.A @ error(d.A) if s.noise else d.A
    B, bias = _camera_error(r, d.B, s.noise, s.sigma_rot_b_deg, s.sigma_trans_b_m)
    X_ws = workspace_X(rngs["workspace"], d.X, d.Y, error, bias) if s.noise else None
    return replace(d, A=A, B=B, X_workspace=X_ws, accuracy_a=accuracy,
                   description=d.description
                   + ", systematic pose-dependent robot error (rms 0.1..0.5 deg / 1..3 mm), "
                   "distance-dependent camera error")
