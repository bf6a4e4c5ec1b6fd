"""Platform ``car``: a car-scale wheeled vehicle driven through MuJoCo physics.

The path's geometry (x, y of the target frame = the chassis frame on the ground under the
wheelbase centre) is driven by the physics car of :mod:`simcalib.world.vehicle`
(``world.vehicle.*`` = :class:`~simcalib.world.vehicle.VehicleConfig`: Ackermann or
differential drive, sprung or rigid, flat / sloped / uneven ground) with pure pursuit and
a speed controller; the chassis pitches, rolls and heaves by itself. Nothing is scripted
but the geometry: the car drives it at ``world.vehicle.speed_mps`` from rest at its start
(heading = the path tangent) to a stop at its end, whatever the path's own clock says.
``world.duration_s`` is the capture window: frames after the car stopped see it standing
(``World.ik["frames_after_stop"]`` counts them), a drive longer than the window is cut.

Ground truth: the physics' chassis poses (sampled at ``world.vehicle.sample_rate_hz``)
interpolated to every capture time (linear position, SLERP rotation; before the start
and after the stop the car stands still) drive a *kinematic copy* of the car in the scene
(the same ``models/car.xml`` body with the same geometry, as a mocap body); the cameras'
poses are then the scene's camera sites on that copy, i.e. ``T_world_base(t) @
T_base_mount @ T_mount_cam`` with the physics' ``T_world_base``: the physics' poses of the
camera sites (tested against :attr:`VehicleTrajectory.T_world_rig_mount`). The rig is
massless in the physics. The wheels of the copy are drawn at their rest position.

World: car scale, outdoors — the scene keeps the room's floor (enlarged to 400 m x 400 m,
flat: the uneven ground's ±centimetres are not drawn) and drops walls, ceiling and the
marker field. So ``car`` supports the ``ground_truth`` and ``noisy`` pose sources only; a
scenario asking for ``aruco`` is rejected (:class:`~simcalib.errors.ConfigError`) before
any work. Paths: ``planar`` (figure-eight, default 60 m x 24 m), ``circular`` (full turns),
``linear`` (one forward pass); a path that reverses on itself is rejected (the car does
not drive backwards).

CLI: ``python -m simcalib.world.platforms.car --table`` regenerates the vertical-translation
table of docs/physics.md (dqopt with and without a prior on the figure-eight).
"""

from __future__ import annotations

import math
import time

import numpy as np

from simcalib.world.platforms.base import PlatformInfo, PlatformMotion
from simcalib.world.platforms.registry import register

__all__ = ["CarPlatform", "interpolate_poses", "car_path", "OUTDOOR_FLOOR_HALF_M",
           "vertical_axis_a", "vertical_error_table", "format_vertical_table"]

#: Half size of the (flat) floor of the car's outdoor scene.
OUTDOOR_FLOOR_HALF_M = 200.0
#: Points the path geometry is sampled at for the follower.
_PATH_POINTS = 4000


def interpolate_poses(t_samples: np.ndarray, T_samples: np.ndarray,
                      t_query: np.ndarray) -> np.ndarray:
    """``(Q, 4, 4)`` poses at ``t_query`` from poses ``T_samples`` ``(N, 4, 4)`` at increasing
    ``t_samples`` ``(N,)``: linear in position, SLERP in rotation; times outside the
    samples take the first / last pose (held)."""
    from simcalib.geometry import matrix_from_quat, quat_from_matrix
    t_samples = np.asarray(t_samples, dtype=np.float64)
    T_samples = np.asarray(T_samples, dtype=np.float64)
    tq = np.clip(np.asarray(t_query, dtype=np.float64), t_samples[0], t_samples[-1])
    if t_samples.size < 2:
        return np.broadcast_to(T_samples[0], tq.shape + (4, 4)).copy()
    k = np.clip(np.searchsorted(t_samples, tq, side="right") - 1, 0, t_samples.size - 2)
    u = ((tq - t_samples[k]) / (t_samples[k + 1] - t_samples[k]))[:, None]
    p = (1.0 - u) * T_samples[k, :3, 3] + u * T_samples[k + 1, :3, 3]
    q0 = quat_from_matrix(T_samples[k, :3, :3])
    q1 = quat_from_matrix(T_samples[k + 1, :3, :3])
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0.0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    small = theta < 1e-9
    s = np.where(small, 1.0, np.sin(theta))
    w0 = np.where(small, 1.0 - u, np.sin((1.0 - u) * theta) / s)
    w1 = np.where(small, u, np.sin(u * theta) / s)
    q = w0 * q0 + w1 * q1
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    out = np.zeros(tq.shape + (4, 4))
    out[:, :3, :3] = matrix_from_quat(q)
    out[:, :3, 3] = p
    out[:, 3, 3] = 1.0
    return out


