"""The vehicle's path and how it follows it: a planar target path (:class:`PlanarPath`,
:func:`as_planar_path` from arrays or a callable, :func:`figure_eight_path` at car scale)
and the driver (:class:`PathFollower`: pure-pursuit steering towards a lookahead point,
a PI speed loop with feed-forward that ramps up, cruises and brakes to a stop at the path's
end, acting on the wheel-torque and brake actuators; the differential drive steers by a
yaw-rate loop on its two wheels). The path's geometry (x, y) is followed; its time column
only orders the points and its yaw only sets the start heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcalib.world.vehicle_config import VehicleConfig, _check_number
from simcalib.world.vehicle_model import VehicleIds

__all__ = ["PathFollower", "PlanarPath", "as_planar_path", "figure_eight_path"]


@dataclass(frozen=True)
class PlanarPath:
    """A planar target path: ``t`` (M,) s increasing, ``x``/``y`` (M,) m, ``yaw`` (M,)
    rad (heading of the vehicle's +x at each point)."""
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray

    @property
    def arc_length_m(self) -> np.ndarray:
        ds = np.hypot(np.diff(self.x), np.diff(self.y))
        return np.concatenate([[0.0], np.cumsum(ds)])


def as_planar_path(path, duration_s: float | None = None, n: int = 4000) -> PlanarPath:
    """Normalise a path: a :class:`PlanarPath`; an ``(M, 4)`` array or a 4-tuple of
    ``(t, x, y, yaw)`` arrays; or a callable ``f(t) -> (x, y, yaw)`` (arrays, or an
    ``(M, 3)`` array) sampled at ``n`` points over ``[0, duration_s]``."""
    if isinstance(path, PlanarPath):
        t, x, y, yaw = path.t, path.x, path.y, path.yaw
    elif callable(path):
        if duration_s is None:
            raise ValueError("a callable path needs path_duration_s (the time span to "
                             "sample it over)")
        _check_number("path_duration_s", duration_s, 0.0, 1e6, lo_open=True)
        t = np.linspace(0.0, float(duration_s), int(n))
        out = path(t)
        arr = np.asarray(out, dtype=np.float64)
        if arr.shape == (3, t.size):
            x, y, yaw = arr
        elif arr.shape == (t.size, 3):
            x, y, yaw = arr.T
        else:
            raise ValueError(f"a callable path must return (x, y, yaw) with {t.size} values "
                             f"each; returned shape {arr.shape}")
    else:
        try:
            arr = np.asarray(path, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError("path must be a PlanarPath, an (M, 4) array / 4-tuple of "
                            "(t, x, y, yaw) arrays, or a callable f(t) -> (x, y, yaw); "
                            f"received {type(path).__name__}") from None
        if arr.ndim == 2 and arr.shape[1] == 4 and arr.shape[0] != 4:
            t, x, y, yaw = arr.T
        elif arr.ndim == 2 and arr.shape[0] == 4:
            t, x, y, yaw = arr
        else:
            raise ValueError(f"path array must be (M, 4) or (4, M) of (t, x, y, yaw); "
                             f"received shape {arr.shape}")
    t, x, y, yaw = (np.asarray(v, dtype=np.float64).copy() for v in (t, x, y, yaw))
    if t.size < 3:
        raise ValueError(f"path needs at least 3 points; received {t.size}")
    if not all(np.isfinite(v).all() for v in (t, x, y, yaw)):
        raise ValueError("path contains non-finite values")
    if np.any(np.diff(t) <= 0):
        raise ValueError("path times must be strictly increasing")
    if np.hypot(np.diff(x), np.diff(y)).sum() < 1e-3:
        raise ValueError("path has no length (all points coincide)")
    return PlanarPath(t, x, y, yaw)


def figure_eight_path(length_m: float = 60.0, width_m: float = 24.0, laps: float = 1.0,
                      n: int = 4000) -> PlanarPath:
    """The registry's ``planar`` cart path (``x = A sin θ``, ``y = B sin 2θ``) sampled at
    car scale: ``length_m`` = 2A along x, ``width_m`` = 2B along y, starting at the
    crossing. The yaw is the path tangent (a car faces along its path; the registry
    path's extra turning is dropped)."""
    from simcalib.world.paths import sample_path
    _check_number("length_m", length_m, 0.0, 1e4, lo_open=True)
    _check_number("width_m", width_m, 0.0, 1e4, lo_open=True)
    _check_number("laps", laps, 0.0, 100.0, lo_open=True)
    t = np.linspace(0.0, float(laps), int(n))
    s = sample_path("planar", "cart", t, 1.0,
                    {"amp_x_m": 0.5 * float(length_m), "amp_y_m": 0.5 * float(width_m),
                     "yaw_turns": 0.0, "amp_yaw_deg": 0.0, "cycles": 1.0})
    x, y = s.dp[:, 0], s.dp[:, 1]
    yaw = np.unwrap(np.arctan2(np.gradient(y, t), np.gradient(x, t)))
    return PlanarPath(t, x, y, yaw)


class PathFollower:
    """Pure-pursuit steering and PI speed control of the vehicle along the path."""

    def __init__(self, cfg: VehicleConfig, p: PlanarPath, model, data, ids: VehicleIds,
                 x_ctrl: float):
        """Path geometry, controller gains and limits, and the controller state."""
        self.cfg, self.model, self.data, self.ids, self.x_ctrl = cfg, model, data, ids, x_ctrl
        L, W = float(cfg.wheelbase_m), float(cfg.track_m)
        self.L, self.W, self.r = L, W, float(cfg.wheel_radius_m)
        # path geometry for the follower
        self.s_path = p.arc_length_m
        self.s_end = float(self.s_path[-1])
        self.px, self.py, self.yaw_path = p.x, p.y, p.yaw
        self.v_set = float(cfg.speed_mps)
        self.a_acc, self.a_dec = float(cfg.accel_mps2), float(cfg.decel_mps2)
        self.m_total = float(model.body_subtreemass[ids.chassis])
        self.kp, self.ki = float(cfg.speed_kp_per_s), float(cfg.speed_ki_per_s2)
        self.max_steer = math.radians(float(cfg.max_steer_deg))
        self.tq_max = float(cfg.max_wheel_torque_nm)
        self.dt_ctrl = 1.0 / float(cfg.control_rate_hz)
        self.ackermann = cfg.drive == "ackermann"
        # yaw-rate loop of the differential drive (1/s, 1/s^2) on the vehicle's yaw inertia
        self.yaw_kp, self.yaw_ki = 8.0, 4.0
        self.i_zz = (float(model.body_inertia[ids.chassis][2])
                     + self.m_total * 0.25 * (L ** 2 + W ** 2) * 0.2)
        # controller state: nearest path index, speed integrator, speed reference, yaw-rate
        # path index, speed integrator, speed reference, yaw-rate integrator
        self.i, self.integ, self.v_ref, self.integ_yaw = 0, 0.0, 0.0, 0.0

    def control_point_state(self):
        """``(pos, heading, v_fwd, omega_z)`` of the controlled point (driven-axle centre)."""
        data, chassis_id, x_ctrl = self.data, self.ids.chassis, self.x_ctrl
        R = data.xmat[chassis_id].reshape(3, 3)
        pos = data.xpos[chassis_id] + R @ np.array([x_ctrl, 0.0, 0.0])
        fwd = R[:, 0]
        heading = math.atan2(fwd[1], fwd[0])
        v_world = data.qvel[0:3] + np.cross(R @ data.qvel[3:6], R @ np.array([x_ctrl, 0, 0]))
        v_fwd = float(v_world[0] * math.cos(heading) + v_world[1] * math.sin(heading))
        omega_z = float((R @ data.qvel[3:6])[2])
        return pos, heading, v_fwd, omega_z

    def advance_to_nearest(self, pos):
        """Index of the path point nearest ``pos`` (searching forward only) and its distance."""
        s_path, i0 = self.s_path, self.i
        # search forward along the path only (a figure-eight crosses itself)
        s_lim = s_path[i0] + 3.0 + 2.0 * self.v_set * self.dt_ctrl + 1.0
        i1 = int(np.searchsorted(s_path, s_lim)) + 1
        seg_x, seg_y = self.px[i0:i1], self.py[i0:i1]
        d2 = (seg_x - pos[0]) ** 2 + (seg_y - pos[1]) ** 2
        k = int(np.argmin(d2))
        self.i = i0 + k
        return i0 + k, math.sqrt(float(d2[k]))

    def stopped_at_end(self) -> bool:
        """Whether the vehicle stands at the path end with a zero speed reference."""
        pos, heading, v, _ = self.control_point_state()
        at_end = self.i >= len(self.s_path) - 2 or (self.s_end - self.s_path[self.i]) < 0.05
        return at_end and abs(v) < 0.05 and self.v_ref < 1e-3

    def speed_reference(self, s_here: float, stop_mode: bool):
        """``(v_ref, a_ff)``: ramp up, cruise, brake to a stop at the path end (0 when stopping)."""
        if stop_mode:
            return 0.0, 0.0
        dt_ctrl, a_dec = self.dt_ctrl, self.a_dec
        v_cap = math.sqrt(max(0.0, 2.0 * a_dec * (self.s_end - s_here)))
        v_ref = min(self.v_set, self.v_ref + self.a_acc * dt_ctrl, v_cap)
        # no steeper drop than 1.2 x decel (v_cap's slope is unbounded at the end)
        v_ref = max(v_ref, self.v_ref - 1.2 * a_dec * dt_ctrl, 0.0)
        a_ff = (v_ref - self.v_ref) / dt_ctrl
        self.v_ref = v_ref
        return v_ref, a_ff

    def pursuit_curvature(self, pos, heading: float, v: float, s_here: float) -> float:
        """Pure-pursuit curvature towards the lookahead point on the path."""
        cfg, s_end = self.cfg, self.s_end
        ld = max(float(cfg.lookahead_min_m), float(cfg.lookahead_gain_s) * abs(v))
        s_goal = min(s_here + ld, s_end)
        gx = float(np.interp(s_goal, self.s_path, self.px))
        gy = float(np.interp(s_goal, self.s_path, self.py))
        if s_end - s_here < 0.5 * ld:     # past the end: extend along the final tangent
            ext = ld - (s_end - s_here)
            gx += ext * math.cos(float(self.yaw_path[-1]))
            gy += ext * math.sin(float(self.yaw_path[-1]))
        alpha = math.atan2(gy - pos[1], gx - pos[0]) - heading
        alpha = (alpha + math.pi) % (2.0 * math.pi) - math.pi
        dist = max(math.hypot(gx - pos[0], gy - pos[1]), 1e-6)
        return 2.0 * math.sin(alpha) / dist

    def speed_force(self, v_ref: float, a_ff: float, v: float) -> float:
        """Total longitudinal force of the PI speed loop (with feed-forward), clipped."""
        e = v_ref - v
        self.integ += e * self.dt_ctrl
        a_cmd = a_ff + self.kp * e + self.ki * self.integ
        a_cmd = max(-1.5 * self.a_dec, min(1.5 * self.a_acc, a_cmd))
        return self.m_total * a_cmd

    def steer_front_wheels(self, kappa: float) -> float:
        """Set the Ackermann front-wheel angles for ``kappa``; the bicycle steering angle."""
        L, W, max_steer = self.L, self.W, self.max_steer
        delta = max(-max_steer, min(max_steer, math.atan(L * kappa)))
        kap = math.tan(delta) / L
        dl = math.atan(L * kap / (1.0 - 0.5 * W * kap)) if abs(0.5 * W * kap) < 0.95 else delta
        dr = math.atan(L * kap / (1.0 + 0.5 * W * kap)) if abs(0.5 * W * kap) < 0.95 else delta
        self.data.ctrl[self.ids.aid["steer_fl"]] = max(-max_steer, min(max_steer, dl))
        self.data.ctrl[self.ids.aid["steer_fr"]] = max(-max_steer, min(max_steer, dr))
        return delta

    def drive_or_brake(self, f_total: float) -> None:
        """Apply ``f_total`` as rear-wheel drive torque, or as 60/40 front/rear braking."""
        torque = f_total * self.r
        if torque >= 0.0:      # drive: rear wheels
            tr, brake_f, brake_r = 0.5 * torque, 0.0, 0.0
        else:                  # brake (dry friction on the wheel hinges): 60/40 f/r
            tr, brake_f, brake_r = 0.0, -0.3 * torque, -0.2 * torque
        for name in ("drive_rl", "drive_rr"):
            self.data.ctrl[self.ids.aid[name]] = min(self.tq_max, tr)
        for c, val in (("fl", brake_f), ("fr", brake_f), ("rl", brake_r), ("rr", brake_r)):
            self.model.dof_frictionloss[self.ids.spin_dof_all[c]] = min(self.tq_max, val)

    def drive_differential(self, kappa: float, v_ref: float, a_ff: float, v: float,
                           omega_z: float) -> None:
        """Set the two wheel torques: force for the speed, yaw moment for the yaw rate."""
        # differential: force for the speed, yaw moment for the pursuit yaw rate
        omega_ref = v * kappa
        f_total = self.speed_force(v_ref, a_ff, v)
        e_w = omega_ref - omega_z
        self.integ_yaw += e_w * self.dt_ctrl
        m_yaw = self.i_zz * (self.yaw_kp * e_w + self.yaw_ki * self.integ_yaw)
        tq_max = self.tq_max
        for side, sgn in (("rl", -1.0), ("rr", 1.0)):
            torque = (0.5 * f_total + sgn * m_yaw / self.W) * self.r
            self.data.ctrl[self.ids.aid[f"drive_{side}"]] = max(-tq_max, min(tq_max, torque))

    def control(self, stop_mode: bool):
        """One controller update; ``(v, v_ref, steer, cte)``."""
        pos, heading, v, omega_z = self.control_point_state()
        i, cte = self.advance_to_nearest(pos)
        s_here = float(self.s_path[i])
        v_ref, a_ff = self.speed_reference(s_here, stop_mode)
        kappa = self.pursuit_curvature(pos, heading, v, s_here)   # on the controlled point
        steer = 0.0
        if self.ackermann:
            steer = self.steer_front_wheels(kappa)
            self.drive_or_brake(self.speed_force(v_ref, a_ff, v))
        else:
            self.drive_differential(kappa, v_ref, a_ff, v, omega_z)
        return v, v_ref, steer, cte

    def settle(self, mujoco) -> None:
        """Stand still for ``cfg.settle_s`` (settling on the ground), then reset the integrators."""
        cfg, n_ctrl = self.cfg, self.cfg.steps_per_control
        n_settle = int(round(float(cfg.settle_s) / float(cfg.timestep_s)))
        for _ in range(max(0, n_settle // n_ctrl)):
            self.control(True)
            mujoco.mj_step(self.model, self.data, nstep=n_ctrl)
        self.integ = self.integ_yaw = 0.0
