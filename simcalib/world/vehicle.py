"""A car-scale wheeled vehicle driven through MuJoCo physics (not posed).

``simulate_vehicle(cfg, path, rng) -> VehicleTrajectory``: the vehicle of
``models/car.xml``, edited into the variant a :class:`VehicleConfig` asks for
(:mod:`simcalib.world.vehicle_model`: Ackermann or differential drive, sprung or rigid
chassis, flat / sloped / uneven ground), follows a planar path
(:mod:`simcalib.world.vehicle_path`: pure-pursuit steering and a speed PI controller acting
on wheel-torque actuators). The chassis pitches and rolls by itself on its suspension under
acceleration, braking and turning, and follows the ground. The ground-truth poses are the
physics' poses of the chassis and of the roof site ``rig_mount`` (camera poses =
``T_world_rig_mount @ T_mount_cam``); :func:`translation_sensitivity` says how well their
motions determine a hand-eye translation.

The path's geometry (x, y) is followed at ``cfg.speed_mps`` (ramped at
``cfg.accel_mps2``, braked to a stop at the end at ``cfg.decel_mps2``); its time column
only orders the points and its yaw only sets the start heading.

Deterministic: all randomness (the uneven ground's bumps) comes from ``rng``; MuJoCo's
stepping is deterministic, so the same config and seed give the same trajectory.

CLI: ``python -m simcalib.world.vehicle --table`` regenerates the roll/pitch table of
docs/physics.md.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from simcalib.world.render_backend import import_mujoco as _mujoco
from simcalib.world.vehicle_config import DRIVES, GROUNDS, VehicleConfig, _check_number
from simcalib.world.vehicle_model import (BuiltVehicle, VehicleIds, build_variant,
                                          build_vehicle_model, lookup_ids)
from simcalib.world.vehicle_path import (PathFollower, PlanarPath, as_planar_path,
                                         figure_eight_path)

__all__ = ["VehicleTrajectory", "physics_table", "simulate_vehicle", "step_cost_us",
           "translation_sensitivity"]


# -------------------------------------------------------------------------- trajectory
@dataclass(frozen=True)
class VehicleTrajectory:
    """Physics ground truth of one drive, sampled at ``sample_rate_hz`` from the drive's
    start (t = 0, after settling) to the stop.

    ``time_s`` (N,); ``T_world_base`` (N, 4, 4) chassis frame; ``T_world_rig_mount``
    (N, 4, 4) roof site (camera poses = ``T_world_rig_mount @ T_mount_cam``);
    ``roll_rad``/``pitch_rad``/``yaw_rad`` (N,) chassis ZYX Euler angles w.r.t. gravity;
    ``speed_mps`` (N,) forward speed of the controlled point; ``speed_ref_mps`` (N,)
    commanded; ``steer_rad`` (N,) (Ackermann: bicycle-model steering angle; differential:
    0); ``cross_track_m`` (N,) distance of the controlled point (driven-axle centre: rear
    axle, or the platform centre for the differential drive) to the path; ``slip_ratio`` (N, nw) and
    ``slip_angle_rad`` (N, nw) of the ``wheels`` with a spin axis (NaN below 1 m/s);
    ``stats`` summary (degrees and metres, see :meth:`summary`); ``timing_s`` wall times;
    ``config``; ``model`` the compiled MjModel; ``mjcf`` the variant's MJCF text."""
    time_s: np.ndarray
    T_world_base: np.ndarray
    T_world_rig_mount: np.ndarray
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    yaw_rad: np.ndarray
    speed_mps: np.ndarray
    speed_ref_mps: np.ndarray
    steer_rad: np.ndarray
    cross_track_m: np.ndarray
    wheels: tuple
    slip_ratio: np.ndarray
    slip_angle_rad: np.ndarray
    stats: dict
    timing_s: dict
    config: VehicleConfig
    model: object = field(repr=False, default=None)
    mjcf: str = field(repr=False, default="")