def car_path(target_fn, cfg):
    """The :class:`~simcalib.world.vehicle.PlanarPath` the car follows: the target frame's
    path (``target_fn``) sampled densely over ``[0, duration_s]``, heading = its tangent.
    Raises ``ValueError`` for a path that reverses on itself (the car drives forward)."""
    from simcalib.world.vehicle import PlanarPath
    t = np.linspace(0.0, float(cfg.duration_s), _PATH_POINTS)
    T = target_fn(t)
    x, y = T[:, 0, 3], T[:, 1, 3]
    dx, dy = np.gradient(x, t), np.gradient(y, t)
    speed = np.hypot(dx, dy)
    if speed.max() <= 0.0:
        raise ValueError(f"path {cfg.path!r} does not move the car (no horizontal motion); "
                         "the car needs a path with length: planar, circular or linear")
    heading = np.arctan2(dy, dx)
    moving = speed > 1e-6 * speed.max()
    turn = np.abs(np.angle(np.exp(1j * np.diff(heading[moving]))))
    stopped = np.flatnonzero(~moving[1:-1]) + 1
    if turn.size and (turn.max() > math.radians(150.0) or stopped.size):
        k = int(np.flatnonzero(moving)[int(np.argmax(turn))]) if not stopped.size \
            else int(stopped[0])
        raise ValueError(f"path {cfg.path!r} reverses on itself at t = {t[k]:.2f} s (of "
                         f"{cfg.duration_s:g} s): the car drives forward only; use a path "
                         "without back-and-forth (e.g. circular with arc_deg=0, linear with "
                         "cycles=0.5)")
    return PlanarPath(t, x, y, np.unwrap(heading))


class CarPlatform:
    info = PlatformInfo(name="car", outdoor=True,
                        description="car-scale vehicle in MuJoCo physics (Ackermann or "
                                    "differential, sprung or rigid, flat/slope/uneven ground: "
                                    "world.vehicle.*) following the path's geometry; "
                                    "outdoors, noisy/ground_truth sources only")

    def attach(self, spec, cfg) -> str:
        import mujoco
        from simcalib.world.vehicle import CAR_XML, apply_vehicle_geometry
        # outdoors: no walls and ceiling, a large flat floor, a far clip plane
        for name in ("ceiling", "wall_px", "wall_nx", "wall_py", "wall_ny"):
            spec.delete(spec.geom(name))
        floor = spec.geom("floor")
        floor.size = [OUTDOOR_FLOOR_HALF_M, OUTDOOR_FLOOR_HALF_M, 0.05]
        spec.visual.map.zfar = 2.0 * OUTDOOR_FLOOR_HALF_M
        # a kinematic copy of the physics car (same geometry), moved as a mocap body
        car = mujoco.MjSpec.from_file(str(CAR_XML))
        apply_vehicle_geometry(car, cfg.vehicle)
        for a in list(car.actuators):
            car.delete(a)
        for j in list(car.joints):
            car.delete(j)
        car.delete(car.geom("ground"))
        for light in list(car.lights):
            car.delete(light)
        car.body("chassis").mocap = True
        car.option.timestep = spec.option.timestep            # no attach conflicts
        car.option.integrator = spec.option.integrator
        car.visual.map.zfar = spec.visual.map.zfar
        spec.attach(car, prefix="car/", frame=spec.worldbody.add_frame())
        return "car/rig_mount"

    def home(self, model, data, mount_site, cfg):
        return np.eye(4), np.zeros(model.nq)

    def simulates(self, cfg) -> bool:
        return True

    def drive(self, scene, T_world_target, t, cfg) -> PlatformMotion:
        raise TypeError("platform 'car' is simulated, not posed: build it with "
                        "simcalib.world.build_world (it calls CarPlatform.simulate with the "
                        "world's random generator)")

    def simulate(self, scene, target_fn, t, cfg, rng) -> PlatformMotion:
        from simcalib.geometry import quat_from_matrix, quat_wxyz_from_xyzw
        from simcalib.world.vehicle import simulate_vehicle
        t1 = time.perf_counter()
        path = car_path(target_fn, cfg)
        tr = simulate_vehicle(cfg.vehicle, path, rng)
        T_base = interpolate_poses(tr.time_s, tr.T_world_base, t)
        n = T_base.shape[0]
        drive_end = float(tr.time_s[-1])
        stats = {k: float(v) for k, v in tr.stats.items()}
        stats.update({"drive_duration_s": drive_end,
                      "frames_after_stop": int(np.sum(np.asarray(t) > drive_end)),
                      "drive_cut_s": max(0.0, drive_end - float(np.max(t))),
                      "physics_time_s": float(tr.timing_s["total"]),
                      "n_physics_samples": int(tr.time_s.size),
                      "time_s": time.perf_counter() - t1})
        return PlatformMotion(
            qpos=np.zeros((n, scene.model.nq)), mocap_pos=T_base[:, None, :3, 3].copy(),
            mocap_quat_wxyz=quat_wxyz_from_xyzw(quat_from_matrix(T_base[:, :3, :3]))[:, None],
            stats=stats, record=tr)


