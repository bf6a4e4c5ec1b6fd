"""The physics vehicle's MuJoCo model: ``models/car.xml`` edited with ``MjSpec`` into the
variant a :class:`~simcalib.world.vehicle_config.VehicleConfig` asks for — geometry (wheel
positions and radii, mass, the rig-mount site), Ackermann or differential drive (the
differential one on ball casters), sprung or rigid corners (springs preloaded so the
chassis rides at q = 0), flat, sloped or uneven ground (a height field of random bumps
drawn from ``rng``) — and the ids the simulation reads. The drive itself is
:mod:`simcalib.world.vehicle`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from simcalib.world.render_backend import import_mujoco as _mujoco
from simcalib.world.vehicle_config import VehicleConfig

__all__ = ["BuiltVehicle", "CAR_XML", "CORNERS", "VehicleIds", "apply_vehicle_geometry",
           "build_variant", "build_vehicle_model", "lookup_ids", "terrain_heights"]

CAR_XML = Path(__file__).resolve().parents[2] / "models" / "car.xml"
CORNERS = ("fl", "fr", "rl", "rr")
_G = 9.81


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


@dataclass(frozen=True)
class BuiltVehicle:
    """A compiled variant: the ``MjModel``, its MJCF text and its ground's height(x, y)."""
    model: object
    spec_xml: str
    ground_height: Callable = field(repr=False)


def build_vehicle_model(cfg: VehicleConfig, rng: np.random.Generator | None = None,
                        extent_xy_m=((-30.0, 30.0), (-30.0, 30.0))):
    """``(MjModel, ground_height(x, y))`` of the variant ``cfg`` (models/car.xml edited
    with MjSpec). ``extent_xy_m`` bounds the uneven ground's height field; ``rng`` draws
    its bumps (required for ``ground='uneven'``)."""
    b = build_variant(cfg, rng, extent_xy_m)
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


def build_variant(cfg: VehicleConfig, rng, extent_xy_m) -> BuiltVehicle:
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
    return BuiltVehicle(model, spec.to_xml(), height)


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


@dataclass(frozen=True)
class VehicleIds:
    """MuJoCo ids and dof addresses of a compiled vehicle model."""
    aid: dict
    chassis: int
    mount: int
    wheels: tuple
    hub_ids: list
    spin_dof: list
    spin_dof_all: dict


def lookup_ids(mujoco, model) -> VehicleIds:
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
    return VehicleIds(aid, chassis_id, mount_id, wheels, hub_ids, spin_dof, spin_dof_all)