def _euler_zyx(R):
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    pitch = -np.arcsin(np.clip(R[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    return roll, pitch, yaw


def _quat_wxyz_yaw_pitch(yaw, pitch=0.0, roll=0.0):
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return np.array([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                     cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr])


def _stats(traj_arrays, cfg, wall):
    roll, pitch, z, slip, slip_ang, cte, speed = traj_arrays
    moving = speed > 1.0
    out = {
        "roll_peak_deg": float(np.degrees(np.abs(roll).max())),
        "roll_std_deg": float(np.degrees(roll.std())),
        "roll_range_deg": float(np.degrees(np.ptp(roll))),
        "pitch_peak_deg": float(np.degrees(np.abs(pitch).max())),
        "pitch_std_deg": float(np.degrees(pitch.std())),
        "pitch_range_deg": float(np.degrees(np.ptp(pitch))),
        "height_range_m": float(np.ptp(z)),
        "height_std_m": float(z.std()),
        "cross_track_max_m": float(cte.max()),
        "speed_max_mps": float(speed.max()),
    }
    if slip.size and moving.any():
        out["slip_ratio_peak"] = float(np.nanmax(np.abs(slip[moving])))
        out["slip_ratio_p95"] = float(np.nanpercentile(np.abs(slip[moving]), 95))
        out["slip_angle_peak_deg"] = float(np.degrees(np.nanmax(np.abs(slip_ang[moving]))))
        out["slip_angle_p95_deg"] = float(np.degrees(np.nanpercentile(
            np.abs(slip_ang[moving]), 95)))
    else:
        out.update(slip_ratio_peak=float("nan"), slip_ratio_p95=float("nan"),
                   slip_angle_peak_deg=float("nan"), slip_angle_p95_deg=float("nan"))
    out.update(wall)
    return out


# -------------------------------------------------------------------------- simulation
def simulate_vehicle(cfg: VehicleConfig, path, rng: np.random.Generator, *,
                     path_duration_s: float | None = None) -> VehicleTrajectory:
    """Drive the physics vehicle ``cfg`` along ``path`` (see :func:`as_planar_path`) and
    return its :class:`VehicleTrajectory`. ``rng`` draws the uneven ground (a child
    generator is spawned, so ``rng`` is advanced identically for every variant).
    Raises ``ValueError`` for bad input, for a path the vehicle leaves (cross-track error
    > 5 m: too fast for the curvature and friction) and for a drive exceeding
    ``cfg.max_duration_s``."""
    if not isinstance(cfg, VehicleConfig):
        raise TypeError(f"cfg must be a VehicleConfig; received {type(cfg).__name__}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    p = as_planar_path(path, path_duration_s)
    mujoco = _mujoco()
    t_wall0 = time.perf_counter()
    (rng_ground,) = rng.spawn(1)
    built = build_variant(cfg, rng_ground, _ground_extent(cfg, p))
    model = built.model
    data = mujoco.MjData(model)
    t_build = time.perf_counter() - t_wall0

    ids = lookup_ids(mujoco, model)
    # the controlled point (driven-axle centre: rear axle, or the middle of the
    # differential platform) starts on the path's first point
    x_ctrl = -0.5 * float(cfg.wheelbase_m) if cfg.drive == "ackermann" else 0.0
    _place_at_path_start(mujoco, model, data, cfg, p, built.ground_height, x_ctrl)
    follower = PathFollower(cfg, p, model, data, ids, x_ctrl)
    follower.settle(mujoco)
    rec, step, t_sim = _drive_and_record(mujoco, model, data, cfg, ids, follower)
    return _trajectory_from_record(rec, step, cfg, ids.wheels, built, t_build, t_sim, t_wall0)


def _ground_extent(cfg: VehicleConfig, p: PlanarPath):
    """The ground's ``((x0, x1), (y0, y1))``: the path's bounding box plus a margin."""
    margin = 12.0 + 2.0 * float(cfg.wheelbase_m)
    return ((float(p.x.min()) - margin, float(p.x.max()) + margin),
            (float(p.y.min()) - margin, float(p.y.max()) + margin))


def _place_at_path_start(mujoco, model, data, cfg: VehicleConfig, p: PlanarPath,
                         ground_height, x_ctrl: float) -> None:
    """Pose the chassis with its controlled point on the path start, facing the start yaw."""
    # initial pose: on the path start, facing its start yaw, wheels just above the ground
    L, W = float(cfg.wheelbase_m), float(cfg.track_m)
    yaw0 = float(p.yaw[0])
    cy, sy = math.cos(yaw0), math.sin(yaw0)
    x0, y0 = float(p.x[0]) - x_ctrl * cy, float(p.y[0]) - x_ctrl * sy
    corners_xy = np.array([[x0 + cy * ax - sy * ay, y0 + sy * ax + cy * ay]
                           for ax in (0.5 * L, -0.5 * L) for ay in (0.5 * W, -0.5 * W)])
    zg = ground_height(corners_xy[:, 0], corners_xy[:, 1])
    pitch0 = 0.0
    if cfg.ground == "slope":
        # ground pitch along the heading (nose up when climbing +x)
        pitch0 = -math.atan(math.tan(math.radians(float(cfg.slope_deg))) * cy)
        roll0 = math.atan(math.tan(math.radians(float(cfg.slope_deg))) * sy)
    else:
        roll0 = 0.0
    data.qpos[0:3] = [x0, y0, float(np.mean(zg)) + 0.02]
    if cfg.ground == "uneven":
        data.qpos[2] = float(zg.max()) + 0.02
    data.qpos[3:7] = _quat_wxyz_yaw_pitch(yaw0, pitch0, roll0)
    mujoco.mj_forward(model, data)


def _check_on_path(cfg: VehicleConfig, last, t: float) -> None:
    """Raise ``ValueError`` when the cross-track error of ``last`` exceeds 5 m."""
    if last[3] > 5.0:
        raise ValueError(
            f"the vehicle left the path (cross-track error {last[3]:.2f} m at "
            f"t = {t:.2f} s, speed {last[0]:.2f} m/s): the path is "
            f"too tight for speed_mps={cfg.speed_mps} with friction {cfg.friction} "
            f"and max_steer_deg={cfg.max_steer_deg}; lower the speed or widen the path")


def _drive_and_record(mujoco, model, data, cfg: VehicleConfig, ids: VehicleIds,
                      follower: PathFollower):
    """Step the drive from its start to the stop, recording samples; ``(rec, step, t_sim)``."""
    n_ctrl = cfg.steps_per_control
    n_per_sample = cfg.steps_per_sample
    rec = {k: [] for k in ("t", "pos", "mat", "mpos", "mmat", "v", "vref", "steer", "cte",
                           "slip", "slipang")}
    res6 = np.zeros(6)
    t_sim0 = time.perf_counter()
    step = 0
    max_steps = int(round(float(cfg.max_duration_s) / float(cfg.timestep_s)))
    last = (0.0, 0.0, 0.0, 0.0)
    finished = False
    stop_steps = 0
    while True:
        if step % n_ctrl == 0:
            if follower.stopped_at_end():
                finished = True
            last = follower.control(False)
            _check_on_path(cfg, last, step * cfg.timestep_s)
        if step % n_per_sample == 0:
            _record_sample(mujoco, model, data, cfg, ids, rec, step * cfg.timestep_s, last,
                           res6)
            if finished:
                stop_steps += 1
                if stop_steps > 1:
                    break
        if step >= max_steps:
            raise ValueError(f"the drive did not finish within max_duration_s="
                             f"{cfg.max_duration_s} s (path length {follower.s_end:.1f} m at "
                             f"{cfg.speed_mps} m/s); raise max_duration_s")
        n = min(n_ctrl - step % n_ctrl, n_per_sample - step % n_per_sample)
        mujoco.mj_step(model, data, nstep=n)
        step += n
    return rec, step, time.perf_counter() - t_sim0


def _record_sample(mujoco, model, data, cfg: VehicleConfig, ids: VehicleIds, rec: dict, t: float,
                   last, res6) -> None:
    """Append the chassis and mount poses, controller outputs and wheel slips to ``rec``."""
    rec["t"].append(t)
    rec["pos"].append(data.xpos[ids.chassis].copy())
    rec["mat"].append(data.xmat[ids.chassis].copy())
    rec["mpos"].append(data.site_xpos[ids.mount].copy())
    rec["mmat"].append(data.site_xmat[ids.mount].copy())
    rec["v"].append(last[0])
    rec["vref"].append(last[1])
    rec["steer"].append(last[2])
    rec["cte"].append(last[3])
    sl, sa = _wheel_slips(mujoco, model, data, float(cfg.wheel_radius_m), ids, res6)
    rec["slip"].append(sl)
    rec["slipang"].append(sa)


def _wheel_slips(mujoco, model, data, r: float, ids: VehicleIds, res6):
    """Slip ratio and slip angle of each spinning wheel (NaN below 1 m/s forward speed)."""
    sl = np.full(len(ids.wheels), np.nan)
    sa = np.full(len(ids.wheels), np.nan)
    for k, (bid, dof) in enumerate(zip(ids.hub_ids, ids.spin_dof)):
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, bid, res6, 1)
        vx, vy = float(res6[3]), float(res6[4])
        if abs(vx) > 1.0:
            sl[k] = (float(data.qvel[dof]) * r - vx) / abs(vx)
            sa[k] = math.atan2(vy, abs(vx))
    return sl, sa


def _trajectory_from_record(rec: dict, step: int, cfg: VehicleConfig, wheels: tuple,
                            built: BuiltVehicle, t_build: float, t_sim: float,
                            t_wall0: float) -> VehicleTrajectory:
    """Assemble the :class:`VehicleTrajectory` (poses, angles, slips, stats) of a record."""
    from simcalib.geometry import transforms_from_flat
    T_base = transforms_from_flat(rec["mat"], rec["pos"])
    T_mount = transforms_from_flat(rec["mmat"], rec["mpos"])
    roll, pitch, yaw = _euler_zyx(T_base[:, :3, :3])
    yaw = np.unwrap(yaw)
    speed = np.array(rec["v"])
    slip = np.array(rec["slip"]).reshape(len(rec["t"]), len(wheels))
    slip_ang = np.array(rec["slipang"]).reshape(len(rec["t"]), len(wheels))
    cte = np.array(rec["cte"])
    sim_seconds = float(step * cfg.timestep_s + cfg.settle_s)
    wall = {"sim_seconds": sim_seconds,
            "physics_ms_per_sim_s": 1e3 * t_sim / max(step * cfg.timestep_s, 1e-9)}
    stats = _stats((roll, pitch, T_base[:, 2, 3], slip, slip_ang, cte, np.abs(speed)), cfg,
                   wall)
    total = time.perf_counter() - t_wall0
    return VehicleTrajectory(
        time_s=np.array(rec["t"]), T_world_base=T_base, T_world_rig_mount=T_mount,
        roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw, speed_mps=speed,
        speed_ref_mps=np.array(rec["vref"]), steer_rad=np.array(rec["steer"]),
        cross_track_m=cte, wheels=wheels, slip_ratio=slip, slip_angle_rad=slip_ang,
        stats=stats, timing_s={"build": t_build, "simulate": t_sim, "total": total},
        config=cfg, model=built.model, mjcf=built.spec_xml)


# ------------------------------------------------------------------- observability
def translation_sensitivity(traj: VehicleTrajectory, capture_rate_hz: float = 2.0) -> dict:
    """How well the motions of the rig mount determine a hand-eye translation.

    For relative motions ``A_i`` between consecutive captures at ``capture_rate_hz`` the
    translation part of AX = XB reads ``(R_Ai - I) t_X = R_X t_Bi - t_Ai``. With exact
    rotations and independent isotropic noise σ on each motion's translation, the
    least-squares ``t_X`` has covariance ``σ² (Aᵀ A)⁻¹`` (A = stacked ``R_Ai - I``). Returns
    ``amplification`` (3,) = ``sqrt(diag((AᵀA)⁻¹))`` along the rig axes (x right, y down,
    z forward: y is the vertical), i.e. metres of ``t_X`` error per metre of per-motion
    translation noise, ``n_motions`` and ``tilt_rms_deg`` (rms of the relative rotations'
    horizontal-axis components, which is what makes the vertical observable)."""
    if not isinstance(traj, VehicleTrajectory):
        raise TypeError(f"traj must be a VehicleTrajectory; received {type(traj).__name__}")
    _check_number("capture_rate_hz", capture_rate_hz, 0.0, traj.config.sample_rate_hz,
                  lo_open=True)
    k = max(1, int(round(traj.config.sample_rate_hz / capture_rate_hz)))
    moving = np.flatnonzero(np.abs(traj.speed_mps) > 0.1)
    idx = np.arange(moving[0], moving[-1] + 1, k) if moving.size else np.arange(0)
    R = traj.T_world_rig_mount[idx, :3, :3]
    R_rel = np.swapaxes(R[:-1], -1, -2) @ R[1:]                 # motion in the mount frame
    A = (R_rel - np.eye(3)).reshape(-1, 3)
    AtA = A.T @ A
    from simcalib.geometry import rotvec_from_matrix
    rv = rotvec_from_matrix(R_rel)
    tilt = np.hypot(rv[:, 0], rv[:, 2])                           # rig y = vertical axis
    with np.errstate(divide="ignore", invalid="ignore"):
        try:
            amp = np.sqrt(np.diag(np.linalg.inv(AtA)))
        except np.linalg.LinAlgError:
            amp = np.full(3, np.inf)
    return {"n_motions": int(R_rel.shape[0]), "amplification": amp,
            "tilt_rms_deg": float(np.degrees(np.sqrt(np.mean(tilt ** 2)))) if tilt.size
            else 0.0}


# ----------------------------------------------------------------------------- CLI
def physics_table(speeds_mps=(3.0, 4.5, 6.0), bump_amplitudes_m=(0.01, 0.04),
                  seed: int = 0) -> list[dict]:
    """Rows of the docs/physics.md table: the default figure-eight (60 m x 24 m) driven
    by the default sprung Ackermann car at each speed on uneven ground of each bump
    amplitude (4 m wavelength), plus the rigid car on flat ground at each speed."""
    path = figure_eight_path()
    rows = []
    variants = [("rigid, flat", dict(sprung=False))] + [
        (f"sprung, bumps {a * 100:g} cm", dict(ground="uneven", bump_amplitude_m=a))
        for a in bump_amplitudes_m]
    for label, kw in variants:
        for v in speeds_mps:
            cfg = VehicleConfig(speed_mps=float(v), **kw)
            tr = simulate_vehicle(cfg, path, np.random.default_rng(seed))
            yaw_rate = np.gradient(tr.yaw_rad, tr.time_s)
            a_lat = np.abs(tr.speed_mps * yaw_rate)
            sens = translation_sensitivity(tr)
            rows.append({"variant": label, "speed_mps": float(v),
                         "a_lat_peak_mps2": float(np.percentile(a_lat, 99)),
                         **{k: tr.stats[k] for k in (
                             "roll_peak_deg", "roll_std_deg", "pitch_peak_deg",
                             "pitch_std_deg", "height_std_m", "slip_ratio_peak",
                             "slip_angle_peak_deg", "cross_track_max_m", "sim_seconds",
                             "physics_ms_per_sim_s")},
                         "tilt_rms_deg": sens["tilt_rms_deg"],
                         "t_vertical_amplification": float(sens["amplification"][1]),
                         "t_horizontal_amplification": float(max(sens["amplification"][0],
                                                                  sens["amplification"][2])),
                         "wall_s": tr.timing_s["total"]})
    return rows


def format_table(rows) -> str:
    head = ("| car, ground | speed m/s | a_lat p99 m/s² | roll peak / std ° | pitch peak / std ° "
            "| height std mm | slip ratio / angle peak | tilt rms ° (0.5 s) "
            "| σ(t_vert) / σ(t_horiz) per σ_t | physics ms per sim s |")
    sep = "|" + "---|" * 10
    lines = [head, sep]
    for r in rows:
        lines.append(
            f"| {r['variant']} | {r['speed_mps']:g} | {r['a_lat_peak_mps2']:.2f} "
            f"| {r['roll_peak_deg']:.2f} / {r['roll_std_deg']:.2f} "
            f"| {r['pitch_peak_deg']:.2f} / {r['pitch_std_deg']:.2f} "
            f"| {1e3 * r['height_std_m']:.1f} "
            f"| {r['slip_ratio_peak']:.3f} / {r['slip_angle_peak_deg']:.2f}° "
            f"| {r['tilt_rms_deg']:.3f} "
            f"| {r['t_vertical_amplification']:.3g} / {r['t_horizontal_amplification']:.3g} "
            f"| {r['physics_ms_per_sim_s']:.0f} |")
    return "\n".join(lines)


def step_cost_us(cfg: VehicleConfig, n: int = 3000, seed: int = 0) -> float:
    """Wall time of one bare ``mj_step`` (µs, best of 3 runs of ``n`` steps) of the
    variant ``cfg`` standing on its ground (no controller, no recording)."""
    mujoco = _mujoco()
    model, height = build_vehicle_model(cfg, np.random.default_rng(seed))
    data = mujoco.MjData(model)
    data.qpos[2] = float(height(np.array([0.0]), np.array([0.0]))[0]) + 0.05
    mujoco.mj_step(model, data, nstep=500)
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        mujoco.mj_step(model, data, nstep=n)
        best = min(best, (time.perf_counter() - t0) / n)
    return 1e6 * best


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="python -m simcalib.world.vehicle",
                                 description="Physics car: regenerate the docs/physics.md "
                                             "table, or drive one figure-eight.")
    ap.add_argument("--table", action="store_true",
                    help="roll/pitch/slip/cost for the figure-eight at 3 speeds x grounds")
    ap.add_argument("--speed", type=float, default=6.0, help="single run: speed (m/s)")
    ap.add_argument("--ground", default="flat", choices=GROUNDS)
    ap.add_argument("--drive", default="ackermann", choices=DRIVES)
    ap.add_argument("--rigid", action="store_true", help="single run: no suspension")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    if args.table:
        print(format_table(physics_table(seed=args.seed)))
        for label, cfg in (("rigid, flat", VehicleConfig(sprung=False)),
                           ("sprung, flat", VehicleConfig()),
                           ("sprung, bumps 4 cm", VehicleConfig(ground="uneven",
                                                                bump_amplitude_m=0.04))):
            print(f"\nbare mj_step, {label}: {step_cost_us(cfg, seed=args.seed):.1f} µs per "
                  f"step at rest on the ground", end="")
        print()
        return 0
    kw = {"ground": args.ground, "drive": args.drive, "sprung": not args.rigid,
          "speed_mps": args.speed}
    if args.ground == "slope":
        kw["slope_deg"] = 3.0
    tr = simulate_vehicle(VehicleConfig(**kw), figure_eight_path(),
                          np.random.default_rng(args.seed))
    for k, v in tr.stats.items():
        print(f"{k:24s} {v:.4g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
