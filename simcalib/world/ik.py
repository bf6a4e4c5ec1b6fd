"""Damped-least-squares inverse kinematics on ``mj_jacSite``, within joint limits.

For a site pose target ``T_world_target`` each iteration solves
``dq = Jᵀ (J Jᵀ + λ² I)⁻¹ e`` with the 6D error ``e = (p* - p, rotvec(R* Rᵀ))`` in the
world frame and the site Jacobian ``J = [jacp; jacr]`` from ``mj_jacSite``, then clips
``q`` to the joint ranges. A path is solved waypoint by waypoint, warm-started from the
previous solution (continuous joint trajectories, no branch flips).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcalib.world.render_backend import import_mujoco as _mujoco

from simcalib.geometry import rotvec_from_matrix

__all__ = ["IKResult", "solve_ik", "solve_ik_path"]


@dataclass(frozen=True)
class IKResult:
    """``qpos`` ``(N, nq)``; per-waypoint ``pos_error_m``, ``rot_error_rad``,
    ``iterations`` ``(N,)``; ``converged`` ``(N,)`` bool (within the tolerances)."""
    qpos: np.ndarray
    pos_error_m: np.ndarray
    rot_error_rad: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray




def _site_error(data, sid, T_target):
    p = data.site_xpos[sid]
    R = data.site_xmat[sid].reshape(3, 3)
    e = np.empty(6)
    e[:3] = T_target[:3, 3] - p
    e[3:] = rotvec_from_matrix(T_target[:3, :3] @ R.T)
    return e


def solve_ik(model, data, site: str, T_target: np.ndarray, q0: np.ndarray, *,
             damping: float = 1e-4, max_iter: int = 200, tol_pos_m: float = 1e-9,
             tol_rot_rad: float = 1e-9) -> tuple[np.ndarray, float, float, int]:
    """One waypoint. Returns ``(q, pos_error_m, rot_error_rad, iterations)``; ``data`` is
    left at the solution (kinematics computed). Joints without a range are unclipped."""
    mujoco = _mujoco()
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    if sid < 0:
        raise ValueError(f"site {site!r} not found in the model")
    lo = np.where(model.jnt_limited.astype(bool), model.jnt_range[:, 0], -np.inf)
    hi = np.where(model.jnt_limited.astype(bool), model.jnt_range[:, 1], np.inf)
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    q = np.clip(np.asarray(q0, dtype=np.float64).copy(), lo, hi)
    lam2 = damping ** 2
    it = 0
    e = None
    for it in range(max_iter + 1):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        e = _site_error(data, sid, T_target)
        if np.linalg.norm(e[:3]) <= tol_pos_m and np.linalg.norm(e[3:]) <= tol_rot_rad:
            break
        if it == max_iter:
            break
        mujoco.mj_jacSite(model, data, jacp, jacr, sid)
        J = np.vstack([jacp, jacr])
        dq = J.T @ np.linalg.solve(J @ J.T + lam2 * np.eye(6), e)
        step = np.linalg.norm(dq)
        if step > 0.5:                      # trust region: no wild jumps far from target
            dq *= 0.5 / step
        q = np.clip(q + dq, lo, hi)
        if step < 1e-15:
            break
    return q, float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:])), it


def solve_ik_path(model, site: str, T_targets: np.ndarray, q0: np.ndarray, ik_cfg
                  ) -> IKResult:
    """Solve ``(N, 4, 4)`` site targets in order, warm-starting each from the previous."""
    mujoco = _mujoco()
    data = mujoco.MjData(model)
    T_targets = np.asarray(T_targets, dtype=np.float64)
    n = T_targets.shape[0]
    Q = np.zeros((n, model.nq))
    ep = np.zeros(n)
    er = np.zeros(n)
    its = np.zeros(n, dtype=np.int64)
    q = np.asarray(q0, dtype=np.float64)
    for k in range(n):
        q, ep[k], er[k], its[k] = solve_ik(
            model, data, site, T_targets[k], q, damping=ik_cfg.damping,
            max_iter=ik_cfg.max_iter, tol_pos_m=ik_cfg.tol_pos_m, tol_rot_rad=ik_cfg.tol_rot_rad)
        Q[k] = q
    conv = (ep <= ik_cfg.fail_pos_m) & (er <= ik_cfg.fail_rot_rad)
    return IKResult(Q, ep, er, its, conv)
