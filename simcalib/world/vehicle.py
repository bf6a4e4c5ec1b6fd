"""A car-scale wheeled vehicle driven through MuJoCo physics (not posed).

``simulate_vehicle(cfg, path, rng) -> VehicleTrajectory``: the vehicle of
``models/car.xml``, edited with ``MjSpec`` into the variant a :class:`VehicleConfig`
asks for (Ackermann or differential drive, sprung or rigid chassis, flat / sloped /
uneven ground), follows a planar path with a pure-pursuit steering controller and a
speed PI controller acting on wheel-torque actuators. The chassis pitches and rolls by
itself on its suspension under acceleration, braking and turning, and follows the
ground. The ground-truth poses are the physics' poses of the chassis and of the roof
site ``rig_mount`` (camera poses = ``T_world_rig_mount @ T_mount_cam``).

The path's geometry (x, y) is followed at ``cfg.speed_mps`` (ramped at
``cfg.accel_mps2``, braked to a stop at the end at ``cfg.decel_mps2``); its time column
only orders the points and its yaw only sets the start heading. :func:`figure_eight_path`
samples the registry's ``planar`` cart path (a Lissajous figure-eight) at car scale.

Deterministic: all randomness (the uneven ground's bumps) comes from ``rng``; MuJoCo's
stepping is deterministic, so the same config and seed give the same trajectory.

CLI: ``python -m simcalib.world.vehicle --table`` regenerates the roll/pitch table of
docs/physics.md.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable


import numpy as np

from simcalib.world.render import import_mujoco as _mujoco

__all__ = ["VehicleConfig", "VehicleTrajectory", "PlanarPath", "DRIVES", "GROUNDS",
           "simulate_vehicle", "build_vehicle_model", "figure_eight_path", "as_planar_path",
           "terrain_heights", "translation_sensitivity", "apply_vehicle_geometry",
           "physics_table", "step_cost_us", "CAR_XML"]

CAR_XML = Path(__file__).resolve().parents[2] / "models" / "car.xml"
CORNERS = ("fl", "fr", "rl", "rr")
_G = 9.81

from simcalib.world.vehicle_config import (DRIVES, GROUNDS, VehicleConfig,  # noqa: E402
                                           _check_number)


# -------------------------------------------------------------------------------- path
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


# ------------------------------------------------------------------------------ ground
def terrain_heights(cfg: VehicleConfig, xs: np.ndarray, ys: np.ndarray,
                    rng: np.random.Generator) -> np.ndarray:
    """Uneven-ground heights on the grid ``xs`` x ``ys`` (shape ``(len(ys), len(xs))``):
    a sum of 16 plane waves with random directions, wavelengths
    ``bump_wavelength_m * U(0.7, 1.4)`` and phases, scaled so the peak |height| on the
    grid equals ``bump_amplitude_m``."""
    k = 16
    theta = rng.uniform(0.0, np.pi, k)
    lam = cfg.bump_wavelength_m * rng.uniform(0.7, 1.4, k)
    phase = rng.uniform(0.0, 2.0 * np.pi, k)
    X, Y = np.meshgrid(xs, ys)
    h = np.zeros_like(X)
    for i in range(k):
        h += np.sin(2.0 * np.pi * (np.cos(theta[i]) * X + np.sin(theta[i]) * Y) / lam[i]
                    + phase[i])
    return h * (cfg.bump_amplitude_m / np.abs(h).max())


# ------------------------------------------------------------------------------- model
@dataclass(frozen=True)
class _Built:
    model: object
    spec_xml: str
    ground_height: Callable = field(repr=False)


def build_vehicle_model(cfg: VehicleConfig, rng: np.random.Generator | None = None,
                        extent_xy_m=((-30.0, 30.0), (-30.0, 30.0))):
    """``(MjModel, ground_height(x, y))`` of the variant ``cfg`` (models/car.xml edited
    with MjSpec). ``extent_xy_m`` bounds the uneven ground's height field; ``rng`` draws
    its bumps (required for ``ground='uneven'``)."""
    b = _build(cfg, rng, extent_xy_m)
    return b.model, b.ground_height


def apply_vehicle_geometry(spec, cfg: VehicleConfig) -> None:
    """Edit a ``models/car.xml`` ``MjSpec`` to the geometry of ``cfg``: wheel positions and
    radii, tyre friction, chassis mass and inertia, the (visual) shell scaled with the
    footprint, and the rig-mount site at ``cfg.mount_pos_m``. Used by the physics build and
    by the kinematic copy the ``car`` platform puts in a scene (one place for both)."""
    L, W, r = float(cfg.wheelbase_m), float(cfg.track_m), float(cfg.wheel_radius_m)
    for c in CORNERS:
        sx = 0.5 * L if c[0] == "f" else -0.5 * L
        sy = 0.5 * W if c[1] == "l" else -0.5 * W
        spec.body(f"susp_{c}").pos = [sx, sy, r]
        spec.geom(f"tyre_{c}").size = [r, 0.0, 0.0]
        spec.geom(f"wheel_{c}_visual").size = [r, 0.33 * r, 0.0]
        spec.geom(f"tyre_{c}").friction = [float(cfg.friction), 0.005, 0.0001]
    spec.geom("ground").friction = [float(cfg.friction), 0.005, 0.0001]
    chassis = spec.body("chassis")
    mass = float(cfg.chassis_mass_kg)
    chassis.mass = mass
    chassis.ipos = [0.0, 0.0, float(cfg.cg_height_m)]
    # box-like inertia for a body of length ~1.65 L, width ~1.1 W, height 1.2 m
    lx, ly, lz = 1.65 * L, 1.1 * W, 1.2
    chassis.inertia = [mass * (ly ** 2 + lz ** 2) / 12, mass * (lx ** 2 + lz ** 2) / 12,
                       mass * (lx ** 2 + ly ** 2) / 12]
    # the shell scales with the footprint (visual only)
    sxl = L / 2.7
    syl = W / 1.6
    for gname, base_pos, base_size in (("body_lower", (0, 0, 0.72), (2.25, 0.88, 0.30)),
                                       ("body_cabin", (-0.25, 0, 1.22), (1.25, 0.80, 0.22)),
                                       ("rack_bar", (0.8, 0, 1.47), (0.04, 0.75, 0.03))):
        g = spec.geom(gname)
        g.pos = [base_pos[0] * sxl, 0.0, base_pos[2]]
        g.size = [base_size[0] * sxl, base_size[1] * syl, base_size[2]]
    spec.site("rig_mount").pos = [float(v) for v in cfg.mount_pos_m]


def _build(cfg: VehicleConfig, rng, extent_xy_m) -> _Built:
    """Compile the variant ``cfg`` of models/car.xml and its ground-height function."""
    mujoco = _mujoco()
    spec = mujoco.MjSpec.from_file(str(CAR_XML))
    spec.option.timestep = float(cfg.timestep_s)
    apply_vehicle_geometry(spec, cfg)
    _set_suspension(spec, cfg)
    if cfg.drive == "ackermann":
        _set_ackermann_limits(spec, cfg)
    else:
        _make_differential(mujoco, spec, cfg)
    height = _set_ground(mujoco, spec, cfg, rng, extent_xy_m)
    model = spec.compile()
    if cfg.sprung:
        _preload_springs(mujoco, model, cfg)
    return _Built(model, spec.to_xml(), height)


def _set_suspension(spec, cfg: VehicleConfig) -> None:
    """Give the four corner slide joints their spring, damper and travel, or delete them."""
    travel = float(cfg.suspension_travel_m)
    for c in CORNERS:
        j = spec.joint(f"susp_{c}")
        if cfg.sprung:
            j.stiffness = [float(cfg.suspension_stiffness_npm), 0.0, 0.0]
            j.damping = [float(cfg.suspension_damping_nspm), 0.0, 0.0]
            j.range = [-travel, travel]
        else:
            spec.delete(j)


def _set_ackermann_limits(spec, cfg: VehicleConfig) -> None:
    """Limit the front steering joints/actuators and the drive/brake torques of the car."""
    max_steer = math.radians(float(cfg.max_steer_deg))
    tq = float(cfg.max_wheel_torque_nm)
    for c in ("fl", "fr"):
        spec.joint(f"steer_{c}").range = [-max_steer, max_steer]
        spec.actuator(f"steer_{c}").ctrlrange = [-max_steer, max_steer]
    for name in ("drive_rl", "drive_rr", "brake_fl", "brake_fr"):
        spec.actuator(name).ctrlrange = [-tq, tq]


def _make_differential(mujoco, spec, cfg: VehicleConfig) -> None:
    """Turn the car into a differential-drive platform with four ball casters."""
    # differential: the driven wheels (rl, rr) move to the middle of the wheelbase,
    # the front corners become ball casters and two more casters (bl, br) are added at
    # the rear: a differential-drive platform turning about its centre
    L, W, r = float(cfg.wheelbase_m), float(cfg.track_m), float(cfg.wheel_radius_m)
    tq = float(cfg.max_wheel_torque_nm)
    for c in ("fl", "fr"):
        spec.delete(spec.actuator(f"steer_{c}"))
        spec.delete(spec.actuator(f"brake_{c}"))
        spec.delete(spec.joint(f"steer_{c}"))
        spec.delete(spec.joint(f"spin_{c}"))
        spec.body(f"wheel_{c}").add_joint(name=f"caster_{c}",
                                          type=mujoco.mjtJoint.mjJNT_BALL,
                                          damping=0.2, armature=0.05)
        spec.geom(f"wheel_{c}_visual").type = mujoco.mjtGeom.mjGEOM_SPHERE
        spec.geom(f"wheel_{c}_visual").size = [r, 0.0, 0.0]
    for c in ("rl", "rr"):
        spec.body(f"susp_{c}").pos = [0.0, 0.5 * W if c[1] == "l" else -0.5 * W, r]
    chassis = spec.body("chassis")
    for c in ("bl", "br"):
        _add_rear_caster(mujoco, chassis, cfg, c, L, W, r)
    for name in ("drive_rl", "drive_rr"):
        spec.actuator(name).ctrlrange = [-tq, tq]


def _add_rear_caster(mujoco, chassis, cfg: VehicleConfig, c, L, W, r) -> None:
    """Add the (sprung) ball-caster corner ``c`` (``bl``/``br``) at the rear of the chassis."""
    travel = float(cfg.suspension_travel_m)
    hub = chassis.add_body(name=f"susp_{c}",
                           pos=[-0.5 * L, 0.5 * W if c[1] == "l" else -0.5 * W, r],
                           mass=25.0, ipos=[0, 0, 0], inertia=[0.5, 0.5, 0.5],
                           explicitinertial=True)
    if cfg.sprung:
        hub.add_joint(name=f"susp_{c}", type=mujoco.mjtJoint.mjJNT_SLIDE,
                      axis=[0, 0, 1], range=[-travel, travel], armature=0.01,
                      stiffness=[float(cfg.suspension_stiffness_npm), 0, 0],
                      damping=[float(cfg.suspension_damping_nspm), 0, 0])
    wheel = hub.add_body(name=f"wheel_{c}", mass=15.0, ipos=[0, 0, 0],
                         inertia=[0.6, 0.6, 0.6], explicitinertial=True)
    wheel.add_joint(name=f"caster_{c}", type=mujoco.mjtJoint.mjJNT_BALL,
                    damping=0.2, armature=0.05)
    wheel.add_geom(name=f"tyre_{c}", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                   size=[r, 0, 0], contype=1, conaffinity=0, condim=3, group=3,
                   friction=[float(cfg.friction), 0.005, 0.0001],
                   rgba=[0.2, 0.2, 0.2, 0.3])
    wheel.add_geom(name=f"wheel_{c}_visual", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                   size=[r, 0, 0], contype=0, conaffinity=0, material="car_tyre")


def _set_ground(mujoco, spec, cfg: VehicleConfig, rng, extent_xy_m) -> Callable:
    """Shape the ground geom (flat, sloped or uneven) and return its height(x, y)."""
    ground = spec.geom("ground")
    if cfg.ground == "flat":
        def height(x, y):
            return np.zeros_like(np.asarray(x, dtype=np.float64))
    elif cfg.ground == "slope":
        a = math.radians(float(cfg.slope_deg))
        ground.quat = [math.cos(-0.5 * a), 0.0, math.sin(-0.5 * a), 0.0]
        ta = math.tan(a)

        def height(x, y):
            return ta * np.asarray(x, dtype=np.float64)
    else:
        height = _set_uneven_ground(mujoco, spec, ground, cfg, rng, extent_xy_m)
    return height


def _set_uneven_ground(mujoco, spec, ground, cfg: VehicleConfig, rng,
                       extent_xy_m) -> Callable:
    """Make the ground a height field of random bumps over ``extent_xy_m``; its height(x, y)."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError("ground='uneven' needs rng, a numpy.random.Generator (it draws "
                        f"the bumps); received {type(rng).__name__}")
    (x0, x1), (y0, y1) = extent_xy_m
    step = min(0.25, float(cfg.bump_wavelength_m) / 8.0)
    ncol = int(math.ceil((x1 - x0) / step)) + 1
    nrow = int(math.ceil((y1 - y0) / step)) + 1
    if nrow * ncol > 4_000_000:
        raise ValueError(f"the uneven ground over {x1 - x0:.0f} x {y1 - y0:.0f} m at "
                         f"{step:.3g} m spacing needs {nrow * ncol} samples (> 4e6); "
                         "use a longer bump_wavelength_m or a smaller path")
    x1 = x0 + (ncol - 1) * step
    y1 = y0 + (nrow - 1) * step
    xs = np.linspace(x0, x1, ncol)
    ys = np.linspace(y0, y1, nrow)
    A = float(cfg.bump_amplitude_m)
    h = terrain_heights(cfg, xs, ys, rng)
    spec.add_hfield(name="terrain", size=[0.5 * (x1 - x0), 0.5 * (y1 - y0), 2.0 * A, 0.5],
                    nrow=nrow, ncol=ncol, userdata=[float(v) for v in h.ravel()])
    ground.type = mujoco.mjtGeom.mjGEOM_HFIELD
    ground.hfieldname = "terrain"
    ground.pos = [0.5 * (x0 + x1), 0.5 * (y0 + y1), -A]
    ground.material = ""
    ground.rgba = [0.45, 0.45, 0.47, 1.0]
    # MuJoCo normalises the samples to [0, 1] over [min, max] of h: the rendered and
    # collided surface is z = -A + 2A (h - min) / (max - min)
    hmin, hmax = float(h.min()), float(h.max())
    hz = -A + 2.0 * A * (h - hmin) / (hmax - hmin)
    from scipy.interpolate import RegularGridInterpolator
    interp = RegularGridInterpolator((ys, xs), hz, bounds_error=False, fill_value=None)

    def height(x, y):
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        return interp(np.stack([y, x], axis=-1))
    return height


