"""The UR5e arm executing a joint path under joint control in MuJoCo physics.

``track_joint_path(model, qpos_targets, ...) -> ArmTrajectory``: the arm of
``models/ur5e.xml`` (or another 6-joint arm MJCF / ``MjSpec``) with its joint servos
(:mod:`simcalib.world.arm_servo`: torque-limited PD servos, optional gravity compensation)
tracks a reference ``q_ref``: the target path passed through a joint-speed limiter
(``max_velocity_rad_s``), updated at ``control_rate_hz`` (UR: 500 Hz). So the arm lags,
overshoots and settles as its gains and limits dictate; nothing is posed.

Capture modes: ``"continuous"`` captures at ``capture_rate_hz`` while the arm moves;
``"stop_and_go"`` stops the path at each capture instant, waits until the arm has settled
(|q - q_target| <= ``settle_tol_rad`` and |qd| <= ``settle_vel_tol_rad_s`` on every
joint, or ``settle_max_s``) and captures then. The quasi-static tracking error of a PD
servo is ``e ≈ tau_needed / kp`` (``tau_needed`` = inverse dynamics of the reference
without gravity when compensated); ``ArmTrajectory.stats["predicted_error_rad"]`` holds it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from simcalib.world.arm_servo import ArmGains, ArmLimits, build_controlled_arm
from simcalib.world.render_backend import import_mujoco as _mujoco

__all__ = ["ArmTrajectory", "CAPTURE_MODES", "demo_path", "track_joint_path"]

CAPTURE_MODES = ("continuous", "stop_and_go")


@dataclass(frozen=True)
class ArmTrajectory:
    """Physics result of :func:`track_joint_path`.

    Samples at ``sample_rate_hz``: ``time_s`` (N,) wall-clock of the robot; ``path_time_s``
    (N,) the path's own clock (stands still at stops); ``qpos`` / ``qvel`` (N, nj) measured;
    ``qpos_target`` (N, nj) the path at ``path_time_s``; ``qpos_ref`` (N, nj) the
    speed-limited reference the servos track; ``torque_nm`` (N, nj) actuator torques;
    ``tracking_error_rad`` (N, nj) = ``qpos_target - qpos``; ``T_world_flange`` (N, 4, 4)
    pose of the ``site`` (the rig mount).
    Captures (K of them): ``capture_time_s``, ``capture_path_time_s``, ``capture_qpos``
    (K, nj), ``capture_T_world_flange`` (K, 4, 4) actual; ``capture_T_world_flange_target``
    (K, 4, 4) where the path wanted it; ``capture_flange_speed_mps`` /
    ``capture_flange_rate_rad_s`` (K,) motion at the capture instant (blur);
    ``capture_settle_s`` (K,) time spent settling before the capture (stop_and_go) and
    ``capture_settled`` (K,) bool. ``stats``: summary (see module docstring);
    ``model``: the compiled model with the servos; ``joint_names``."""
    time_s: np.ndarray
    path_time_s: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    qpos_target: np.ndarray
    qpos_ref: np.ndarray
    torque_nm: np.ndarray
    tracking_error_rad: np.ndarray
    T_world_flange: np.ndarray
    capture_time_s: np.ndarray
    capture_path_time_s: np.ndarray
    capture_qpos: np.ndarray
    capture_T_world_flange: np.ndarray
    capture_T_world_flange_target: np.ndarray
    capture_flange_speed_mps: np.ndarray
    capture_flange_rate_rad_s: np.ndarray
    capture_settle_s: np.ndarray
    capture_settled: np.ndarray
    capture: str
    joint_names: tuple
    stats: dict
    timing_s: dict
    model: object = field(repr=False, default=None)


# ------------------------------------------------------------------------------ target
def _target_fn(qpos_targets, nj):
    """``(q(t) -> (nj,), qd(t) -> (nj,), t_end or None)``."""
    if callable(qpos_targets):
        def q(t):
            v = np.asarray(qpos_targets(float(t)), dtype=np.float64)
            if v.shape != (nj,):
                raise ValueError(f"qpos_targets(t) must return {nj} joint values; returned "
                                 f"shape {v.shape}")
            return v

        def qd(t, h=1e-4):
            return (q(t + h) - q(max(t - h, 0.0))) / (t + h - max(t - h, 0.0))
        return q, qd, None
    if isinstance(qpos_targets, (tuple, list)) and len(qpos_targets) == 2:
        t = np.asarray(qpos_targets[0], dtype=np.float64)
        Q = np.asarray(qpos_targets[1], dtype=np.float64)
        if t.ndim != 1 or Q.shape != (t.size, nj) or t.size < 2:
            raise ValueError(f"qpos_targets as (t, qpos) needs t (M,) and qpos (M, {nj}) with "
                             f"M >= 2; received shapes {t.shape} and {Q.shape}")
        if not (np.isfinite(t).all() and np.isfinite(Q).all()):
            raise ValueError("qpos_targets contains non-finite values")
        if np.any(np.diff(t) <= 0):
            raise ValueError("qpos_targets times must be strictly increasing")
        dQ = np.gradient(Q, t, axis=0)

        def q(tt):
            return np.array([np.interp(tt, t, Q[:, j]) for j in range(nj)])

        def qd(tt):
            if tt <= t[0] or tt >= t[-1]:
                return np.zeros(nj)
            return np.array([np.interp(tt, t, dQ[:, j]) for j in range(nj)])
        return q, qd, float(t[-1] - t[0]) if t[0] == 0.0 else None
    raise TypeError("qpos_targets must be a callable t -> (nj,) joint positions or a tuple "
                    f"(t (M,), qpos (M, nj)); received {type(qpos_targets).__name__}")


# ------------------------------------------------------------------------------- track
def track_joint_path(model, qpos_targets, *, duration_s: float | None = None,
                     gains: ArmGains = ArmGains(), limits: ArmLimits = ArmLimits(),
                     capture: str = "continuous", capture_rate_hz: float = 10.0,
                     site: str = "rig_mount", gravity_compensation: bool = True,
                     timestep_s: float = 0.001, control_rate_hz: float = 500.0,
                     sample_rate_hz: float = 100.0, settle_tol_rad: float = 1e-4,
                     settle_vel_tol_rad_s: float = 1e-3,
                     settle_max_s: float = 3.0) -> ArmTrajectory:
    """Execute ``qpos_targets`` (callable ``q(t)`` or ``(t, qpos)`` arrays; times from 0)
    on the arm ``model`` (see :func:`build_controlled_arm`) for ``duration_s`` of path time
    (default: the arrays' span) and return the :class:`ArmTrajectory`. The arm starts at
    rest at ``q(0)``. Deterministic (no randomness)."""
    _mujoco()                       # decide the GL backend and import mujoco first
    _check_track_options(capture, gains, limits, capture_rate_hz, control_rate_hz,
                         sample_rate_hz, settle_tol_rad, settle_vel_tol_rad_s, settle_max_s)
    t0 = time.perf_counter()
    m, jnames = build_controlled_arm(model, gains, limits,
                                     gravity_compensation=gravity_compensation,
                                     timestep_s=timestep_s)
    nj = len(jnames)
    kp, kd = gains.resolved(nj)
    tmax, vmax = limits.resolved(nj)
    n_ctrl, n_samp = _steps_per_tick(control_rate_hz, sample_rate_hz, timestep_s)
    q_fn, qd_fn, span = _target_fn(qpos_targets, nj)
    duration_s = _path_duration(duration_s, span)
    sid, qadr, vadr, lo, hi = _site_and_joint_indices(m, jnames, site)
    _check_target_in_joint_ranges(q_fn, duration_s, lo, hi, jnames)

    arm = _ServoArm(m=m, data=_arm_at_rest(m, qadr, q_fn(0.0)), sid=sid, qadr=qadr,
                    vadr=vadr, kp=kp, kd=kd, tmax=tmax, vmax=vmax, q_fn=q_fn, qd_fn=qd_fn,
                    timestep_s=timestep_s, n_ctrl=n_ctrl, n_samp=n_samp,
                    dt_c=n_ctrl * timestep_s)
    plan = _capture_plan(capture, capture_rate_hz, duration_s, settle_tol_rad,
                         settle_vel_tol_rad_s, settle_max_s)
    st = _LoopState(q_ref=q_fn(0.0).copy(), holding=plan.stop_mode)
    _run_control_loop(arm, plan, st)
    t_sim = time.perf_counter() - t0
    return _trajectory_from_run(arm, plan, st, capture, jnames, t0, t_sim)


def _check_track_options(capture, gains, limits, capture_rate_hz, control_rate_hz,
                         sample_rate_hz, settle_tol_rad, settle_vel_tol_rad_s, settle_max_s):
    """Raise on a bad capture mode, gains/limits type or out-of-range rate or tolerance."""
    if not isinstance(capture, str) or capture not in CAPTURE_MODES:
        raise ValueError(f"capture must be one of {list(CAPTURE_MODES)}; received {capture!r}")
    if not isinstance(gains, ArmGains):
        raise TypeError(f"gains must be an ArmGains; received {type(gains).__name__}")
    if not isinstance(limits, ArmLimits):
        raise TypeError(f"limits must be an ArmLimits; received {type(limits).__name__}")
    for name, v, lo, hi in (("capture_rate_hz", capture_rate_hz, 1e-3, 1000.0),
                            ("control_rate_hz", control_rate_hz, 1.0, 10000.0),
                            ("sample_rate_hz", sample_rate_hz, 1.0, 10000.0),
                            ("settle_tol_rad", settle_tol_rad, 1e-9, 1.0),
                            ("settle_vel_tol_rad_s", settle_vel_tol_rad_s, 1e-9, 10.0),
                            ("settle_max_s", settle_max_s, 0.0, 60.0)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (
                math.isfinite(v) and lo <= v <= hi):
            raise ValueError(f"{name} must be a number in [{lo}, {hi}]; received {v!r}")


def _steps_per_tick(control_rate_hz, sample_rate_hz, timestep_s):
    """Physics steps per control tick and per sample (whole numbers, samples on ticks)."""
    n_ctrl = 1.0 / (control_rate_hz * timestep_s)
    n_samp = 1.0 / (sample_rate_hz * timestep_s)
    for name, nn in (("control_rate_hz", n_ctrl), ("sample_rate_hz", n_samp)):
        if abs(nn - round(nn)) > 1e-6 or round(nn) < 1:
            raise ValueError(f"{name} must divide the physics rate 1/timestep_s = "
                             f"{1.0 / timestep_s:g} Hz into whole steps")
    n_ctrl, n_samp = int(round(n_ctrl)), int(round(n_samp))
    if n_samp % n_ctrl:
        raise ValueError(f"sample_rate_hz={sample_rate_hz} must divide control_rate_hz="
                         f"{control_rate_hz}")
    return n_ctrl, n_samp


def _path_duration(duration_s, span):
    """Path time to execute: ``duration_s``, else the target arrays' span (positive)."""
    if duration_s is None:
        if span is None:
            raise ValueError("duration_s is required for a callable qpos_targets (or arrays "
                             "whose times do not start at 0)")
        duration_s = span
    if not (isinstance(duration_s, (int, float)) and math.isfinite(duration_s)
            and duration_s > 0):
        raise ValueError(f"duration_s must be a positive number; received {duration_s!r}")
    return duration_s


def _site_and_joint_indices(m, jnames, site):
    """``(site id, qpos addresses, dof addresses, lower limits, upper limits)`` of the arm."""
    mujoco = _mujoco()
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
    if sid < 0:
        raise ValueError(f"site {site!r} not found in the arm model; sites: "
                         f"{[m.site(i).name for i in range(m.nsite)]}")
    jids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in jnames]
    qadr = np.array([m.jnt_qposadr[j] for j in jids])
    vadr = np.array([m.jnt_dofadr[j] for j in jids])
    lo = np.where(m.jnt_limited[jids].astype(bool), m.jnt_range[jids, 0], -np.inf)
    hi = np.where(m.jnt_limited[jids].astype(bool), m.jnt_range[jids, 1], np.inf)
    return sid, qadr, vadr, lo, hi


