"""Robot error: the arm the world moves (true kinematics) versus the arm the user believes
(nominal DH table), and the joint encoders that connect them.

* Kinematics: standard DH, ``T_i = Rz(q_i + theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``
  (UR5e table :data:`UR5E_DH`, the one in ``models/ur5e.xml``). The *true* arm is the
  nominal table plus a deviation ``(dtheta_i, dd_i, da_i, dalpha_i)`` per joint
  (:class:`KinematicErrorConfig` sigmas, drawn from the run's ``robot`` generator, or given
  explicitly as ``world.arm_dh_error``). The world's MuJoCo arm is built from the true table
  (:func:`apply_dh_to_spec`), so IK, camera poses and renders follow the true arm; the
  ``robot_fk`` source maps encoder readings through the nominal table.
* Encoders (:class:`EncoderConfig`): the reading of joint ``i`` is
  ``quantise(q_i + backlash_i/2 * s_i + n_i)`` with ``s_i`` the sign of the joint's latest
  motion (kept while it stands still; the encoder sits on the motor side, the link lags by
  half the backlash), ``n_i ~ N(0, noise_rad^2)`` and quantisation to
  ``2 pi / counts_per_rev``.

Everything here is pure numpy (MuJoCo only inside :func:`apply_dh_to_spec`, on a spec
given to it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from simcalib.config.checks import check_int, check_range, set_fields
from simcalib.config.engine import key_help

__all__ = ["UR5E_DH", "DH_COLUMNS", "KinematicErrorConfig", "EncoderConfig", "RobotConfig",
           "dh_fk", "draw_dh_error", "true_dh", "check_dh_error", "apply_dh_to_spec",
           "fk_pose_error_basis",
           "encoder_readings", "robot_report", "ARM_LINK_BODIES", "ARM_FLANGE_SITE",
           "ARM_BASE_BODY", "ARM_JOINTS", "arm_state"]

#: Columns of a DH table / DH error: joint angle offset (rad), d (m), a (m), alpha (rad).
DH_COLUMNS = ("theta_rad", "d_m", "a_m", "alpha_rad")
#: Nominal UR5e DH table (Universal Robots), rows = joints 1..6, columns :data:`DH_COLUMNS`.
UR5E_DH = np.array([
    [0.0, 0.1625, 0.0, math.pi / 2],
    [0.0, 0.0, -0.425, 0.0],
    [0.0, 0.0, -0.3922, 0.0],
    [0.0, 0.1333, 0.0, math.pi / 2],
    [0.0, 0.0997, 0.0, -math.pi / 2],
    [0.0, 0.0996, 0.0, 0.0]])
#: Bodies of models/ur5e.xml placed by DH rows 1..5 (link<i+1> in link<i>), and the site
#: placed by row 6 (the flange, where the rig is mounted); the robot base body.
ARM_LINK_BODIES = ("link2", "link3", "link4", "link5", "link6")
ARM_FLANGE_SITE = "rig_mount"
ARM_BASE_BODY = "ur5e_base"



def _check_sigma(name: str, v) -> float:
    return check_range(name, v, lo=0.0)


@dataclass(frozen=True)
class KinematicErrorConfig:
    """Std of the deviation of each DH parameter of the true arm from the nominal table
    (every joint, independently, Gaussian). Zero (default): the true arm is the nominal
    one. Typical uncalibrated industrial arm: ~1 mm and ~1 mrad."""
    sigma_theta_rad: float = field(default=0.0, metadata=key_help(
        "joint zero offset error per joint, radians"))
    sigma_d_m: float = field(default=0.0, metadata=key_help("DH d error per joint, metres"))
    sigma_a_m: float = field(default=0.0, metadata=key_help("DH a error per joint, metres"))
    sigma_alpha_rad: float = field(default=0.0, metadata=key_help(
        "DH alpha (link twist) error per joint, radians"))

    def __post_init__(self):
        set_fields(self, **{name: _check_sigma(name, getattr(self, name)) for name in (
            "sigma_theta_rad", "sigma_d_m", "sigma_a_m", "sigma_alpha_rad")})

    @property
    def sigmas(self) -> np.ndarray:
        """``(4,)`` in :data:`DH_COLUMNS` order."""
        return np.array([self.sigma_theta_rad, self.sigma_d_m, self.sigma_a_m,
                         self.sigma_alpha_rad])

    @property
    def active(self) -> bool:
        return bool(np.any(self.sigmas > 0))


@dataclass(frozen=True)
class EncoderConfig:
    """Joint encoders read by ``robot_fk``: resolution, noise, backlash."""
    counts_per_rev: int = field(default=0, metadata=key_help(
        "encoder counts per joint revolution (0: no quantisation); UR-class arms ~2^18"))
    noise_rad: float = field(default=0.0, metadata=key_help(
        "Gaussian reading noise per joint and frame, radians (std)"))
    backlash_rad: float = field(default=0.0, metadata=key_help(
        "joint backlash (full play), radians: the reading leads the link by half of it in "
        "the direction of the latest motion"))

    def __post_init__(self):
        set_fields(self,
                   counts_per_rev=check_int("counts_per_rev", self.counts_per_rev, lo=0,
                                            hi=2 ** 32),
                   noise_rad=_check_sigma("noise_rad", self.noise_rad),
                   backlash_rad=_check_sigma("backlash_rad", self.backlash_rad))


@dataclass(frozen=True)
class RobotConfig:
    """The arm's error model (``robot.*``): kinematic error of the true arm (applies to the
    world whenever the platform is the built-in ``arm``) and its encoders (read by the
    ``robot_fk`` source). Defaults: an ideal robot."""
    kinematic_error: KinematicErrorConfig = field(default_factory=KinematicErrorConfig)
    encoder: EncoderConfig = field(default_factory=EncoderConfig)


# ------------------------------------------------------------------------ kinematics
def _link_transforms(q: np.ndarray, dh: np.ndarray) -> np.ndarray:
    """``(..., 6, 4, 4)``: ``Rz(q_i + theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``."""
    th = q + dh[:, 0]
    d, a, al = dh[:, 1], dh[:, 2], dh[:, 3]
    ct, st = np.cos(th), np.sin(th)
    ca, sa = np.cos(al), np.sin(al)
    ca, sa, d, a = (np.broadcast_to(v, th.shape) for v in (ca, sa, d, a))
    T = np.zeros(th.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
    T[..., 3, 3] = 1.0
    return T


def _check_dh(dh) -> np.ndarray:
    dh = np.asarray(dh, dtype=np.float64)
    if dh.ndim != 2 or dh.shape[1] != 4 or not np.isfinite(dh).all():
        raise ValueError(f"a DH table must be (joints, 4) finite numbers {DH_COLUMNS}; "
                         f"received shape {dh.shape}")
    return dh


def dh_fk(q, dh=UR5E_DH) -> np.ndarray:
    """``(..., 4, 4)`` flange pose in the robot base frame for joint angles ``q``
    ``(..., J)`` (radians) through the DH table ``dh`` ``(J, 4)``."""
    dh = _check_dh(dh)
    q = np.asarray(q, dtype=np.float64)
    if q.shape[-1:] != (dh.shape[0],):
        raise ValueError(f"q must have {dh.shape[0]} joint angles in its last axis; received "
                         f"shape {q.shape}")
    L = _link_transforms(q, dh)
    T = L[..., 0, :, :]
    for i in range(1, dh.shape[0]):
        T = T @ L[..., i, :, :]
    return T


def fk_pose_error_basis(q, T_flange_cam, sigmas, dh=UR5E_DH) -> np.ndarray:
    """How the true arm's DH deviation moves the poses a controller reports through the
    nominal table ``dh``: ``(N, 6, J * 4)`` — the pose error ``xi = (rotvec, t)`` of the
    camera mounted at ``T_flange_cam`` (``T_reported = T_true exp(xi)``, camera frame) at
    joint angles ``q`` ``(N, J)`` per 1-sigma ``sigmas`` ``(4,)`` (theta, d, a, alpha, the
    same for every joint) of each table entry, joint-major. Central differences of the
    flange pose (exact to second order); a sigma of 0 gives a zero column."""
    from simcalib.geometry import adjoint_from_transform, invert_transform, rotvec_from_matrix
    dh = _check_dh(dh)
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    sig = np.asarray(sigmas, dtype=np.float64).ravel()
    if q.shape[-1] != dh.shape[0] or not np.isfinite(q).all():
        raise ValueError(f"q must be (N, {dh.shape[0]}) finite joint angles; received shape "
                         f"{q.shape}")
    if sig.shape != (4,) or not np.isfinite(sig).all() or (sig < 0).any():
        raise ValueError(f"sigmas must be 4 finite numbers >= 0 {DH_COLUMNS}; received "
                         f"{sigmas!r}")
    T_fc = np.asarray(T_flange_cam, dtype=np.float64)
    if T_fc.shape != (4, 4) or not np.isfinite(T_fc).all():
        raise ValueError(f"T_flange_cam must be a finite 4x4 transform; received shape "
                         f"{T_fc.shape}")
    F0i = invert_transform(dh_fk(q, dh))
    J = np.zeros(q.shape[:1] + (6, dh.size))
    for j in range(dh.shape[0]):
        for c in range(4):
            if sig[c] == 0:
                continue
            xi = []
            for s in (1.0, -1.0):
                d2 = dh.copy()
                d2[j, c] += s * sig[c]
                E = F0i @ dh_fk(q, d2)             # FK_nominal^-1 FK_true
                xi.append(np.concatenate([rotvec_from_matrix(E[:, :3, :3]), E[:, :3, 3]], -1))
            J[:, :, 4 * j + c] = 0.5 * (xi[0] - xi[1])
    # reported = true exp(xi): flange error -E, moved to the camera frame
    return -adjoint_from_transform(invert_transform(T_fc)) @ J


def check_dh_error(value) -> tuple | None:
    """``None`` or a ``(6, 4)`` table of finite DH deviations (``world.arm_dh_error``) as
    nested tuples; sanity bound: lengths within 5 cm, angles within 0.1 rad."""
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"arm_dh_error must be 6 rows of 4 numbers {DH_COLUMNS}; received "
                        f"{value!r}") from None
    if arr.shape != (6, 4) or not np.isfinite(arr).all():
        raise ValueError(f"arm_dh_error must be 6 rows of 4 finite numbers {DH_COLUMNS}; "
                         f"received shape {arr.shape}")
    if np.abs(arr[:, 1:3]).max() > 0.05 or np.abs(arr[:, [0, 3]]).max() > 0.1:
        raise ValueError("arm_dh_error: deviations must stay within 0.05 m (d, a) and "
                         f"0.1 rad (theta, alpha); received max {np.abs(arr).max(axis=0)}")
    return tuple(tuple(float(v) for v in row) for row in arr)


def true_dh(dh_error) -> np.ndarray:
    """The true arm's DH table: :data:`UR5E_DH` plus ``dh_error`` (``None``: nominal)."""
    return UR5E_DH.copy() if dh_error is None else UR5E_DH + np.asarray(dh_error, float)


def draw_dh_error(cfg: KinematicErrorConfig, rng: np.random.Generator) -> np.ndarray:
    """``(6, 4)`` deviation of the true arm: ``N(0, sigma^2)`` per parameter and joint."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; received {type(rng).__name__}")
    return rng.standard_normal((UR5E_DH.shape[0], 4)) * cfg.sigmas[None, :]


def _quat_wxyz(R):
    from simcalib.geometry import quat_from_matrix, quat_wxyz_from_xyzw
    return [float(v) for v in quat_wxyz_from_xyzw(quat_from_matrix(R))]


def apply_dh_to_spec(spec, dh) -> None:
    """Place the links and flange site of a models/ur5e.xml ``MjSpec`` from the DH table
    ``dh`` (6, 4): link<i+1> at ``Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`` in link<i>,
    the flange site by row 6. (The geoms keep their nominal shapes: mm-level changes.)"""
    dh = _check_dh(dh)
    L = _link_transforms(np.zeros(6), dh)
    for i, name in enumerate(ARM_LINK_BODIES + (ARM_FLANGE_SITE,)):
        el = spec.site(name) if name == ARM_FLANGE_SITE else spec.body(name)
        if el is None:
            raise ValueError(f"the arm model has no {'site' if name == ARM_FLANGE_SITE else 'body'} "
                             f"{name!r}; a DH kinematic error needs models/ur5e.xml")
        el.pos = [float(v) for v in L[i, :3, 3]]
        el.quat = _quat_wxyz(L[i, :3, :3])


# -------------------------------------------------------------------------- encoders
def _motion_sign(q: np.ndarray) -> np.ndarray:
    """``(F, J)`` sign of each joint's latest motion (held while still; the first frames
    take the sign of the first motion; +1 for a joint that never moves)."""
    dq = np.diff(q, axis=0)
    s = np.sign(dq)
    s = np.concatenate([s[:1], s], axis=0)           # frame k: motion from k-1 to k
    F = s.shape[0]
    idx = np.where(s != 0, np.arange(F)[:, None], -1)
    idx = np.maximum.accumulate(idx, axis=0)          # latest frame with a non-zero sign
    first = np.argmax(s != 0, axis=0)                 # first non-zero (0 if none)
    idx = np.where(idx < 0, first[None, :], idx)
    out = np.take_along_axis(s, idx, axis=0)
    return np.where(out == 0, 1.0, out)


def encoder_readings(q_true, cfg: EncoderConfig, rng: np.random.Generator) -> np.ndarray:
    """``(F, J)`` encoder readings of the true joint angles ``q_true`` ``(F, J)`` (frames
    in time order) under ``cfg`` (module docstring), seeded by ``rng``."""
    q = np.asarray(q_true, dtype=np.float64)
    if q.ndim != 2:
        raise ValueError(f"q_true must be (frames, joints); received shape {q.shape}")
    out = q.copy()
    if cfg.backlash_rad > 0 and q.shape[0] > 1:
        out = out + 0.5 * cfg.backlash_rad * _motion_sign(q)
    if cfg.noise_rad > 0:
        out = out + rng.normal(0.0, cfg.noise_rad, q.shape)
    if cfg.counts_per_rev > 0:
        res = 2.0 * math.pi / cfg.counts_per_rev
        out = np.round(out / res) * res
    return out


def robot_report(world, cfg, fk_log=None) -> dict | None:
    """results.json ``robot``: the nominal DH table, the true arm's deviation, the error and
    encoder settings, and (with ``robot_fk``) its FK error against the truth per camera.
    ``None`` when the world has no built-in arm."""
    from simcalib.config.engine import to_dict
    w = world.config
    if w.platform != "arm" or w.arm_model != "builtin":
        return None
    err = np.zeros((6, 4)) if w.arm_dh_error is None else np.asarray(w.arm_dh_error)
    return {"dh_columns": list(DH_COLUMNS), "dh_nominal": UR5E_DH.tolist(),
            "dh_error": err.tolist(),
            "kinematic_error": to_dict(cfg.robot.kinematic_error),
            "encoder": to_dict(cfg.robot.encoder),
            "fk_error": fk_log}


#: Joint names of models/ur5e.xml in DH order (prefixed ``arm/`` in the scene).
ARM_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")


def arm_state(world) -> tuple[np.ndarray, np.ndarray]:
    """``(qpos addresses (6,), T_world_base (4, 4))`` of the world's arm."""
    import mujoco
    cfg = world.config
    if cfg.platform != "arm" or cfg.arm_model != "builtin":
        raise ValueError(f"source robot_fk needs world.platform='arm' with "
                         f"world.arm_model='builtin' (the UR5e DH model); received "
                         f"platform={cfg.platform!r}, arm_model={cfg.arm_model!r}")
    m = world.model
    adr = []
    for name in ARM_JOINTS:
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"arm/{name}")
        if jid < 0:
            raise ValueError(f"the arm model has no joint 'arm/{name}'")
        adr.append(int(m.jnt_qposadr[jid]))
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"arm/{ARM_BASE_BODY}")
    T = np.eye(4)
    T[:3, :3] = d.xmat[bid].reshape(3, 3)
    T[:3, 3] = d.xpos[bid]
    return np.array(adr), T