def _preload_springs(mujoco, model, cfg: VehicleConfig) -> None:
    """Set the suspension springs' rest positions so the chassis rides at q = 0."""
    # spring preload, so that the chassis rides at q = 0: Ackermann, a quarter of the
    # sprung weight per corner; differential, half on the two driven wheels and an eighth
    # on each of the four casters (symmetric about the CG)
    mass = float(cfg.chassis_mass_kg)
    if cfg.drive == "ackermann":
        share = {c: 0.25 for c in CORNERS}
    else:
        share = {"rl": 0.25, "rr": 0.25, "fl": 0.125, "fr": 0.125, "bl": 0.125,
                 "br": 0.125}
    for c, f in share.items():
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"susp_{c}")
        model.qpos_spring[model.jnt_qposadr[jid]] = -(
            f * mass * _G / float(cfg.suspension_stiffness_npm))


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
    built = _build(cfg, rng_ground, _ground_extent(cfg, p))
    model = built.model
    data = mujoco.MjData(model)
    t_build = time.perf_counter() - t_wall0

    ids = _lookup_ids(mujoco, model)
    # the controlled point (driven-axle centre: rear axle, or the middle of the
    # differential platform) starts on the path's first point
    x_ctrl = -0.5 * float(cfg.wheelbase_m) if cfg.drive == "ackermann" else 0.0
    _place_at_path_start(mujoco, model, data, cfg, p, built.ground_height, x_ctrl)
    follower = _PathFollower(cfg, p, model, data, ids, x_ctrl)
    follower.settle(mujoco)
    rec, step, t_sim = _drive_and_record(mujoco, model, data, cfg, ids, follower)
    return _trajectory_from_record(rec, step, cfg, ids.wheels, built, t_build, t_sim, t_wall0)