def _check_target_in_joint_ranges(q_fn, duration_s, lo, hi, jnames):
    """Raise if the target path leaves a joint's range (dense sampling)."""
    tt = np.linspace(0.0, duration_s, max(50, int(duration_s * 100)))
    Qs = np.array([q_fn(v) for v in tt])
    bad = (Qs < lo) | (Qs > hi)
    if bad.any():
        k, j = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(f"qpos_targets leaves joint {jnames[j]!r}'s range "
                         f"[{lo[j]:.4g}, {hi[j]:.4g}] rad at t = {tt[k]:.3f} s "
                         f"(value {Qs[k, j]:.4g} rad)")


def _arm_at_rest(m, qadr, q0):
    """New ``MjData`` with the arm at rest at joint angles ``q0`` (forward computed)."""
    mujoco = _mujoco()
    data = mujoco.MjData(m)
    data.qpos[qadr] = q0
    data.qvel[:] = 0.0
    mujoco.mj_forward(m, data)
    return data


@dataclass
class _ServoArm:
    """The servo-controlled arm of one run: model, data, addresses, gains, limits, path."""
    m: object
    data: object
    sid: int
    qadr: np.ndarray
    vadr: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    tmax: np.ndarray
    vmax: np.ndarray
    q_fn: object
    qd_fn: object
    timestep_s: float
    n_ctrl: int
    n_samp: int
    dt_c: float
    jacp: np.ndarray = field(init=False)
    jacr: np.ndarray = field(init=False)

    def __post_init__(self):
        """Site Jacobian buffers for :func:`_flange_motion`."""
        self.jacp = np.zeros((3, self.m.nv))
        self.jacr = np.zeros((3, self.m.nv))


