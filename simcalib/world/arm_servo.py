"""The UR5e arm (or another 6-joint arm MJCF) with joint servos, for MuJoCo physics.

:func:`build_controlled_arm` adds one torque-limited joint servo per hinge with ``MjSpec``::

    tau_j = clip(kp_j (q_ref_j - q_j) + kd_j (qd_ref_j - qd_j), ±max_torque_nm_j)

(a MuJoCo ``general`` actuator: gain 1 on ``ctrl = kp q_ref + kd qd_ref``, bias
``-kp q - kd qd``, ``forcerange`` = the torque limit), plus gravity compensation of the
links (``gravcomp``, as a UR controller's model-based feed-forward; optional). The gains
(:class:`ArmGains`) and limits (:class:`ArmLimits`) are UR5e-like by default. The run that
drives the servos along a joint path is :mod:`simcalib.world.arm_control`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simcalib.world.render_backend import import_mujoco as _mujoco

__all__ = ["ArmGains", "ArmLimits", "UR5E_XML", "build_controlled_arm"]

UR5E_XML = Path(__file__).resolve().parents[2] / "models" / "ur5e.xml"


def _per_joint(name, value, n, lo=0.0, lo_open=True, hi=None):
    arr = np.atleast_1d(np.asarray(value, dtype=object))
    if arr.ndim != 1 or arr.size not in (1, n):
        raise ValueError(f"{name} must be a number or {n} numbers (one per joint); "
                         f"received {value!r}")
    out = []
    for v in arr:
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise TypeError(f"{name} must be numbers; received {value!r}")
        v = float(v)
        if not math.isfinite(v) or (v <= lo if lo_open else v < lo) or (hi is not None
                                                                        and v > hi):
            rng_txt = f"{'(' if lo_open else '['}{lo}, {hi if hi is not None else 'inf'}]"
            raise ValueError(f"{name} must be finite and in {rng_txt}; received {value!r}")
        out.append(v)
    return tuple(out * n) if len(out) == 1 else tuple(out)


@dataclass(frozen=True)
class ArmGains:
    """Joint servo gains, one per joint or one for all: ``kp_nm_per_rad`` (N m/rad),
    ``kd_nm_s_per_rad`` (N m s/rad). Defaults: a stiff UR-like servo, ~0.7 damping ratio
    and 5-10 Hz bandwidth on the built-in UR5e at its home pose."""
    kp_nm_per_rad: tuple = (3000.0, 3000.0, 1500.0, 300.0, 300.0, 300.0)
    kd_nm_s_per_rad: tuple = (70.0, 90.0, 40.0, 8.0, 8.0, 8.0)

    def resolved(self, n: int):
        return (np.array(_per_joint("ArmGains.kp_nm_per_rad", self.kp_nm_per_rad, n)),
                np.array(_per_joint("ArmGains.kd_nm_s_per_rad", self.kd_nm_s_per_rad, n,
                                    lo_open=False)))


@dataclass(frozen=True)
class ArmLimits:
    """Actuation limits: ``max_torque_nm`` per joint (UR5e data sheet: 150 N m base,
    shoulder, elbow; 28 N m wrists) and ``max_velocity_rad_s`` of the reference (UR5e:
    180 °/s). Joint position limits are the model's joint ranges (a target outside them
    raises ``ValueError``)."""
    max_torque_nm: tuple = (150.0, 150.0, 150.0, 28.0, 28.0, 28.0)
    max_velocity_rad_s: tuple = (math.pi,) * 6

    def resolved(self, n: int):
        return (np.array(_per_joint("ArmLimits.max_torque_nm", self.max_torque_nm, n)),
                np.array(_per_joint("ArmLimits.max_velocity_rad_s", self.max_velocity_rad_s,
                                    n)))


def build_controlled_arm(model=None, gains: ArmGains = ArmGains(),
                         limits: ArmLimits = ArmLimits(), *, gravity_compensation=True,
                         timestep_s: float = 0.001):
    """``(MjModel, joint_names)``: the arm with one PD servo per hinge joint (see module
    docstring). ``model``: ``None`` (built-in UR5e), a path to an MJCF file, or a
    ``mujoco.MjSpec`` (copied, not modified)."""
    mujoco = _mujoco()
    if model is None:
        spec = mujoco.MjSpec.from_file(str(UR5E_XML))
    elif isinstance(model, (str, Path)):
        p = Path(model).expanduser()
        if not p.is_file():
            raise ValueError(f"model file {str(p)!r} does not exist")
        spec = mujoco.MjSpec.from_file(str(p))
    elif isinstance(model, mujoco.MjSpec):
        spec = model.copy()
    else:
        raise TypeError("model must be None (built-in UR5e), a path to an MJCF file or a "
                        f"mujoco.MjSpec; received {type(model).__name__} (an MjModel cannot "
                        "get actuators added: pass its MjSpec)")
    if not (isinstance(timestep_s, (int, float)) and 1e-5 <= float(timestep_s) <= 0.002):
        raise ValueError(f"timestep_s must be in [1e-05, 0.002] s (>= 500 Hz); "
                         f"received {timestep_s!r}")
    spec.option.timestep = float(timestep_s)
    hinges = [j for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_HINGE]
    if not hinges:
        raise ValueError("the arm model has no hinge joints to control")
    if len(spec.actuators):
        raise ValueError(f"the arm model already has {len(spec.actuators)} actuator(s); "
                         "pass a model without actuators (the servos are added here)")
    n = len(hinges)
    kp, kd = gains.resolved(n)
    tmax, _ = limits.resolved(n)
    for j, jnt in enumerate(hinges):
        a = spec.add_actuator(name=f"servo_{jnt.name}", target=jnt.name,
                              trntype=mujoco.mjtTrn.mjTRN_JOINT)
        a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        a.gainprm[0] = 1.0
        a.biasprm[0] = 0.0
        a.biasprm[1] = -kp[j]
        a.biasprm[2] = -kd[j]
        a.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        a.forcerange = [-tmax[j], tmax[j]]
    if gravity_compensation:
        for b in spec.bodies:
            if b.name != "world":
                b.gravcomp = 1.0
    m = spec.compile()
    return m, tuple(j.name for j in hinges)