register(CarPlatform())


# --------------------------------------------------------------------- docs table
def vertical_axis_a(cfg) -> np.ndarray:
    """The car's vertical (chassis +z) in camera a's frame for the world config ``cfg``:
    the direction along which planar motion leaves X's translation undetermined."""
    R_rig_a = cfg.rig.T_rig_cam_a()[:3, :3]
    return R_rig_a.T @ np.array([0.0, -1.0, 0.0])      # rig +y = down on the car


def vertical_error_table(speeds_mps=(3.0, 4.5, 6.0), bumps_m=(0.01, 0.04),
                         seeds=(0, 1, 2), scenario: str = "car", extra=(),
                         out_dir: str = "runs/car-table") -> list[dict]:
    """Rows of the docs table: for each ground (the rigid car on flat ground, then the
    sprung car on uneven ground of each bump height) and speed, runs of ``scenario`` with
    those settings, one per seed: |error of X's translation along the car's vertical| of
    dqopt and of dqopt with the prior (median and max over the seeds), the nominal
    (prior) X's own vertical error, and how often dqopt's observability flagged it."""
    from simcalib.config import load_config
    from simcalib.pipeline import run
    variants = [("rigid, flat", ["world.vehicle.sprung=false", "world.vehicle.ground=flat"])]
    variants += [(f"sprung, bumps {b * 100:g} cm",
                  ["world.vehicle.sprung=true", "world.vehicle.ground=uneven",
                   f"world.vehicle.bump_amplitude_m={b}"]) for b in bumps_m]
    rows = []
    for label, over in variants:
        for v in speeds_mps:
            err, err_p, err_nom, flagged, wall = [], [], [], 0, []
            for seed in seeds:
                tag = f"{label.replace(' ', '').replace(',', '-')}-{v:g}-{seed}"
                cfg = load_config(scenario, [*over, f"world.vehicle.speed_mps={v}",
                                             f"seed={seed}", "progress=false",
                                             "recording.enabled=false",
                                             f"output={out_dir}/{tag}", *extra])
                up = vertical_axis_a(cfg.world)
                t0 = time.perf_counter()
                res = run(cfg, echo=False)
                wall.append(time.perf_counter() - t0)
                t_true = res.X_true[:3, 3]
                for name, out in (("dqopt", err), ("dqopt+prior", err_p)):
                    s = res.solver(name)
                    out.append(abs(float((s.X[:3, 3] - t_true) @ up)) if s.X is not None
                               else float("nan"))
                s = res.solver("dqopt")
                flagged += int(bool(s.degenerate))
                nominal = np.asarray(res.solver("dqopt+prior").prior["X"])
                err_nom.append(abs(float((nominal[:3, 3] - t_true) @ up)))
            rows.append({"variant": label, "speed_mps": float(v), "n_seeds": len(seeds),
                         "dqopt_vert_median_m": float(np.median(err)),
                         "dqopt_vert_max_m": float(np.max(err)),
                         "prior_vert_median_m": float(np.median(err_p)),
                         "prior_vert_max_m": float(np.max(err_p)),
                         "nominal_vert_median_m": float(np.median(err_nom)),
                         "flagged_degenerate": flagged,
                         "wall_s": float(np.median(wall))})
    return rows


def format_vertical_table(rows) -> str:
    head = ("| car, ground | speed m/s | dqopt vertical error median / max cm "
            "| dqopt+prior vertical error median / max cm | nominal X vertical error "
            "median cm | dqopt flagged degenerate | run s (median) |")
    lines = [head, "|" + "---|" * 7]
    for r in rows:
        lines.append(
            f"| {r['variant']} | {r['speed_mps']:g} "
            f"| {100 * r['dqopt_vert_median_m']:.2f} / {100 * r['dqopt_vert_max_m']:.2f} "
            f"| {100 * r['prior_vert_median_m']:.2f} / {100 * r['prior_vert_max_m']:.2f} "
            f"| {100 * r['nominal_vert_median_m']:.2f} "
            f"| {r['flagged_degenerate']}/{r['n_seeds']} | {r['wall_s']:.0f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="python -m simcalib.world.platforms.car",
                                 description="Regenerate the docs/physics.md table of X's "
                                             "vertical translation on the car.")
    ap.add_argument("--table", action="store_true", help="print the docs table")
    ap.add_argument("--seeds", type=int, default=3, help="runs per cell (seeds 0..n-1)")
    ap.add_argument("--scenario", default="car")
    args = ap.parse_args(argv)
    if not args.table:
        ap.print_help()
        return 0
    print(format_vertical_table(vertical_error_table(seeds=tuple(range(args.seeds)),
                                                     scenario=args.scenario)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