@dataclass(frozen=True)
class _CapturePlan:
    """When to capture: mode, the K capture path times and the settling criteria."""
    stop_mode: bool
    n_cap: int
    cap_tau: np.ndarray
    duration_s: float
    settle_tol_rad: float
    settle_vel_tol_rad_s: float
    settle_max_s: float


def _capture_plan(capture, capture_rate_hz, duration_s, settle_tol_rad, settle_vel_tol_rad_s,
                  settle_max_s):
    """The :class:`_CapturePlan`: one capture every ``1 / capture_rate_hz`` of path time."""
    n_cap = int(math.floor(duration_s * capture_rate_hz + 1e-9)) + 1
    if capture == "stop_and_go" and n_cap < 2:
        raise ValueError(f"capture='stop_and_go' needs at least two stops (duration_s * "
                         f"capture_rate_hz >= 1); received duration_s={duration_s!r}, "
                         f"capture_rate_hz={capture_rate_hz!r}: one stop has no motion")
    return _CapturePlan(stop_mode=capture == "stop_and_go", n_cap=n_cap,
                        cap_tau=np.arange(n_cap) / capture_rate_hz, duration_s=duration_s,
                        settle_tol_rad=settle_tol_rad,
                        settle_vel_tol_rad_s=settle_vel_tol_rad_s, settle_max_s=settle_max_s)