def _ground_extent(cfg: VehicleConfig, p: PlanarPath):
    """The ground's ``((x0, x1), (y0, y1))``: the path's bounding box plus a margin."""
    margin = 12.0 + 2.0 * float(cfg.wheelbase_m)
    return ((float(p.x.min()) - margin, float(p.x.max()) + margin),
            (float(p.y.min()) - margin, float(p.y.max()) + margin))


@dataclass(frozen=True)
class _Ids:
    """MuJoCo ids and dof addresses of a compiled vehicle model."""
    aid: dict
    chassis: int
    mount: int
    wheels: tuple
    hub_ids: list
    spin_dof: list
    spin_dof_all: dict


def _lookup_ids(mujoco, model) -> _Ids:
    """The actuator, body, site ids and wheel spin dofs of ``model`` (wheels with a spin joint)."""
    jid = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in
           [f"spin_{c}" for c in CORNERS] + ["steer_fl", "steer_fr"]}
    aid = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in
           ("steer_fl", "steer_fr", "drive_rl", "drive_rr", "brake_fl", "brake_fr")}
    chassis_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "chassis")
    mount_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "rig_mount")
    wheels = tuple(c for c in CORNERS if jid[f"spin_{c}"] >= 0)
    hub_ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"steer_{c}") for c in wheels]
    spin_dof = [model.jnt_dofadr[jid[f"spin_{c}"]] for c in wheels]
    spin_dof_all = {c: model.jnt_dofadr[jid[f"spin_{c}"]] for c in wheels}
    return _Ids(aid, chassis_id, mount_id, wheels, hub_ids, spin_dof, spin_dof_all)


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


class _PathFollower:
    """Pure-pursuit steering and PI speed control of the vehicle along the path."""

    def __init__(self, cfg: VehicleConfig, p: PlanarPath, model, data, ids: _Ids,
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


def _check_on_path(cfg: VehicleConfig, last, t: float) -> None:
    """Raise ``ValueError`` when the cross-track error of ``last`` exceeds 5 m."""
    if last[3] > 5.0:
        raise ValueError(
            f"the vehicle left the path (cross-track error {last[3]:.2f} m at "
            f"t = {t:.2f} s, speed {last[0]:.2f} m/s): the path is "
            f"too tight for speed_mps={cfg.speed_mps} with friction {cfg.friction} "
            f"and max_steer_deg={cfg.max_steer_deg}; lower the speed or widen the path")


def _drive_and_record(mujoco, model, data, cfg: VehicleConfig, ids: _Ids,
                      follower: _PathFollower):
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


def _record_sample(mujoco, model, data, cfg: VehicleConfig, ids: _Ids, rec: dict, t: float,
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


def _wheel_slips(mujoco, model, data, r: float, ids: _Ids, res6):
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
                            built: _Built, t_build: float, t_sim: float,
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
