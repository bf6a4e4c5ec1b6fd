"""Configuration of the physics vehicle (:class:`VehicleConfig`): the section
``world.vehicle`` of a scenario. Config only (numpy, no MuJoCo): the simulation that uses
it is :mod:`simcalib.world.vehicle`."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

__all__ = ["VehicleConfig", "DRIVES", "GROUNDS"]

DRIVES = ("ackermann", "differential")
GROUNDS = ("flat", "slope", "uneven")


# ------------------------------------------------------------------------------ config
def _check_choice(name, value, allowed):
    if not isinstance(value, str) or value not in allowed:
        raise ValueError(f"VehicleConfig.{name} must be one of {list(allowed)}; "
                         f"received {value!r}")


def _check_number(name, value, lo=None, hi=None, lo_open=False, hi_open=False):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"VehicleConfig.{name} must be a number; received {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"VehicleConfig.{name} must be finite; received {value!r}")
    bad_lo = lo is not None and (v <= lo if lo_open else v < lo)
    bad_hi = hi is not None and (v >= hi if hi_open else v > hi)
    if bad_lo or bad_hi:
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        raise ValueError(f"VehicleConfig.{name} must be in {lb}{lo}, {hi}{rb}; "
                         f"received {value!r}")


@dataclass(frozen=True)
class VehicleConfig:
    """A physics vehicle variant and its driving. SI units (m, s, kg, N, rad) unless the
    name says ``_deg``.

    Variant: ``drive`` ``"ackermann"`` (front-steered, rear-wheel drive, four-wheel
    brakes) or ``"differential"`` (a platform with two driven wheels at the middle of the
    wheelbase steering by speed difference, and four ball casters at the corners; the
    driven wheels carry half the weight, so its grip limits it to gentle driving);
    ``sprung`` True = slide-joint suspension at each corner with
    ``suspension_stiffness_npm`` / ``suspension_damping_nspm`` (travel
    ``±suspension_travel_m``), False = wheels rigidly on the chassis; ``ground``
    ``"flat"``, ``"slope"`` (plane rising ``slope_deg`` along world +x) or ``"uneven"``
    (height field: random smooth bumps of peak height ``bump_amplitude_m`` and dominant
    wavelength ``bump_wavelength_m``, phases from the rng).
    Geometry: ``wheelbase_m``, ``track_m``, ``wheel_radius_m``, ``chassis_mass_kg`` (CG
    ``cg_height_m`` above the ground), ``friction`` (tyre-ground Coulomb coefficient),
    ``mount_pos_m`` rig-mount site in the chassis frame (x fwd, y left, z up from the
    ground under the wheelbase centre).
    Driving: ``speed_mps`` cruise speed along the path, ramped at ``accel_mps2`` and
    stopped at the path end at ``decel_mps2``; pure pursuit with lookahead
    ``max(lookahead_min_m, lookahead_gain_s * v)``; steering limited to
    ``max_steer_deg``; wheel torque limited to ``max_wheel_torque_nm``.
    Simulation: ``timestep_s`` (<= 0.002 s, i.e. >= 500 Hz), ``control_rate_hz``
    (controller update), ``sample_rate_hz`` (recorded poses), ``settle_s`` (standing
    time before the drive starts, not recorded), ``max_duration_s`` (guard)."""
    drive: str = "ackermann"
    sprung: bool = True
    ground: str = "flat"
    slope_deg: float = 0.0
    bump_amplitude_m: float = 0.03
    bump_wavelength_m: float = 4.0
    speed_mps: float = 6.0
    accel_mps2: float = 1.5
    decel_mps2: float = 2.5
    wheelbase_m: float = 2.7
    track_m: float = 1.6
    wheel_radius_m: float = 0.33
    chassis_mass_kg: float = 1400.0
    cg_height_m: float = 0.55
    suspension_stiffness_npm: float = 35000.0
    suspension_damping_nspm: float = 3500.0
    suspension_travel_m: float = 0.12
    friction: float = 1.0
    mount_pos_m: tuple = (0.8, 0.0, 1.55)
    max_steer_deg: float = 35.0
    max_wheel_torque_nm: float = 2500.0
    lookahead_min_m: float = 4.0
    lookahead_gain_s: float = 0.5
    speed_kp_per_s: float = 2.0
    speed_ki_per_s2: float = 0.5
    timestep_s: float = 0.001
    control_rate_hz: float = 100.0
    sample_rate_hz: float = 100.0
    settle_s: float = 1.5
    max_duration_s: float = 600.0

    def __post_init__(self):
        _check_choice("drive", self.drive, DRIVES)
        _check_choice("ground", self.ground, GROUNDS)
        if not isinstance(self.sprung, (bool, np.bool_)):
            raise TypeError(f"VehicleConfig.sprung must be a bool; received {self.sprung!r}")
        _check_number("slope_deg", self.slope_deg, -20.0, 20.0)
        if self.ground == "slope" and float(self.slope_deg) == 0.0:
            raise ValueError("VehicleConfig.ground='slope' needs a non-zero slope_deg "
                             "(within [-20, 20] degrees); received slope_deg=0.0 "
                             "(use ground='flat' for no slope)")
        if self.ground != "slope" and float(self.slope_deg) != 0.0:
            raise ValueError(f"VehicleConfig.slope_deg={self.slope_deg!r} is only used with "
                             f"ground='slope'; received ground={self.ground!r}")
        _check_number("bump_amplitude_m", self.bump_amplitude_m, 0.0, 0.3, lo_open=True)
        _check_number("bump_wavelength_m", self.bump_wavelength_m, 0.5, 100.0)
        _check_number("speed_mps", self.speed_mps, 0.0, 30.0, lo_open=True)
        _check_number("accel_mps2", self.accel_mps2, 0.0, 8.0, lo_open=True)
        _check_number("decel_mps2", self.decel_mps2, 0.0, 9.0, lo_open=True)
        _check_number("wheelbase_m", self.wheelbase_m, 0.3, 6.0)
        _check_number("track_m", self.track_m, 0.2, 3.0)
        _check_number("wheel_radius_m", self.wheel_radius_m, 0.05, 0.6)
        if float(self.wheel_radius_m) >= 0.5 * float(self.wheelbase_m):
            raise ValueError(f"VehicleConfig.wheel_radius_m={self.wheel_radius_m!r} must be "
                             f"< wheelbase_m / 2 = {0.5 * float(self.wheelbase_m)!r} "
                             "(front and rear wheels would overlap)")
        _check_number("chassis_mass_kg", self.chassis_mass_kg, 1.0, 10000.0)
        _check_number("cg_height_m", self.cg_height_m, 0.05, 2.0)
        _check_number("suspension_stiffness_npm", self.suspension_stiffness_npm, 0.0, 1e7,
                      lo_open=True)
        _check_number("suspension_damping_nspm", self.suspension_damping_nspm, 0.0, 1e6)
        _check_number("suspension_travel_m", self.suspension_travel_m, 0.01, 0.5)
        _check_number("friction", self.friction, 0.05, 3.0)
        m = np.asarray(self.mount_pos_m, dtype=object)
        if m.shape != (3,):
            raise ValueError(f"VehicleConfig.mount_pos_m must be 3 numbers (x, y, z) in m; "
                             f"received {self.mount_pos_m!r}")
        for i, v in enumerate(self.mount_pos_m):
            _check_number(f"mount_pos_m[{i}]", v, -10.0, 10.0)
        _check_number("max_steer_deg", self.max_steer_deg, 1.0, 60.0)
        _check_number("max_wheel_torque_nm", self.max_wheel_torque_nm, 0.0, 1e5, lo_open=True)
        _check_number("lookahead_min_m", self.lookahead_min_m, 0.1, 50.0)
        _check_number("lookahead_gain_s", self.lookahead_gain_s, 0.0, 5.0)
        _check_number("speed_kp_per_s", self.speed_kp_per_s, 0.0, 50.0, lo_open=True)
        _check_number("speed_ki_per_s2", self.speed_ki_per_s2, 0.0, 50.0)
        _check_number("timestep_s", self.timestep_s, 1e-5, 0.002)
        _check_number("control_rate_hz", self.control_rate_hz, 1.0, 1000.0)
        _check_number("sample_rate_hz", self.sample_rate_hz, 1.0, 1000.0)
        _check_number("settle_s", self.settle_s, 0.0, 30.0)
        _check_number("max_duration_s", self.max_duration_s, 0.1, 3600.0)
        for name, rate in (("control_rate_hz", self.control_rate_hz),
                           ("sample_rate_hz", self.sample_rate_hz)):
            n = 1.0 / (float(rate) * float(self.timestep_s))
            if abs(n - round(n)) > 1e-6 or round(n) < 1:
                raise ValueError(f"VehicleConfig.{name}={rate!r} must divide the physics "
                                 f"rate 1/timestep_s = {1.0 / float(self.timestep_s):g} Hz "
                                 "into a whole number of steps")

    @property
    def steps_per_control(self) -> int:
        return int(round(1.0 / (self.control_rate_hz * self.timestep_s)))

    @property
    def steps_per_sample(self) -> int:
        return int(round(1.0 / (self.sample_rate_hz * self.timestep_s)))

    def replace(self, **changes) -> "VehicleConfig":
        names = {f.name for f in fields(self)}
        bad = sorted(set(changes) - names)
        if bad:
            raise ValueError(f"unknown VehicleConfig field(s) {bad}; valid: {sorted(names)}")
        return VehicleConfig(**{**{n: getattr(self, n) for n in names}, **changes})