@dataclass
class _LoopState:
    """Mutable state of the control loop: clocks, reference, captures taken, records."""
    q_ref: np.ndarray
    holding: bool                   # stop_and_go starts with the first capture at tau = 0
    tau: float = 0.0
    step: int = 0
    k_cap: int = 0
    hold_start: float = 0.0
    seg_start: float = 0.0
    sat_count: int = 0
    ctrl_count: int = 0
    rec: dict = field(default_factory=lambda: {
        k: [] for k in ("t", "tau", "q", "qd", "qt", "qr", "tq", "pos", "mat")})
    caps: dict = field(default_factory=lambda: {
        k: [] for k in ("t", "tau", "q", "pos", "mat", "v", "w", "settle", "ok")})


def _run_control_loop(arm, plan, st):
    """Step the physics under servo control until the last capture (updates ``st``)."""
    mujoco = _mujoco()
    # stop_and_go: between stops the path clock follows a smoothstep (zero speed at both
    # stops, peak speed = the path's own), so each move takes 1.5x its path time
    max_steps = int(round((1.5 * plan.duration_s + plan.n_cap * (plan.settle_max_s + arm.dt_c)
                           + 1.0) / arm.timestep_s))
    while True:
        t_now = st.step * arm.timestep_s
        if st.step % arm.n_ctrl == 0:
            tau_rate = _advance_path_clock(plan, st, t_now)
            if _take_due_capture(arm, plan, st, t_now):
                break
            _command_servos(arm, st, tau_rate)
        if st.step % arm.n_samp == 0:
            _record_sample(arm, st, t_now)
        if st.step >= max_steps:
            raise ValueError(f"the arm did not finish the path within "
                             f"{max_steps * arm.timestep_s:.1f} s of simulated time")
        mujoco.mj_step(arm.m, arm.data, nstep=arm.n_ctrl)
        st.sat_count += int(np.any(np.abs(arm.data.actuator_force) >= arm.tmax - 1e-9))
        st.step += arm.n_ctrl


def _advance_path_clock(plan, st, t_now):
    """Set the path time ``st.tau`` at ``t_now``; return its rate d(tau)/dt."""
    tau_rate = 1.0
    if plan.stop_mode and not st.holding:
        ta, tb = plan.cap_tau[st.k_cap - 1], plan.cap_tau[st.k_cap]
        T_seg = 1.5 * (tb - ta)
        u = min(1.0, (t_now - st.seg_start) / T_seg)
        st.tau = ta + (tb - ta) * (3.0 * u * u - 2.0 * u ** 3)
        tau_rate = (tb - ta) * 6.0 * u * (1.0 - u) / T_seg
        if u >= 1.0:
            st.tau, st.holding, st.hold_start = tb, True, t_now
    elif not plan.stop_mode:
        st.tau = min(t_now, plan.duration_s)
    return tau_rate


def _take_due_capture(arm, plan, st, t_now):
    """Capture if one is due at ``t_now``; return True when the run is complete."""
    if plan.stop_mode and st.holding:
        err = np.abs(arm.q_fn(st.tau) - arm.data.qpos[arm.qadr])
        settled = bool(err.max() <= plan.settle_tol_rad
                       and np.abs(arm.data.qvel[arm.vadr]).max() <= plan.settle_vel_tol_rad_s)
        if settled or t_now - st.hold_start >= plan.settle_max_s - 1e-12:
            _record_capture(arm, st, t_now - st.hold_start, settled)
            st.k_cap += 1
            if st.k_cap >= plan.n_cap:
                return True
            st.holding, st.seg_start = False, t_now
    elif not plan.stop_mode and st.k_cap < plan.n_cap and st.tau >= plan.cap_tau[st.k_cap] - 1e-9:
        _record_capture(arm, st, 0.0, True)
        st.k_cap += 1
    return not plan.stop_mode and t_now >= plan.duration_s - 1e-9 and st.k_cap >= plan.n_cap


def _flange_motion(arm):
    """``(linear m/s, angular rad/s)`` speed of the site, from its Jacobian and ``qvel``."""
    _mujoco().mj_jacSite(arm.m, arm.data, arm.jacp, arm.jacr, arm.sid)
    return (float(np.linalg.norm(arm.jacp @ arm.data.qvel)),
            float(np.linalg.norm(arm.jacr @ arm.data.qvel)))


def _record_capture(arm, st, settle_s, ok):
    """Append a capture of the arm's current state to ``st.caps``."""
    v, w = _flange_motion(arm)
    caps = st.caps
    caps["t"].append(st.step * arm.timestep_s)
    caps["tau"].append(st.tau)
    caps["q"].append(arm.data.qpos[arm.qadr].copy())
    caps["pos"].append(arm.data.site_xpos[arm.sid].copy())
    caps["mat"].append(arm.data.site_xmat[arm.sid].copy())
    caps["v"].append(v)
    caps["w"].append(w)
    caps["settle"].append(settle_s)
    caps["ok"].append(ok)


def _command_servos(arm, st, tau_rate):
    """Advance the speed-limited reference ``st.q_ref`` and write the servos' ``ctrl``."""
    q_tgt = arm.q_fn(st.tau)
    qd_tgt = np.zeros(len(arm.qadr)) if st.holding else arm.qd_fn(st.tau) * tau_rate
    step_lim = arm.vmax * arm.dt_c
    q_new = st.q_ref + np.clip(q_tgt - st.q_ref, -step_lim, step_lim)
    limited = np.abs(q_tgt - st.q_ref) > step_lim
    qd_ref = np.where(limited, (q_new - st.q_ref) / arm.dt_c,
                      np.clip(qd_tgt, -arm.vmax, arm.vmax))
    st.q_ref = q_new
    arm.data.ctrl[:] = arm.kp * st.q_ref + arm.kd * qd_ref
    st.ctrl_count += 1


def _record_sample(arm, st, t_now):
    """Append a sample (clocks, measured state, target, reference, torques, site pose)."""
    rec = st.rec
    rec["t"].append(t_now)
    rec["tau"].append(st.tau)
    rec["q"].append(arm.data.qpos[arm.qadr].copy())
    rec["qd"].append(arm.data.qvel[arm.vadr].copy())
    rec["qt"].append(arm.q_fn(st.tau))
    rec["qr"].append(st.q_ref.copy())
    rec["tq"].append(arm.data.actuator_force.copy())
    rec["pos"].append(arm.data.site_xpos[arm.sid].copy())
    rec["mat"].append(arm.data.site_xmat[arm.sid].copy())


def _target_flange_poses(arm, cap_taus, like):
    """Site poses of the target joint angles at the capture path times (kinematics)."""
    mujoco = _mujoco()
    dk = mujoco.MjData(arm.m)
    T_tgt = np.zeros_like(like)
    for i, tau_i in enumerate(cap_taus):
        dk.qpos[arm.qadr] = arm.q_fn(tau_i)
        mujoco.mj_kinematics(arm.m, dk)
        T_tgt[i] = np.eye(4)
        T_tgt[i, :3, :3] = dk.site_xmat[arm.sid].reshape(3, 3)
        T_tgt[i, :3, 3] = dk.site_xpos[arm.sid]
    return T_tgt


def _trajectory_from_run(arm, plan, st, capture, jnames, t0, t_sim):
    """The :class:`ArmTrajectory` of a finished run, with its ``stats``."""
    from simcalib.geometry import transforms_from_flat
    rec, caps = st.rec, st.caps
    T_fl = transforms_from_flat(rec["mat"], rec["pos"])
    T_cap = transforms_from_flat(caps["mat"], caps["pos"])
    # target flange poses at the capture path times (forward kinematics of the target)
    T_tgt = _target_flange_poses(arm, caps["tau"], T_cap)
    qpos = np.array(rec["q"])
    qt = np.array(rec["qt"])
    err = qt - qpos
    cap_pos_err = np.linalg.norm(T_cap[:, :3, 3] - T_tgt[:, :3, 3], axis=1)
    pred = _predicted_error(arm.m, arm.q_fn, arm.qd_fn, plan.duration_s, arm.qadr, arm.vadr,
                            arm.kp)
    stats = _run_stats(err, pred, cap_pos_err, caps, st, arm.timestep_s, t_sim)
    return ArmTrajectory(
        time_s=np.array(rec["t"]), path_time_s=np.array(rec["tau"]), qpos=qpos,
        qvel=np.array(rec["qd"]), qpos_target=qt, qpos_ref=np.array(rec["qr"]),
        torque_nm=np.array(rec["tq"]), tracking_error_rad=err, T_world_flange=T_fl,
        capture_time_s=np.array(caps["t"]), capture_path_time_s=np.array(caps["tau"]),
        capture_qpos=np.array(caps["q"]), capture_T_world_flange=T_cap,
        capture_T_world_flange_target=T_tgt,
        capture_flange_speed_mps=np.array(caps["v"]),
        capture_flange_rate_rad_s=np.array(caps["w"]),
        capture_settle_s=np.array(caps["settle"]), capture_settled=np.array(caps["ok"]),
        capture=capture, joint_names=jnames, stats=stats,
        timing_s={"total": time.perf_counter() - t0}, model=arm.m)


def _run_stats(err, pred, cap_pos_err, caps, st, timestep_s, t_sim):
    """``ArmTrajectory.stats``: tracking, capture, settling, saturation and timing summary."""
    return {
        "max_tracking_error_rad": np.abs(err).max(axis=0).tolist(),
        "rms_tracking_error_rad": np.sqrt((err ** 2).mean(axis=0)).tolist(),
        "predicted_error_rad": pred.tolist(),
        "capture_position_error_max_m": float(cap_pos_err.max()),
        "capture_position_error_mean_m": float(cap_pos_err.mean()),
        "capture_flange_speed_max_mps": float(np.max(caps["v"])),
        "settle_mean_s": float(np.mean(caps["settle"])),
        "settle_max_s": float(np.max(caps["settle"])),
        "settled_fraction": float(np.mean(caps["ok"])),
        "torque_saturated_fraction": st.sat_count / max(st.ctrl_count, 1),
        "duration_s": float(st.step * timestep_s),
        "physics_ms_per_sim_s": 1e3 * t_sim / max(st.step * timestep_s, 1e-9),
    }


def _predicted_error(m, q_fn, qd_fn, duration_s, qadr, vadr, kp, n=400):
    """Quasi-static PD tracking error ``max_t |tau_needed(t)| / kp`` per joint, with
    ``tau_needed`` from MuJoCo's inverse dynamics of the target (passive forces, i.e.
    joint damping and gravity compensation, included)."""
    mujoco = _mujoco()
    d = mujoco.MjData(m)
    t = np.linspace(0.0, duration_s, n)
    h = t[1] - t[0]
    out = np.zeros(len(qadr))
    for tt in t:
        d.qpos[qadr] = q_fn(tt)
        d.qvel[vadr] = qd_fn(tt)
        ta, tb = max(tt - 0.5 * h, 0.0), min(tt + 0.5 * h, duration_s)
        d.qacc[vadr] = (qd_fn(tb) - qd_fn(ta)) / (tb - ta)
        mujoco.mj_inverse(m, d)
        out = np.maximum(out, np.abs(d.qfrc_inverse[vadr]) / kp)
    return out


# ----------------------------------------------------------------------------- CLI
#: The UR5e home joint angles of the scene builder (see simcalib.world.scene).
DEMO_Q_HOME = np.array([0.3005, -1.8099, -1.9046, 0.5729, 1.2703, 0.0])
DEMO_AMP_RAD = np.array([0.3, 0.2, 0.25, 0.4, 0.4, 0.5])


def demo_path(t: float, freq_hz: float = 0.25) -> np.ndarray:
    """The docs' joint path: from rest at the home pose, a ``freq_hz`` swing of
    ``DEMO_AMP_RAD`` on every joint (``q = q_home + A (1 - cos 2π f t)``)."""
    return DEMO_Q_HOME + DEMO_AMP_RAD * (1.0 - np.cos(2.0 * np.pi * freq_hz * t))


def report_rows(duration_s: float = 4.0) -> list[dict]:
    rows = []
    for capture in CAPTURE_MODES:
        for f in (0.25, 0.5):
            tr = track_joint_path(None, lambda t, f=f: demo_path(t, f), duration_s=duration_s,
                                  capture=capture, capture_rate_hz=2.0)
            d = np.linalg.norm(tr.capture_T_world_flange[:, :3, 3]
                               - tr.capture_T_world_flange_target[:, :3, 3], axis=1)
            rows.append({"capture": capture, "freq_hz": f,
                         "max_err_mrad": 1e3 * np.abs(tr.tracking_error_rad).max(axis=0),
                         "pred_mrad": 1e3 * np.array(tr.stats["predicted_error_rad"]),
                         "capture_pos_err_max_mm": 1e3 * float(d.max()),
                         "capture_speed_max_mps": tr.stats["capture_flange_speed_max_mps"],
                         "settle_max_s": tr.stats["settle_max_s"],
                         "duration_s": tr.stats["duration_s"],
                         "ms_per_sim_s": tr.stats["physics_ms_per_sim_s"]})
    return rows


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="python -m simcalib.world.arm_control",
                                 description="UR5e under joint control: regenerate the "
                                             "docs/physics.md arm table.")
    ap.add_argument("--table", action="store_true", help="print the docs table")
    args = ap.parse_args(argv)
    if not args.table:
        ap.print_help()
        return 0
    print("| capture | swing Hz | max error / predicted τ/kp (mrad), joints 1-6 "
          "| flange error at captures max mm | flange speed at captures max m/s "
          "| settle max s | run s | physics ms per sim s |")
    print("|" + "---|" * 8)
    for r in report_rows():
        pairs = " ".join(f"{e:.2f}/{p:.2f}" for e, p in zip(r["max_err_mrad"], r["pred_mrad"]))
        print(f"| {r['capture']} | {r['freq_hz']:g} | {pairs} | {r['capture_pos_err_max_mm']:.3f} "
              f"| {r['capture_speed_max_mps']:.3f} | {r['settle_max_s']:.3f} "
              f"| {r['duration_s']:.2f} | {r['ms_per_sim_s']:.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
