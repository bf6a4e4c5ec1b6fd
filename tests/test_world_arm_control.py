"""UR5e under joint control (simcalib.world.arm_control, its servos simcalib.world.arm_servo):
tracking error vs gains, settling, capture modes, limits, errors."""

import math

import numpy as np
import pytest

from simcalib.world.arm_control import track_joint_path
from simcalib.world.arm_servo import ArmGains, ArmLimits, build_controlled_arm

Q_HOME = np.array([0.3005, -1.8099, -1.9046, 0.5729, 1.2703, 0.0])
AMP = np.array([0.3, 0.2, 0.25, 0.4, 0.4, 0.5])


def smooth_path(t):
    """Starts at rest at Q_HOME; 0.25 Hz joint-space swing."""
    return Q_HOME + AMP * (1.0 - np.cos(2.0 * np.pi * 0.25 * t))


@pytest.fixture(scope="module")
def continuous():
    return track_joint_path(None, smooth_path, duration_s=4.0, capture="continuous",
                            capture_rate_hz=4.0)


@pytest.fixture(scope="module")
def stop_and_go():
    return track_joint_path(None, smooth_path, duration_s=4.0, capture="stop_and_go",
                            capture_rate_hz=2.0)


def test_tracking_error_matches_what_the_gains_imply(continuous):
    err = np.abs(continuous.tracking_error_rad).max(axis=0)
    pred = np.array(continuous.stats["predicted_error_rad"])    # max |tau_needed| / kp
    assert np.all(pred > 1e-4)
    # the quasi-static PD error: same order as tau / kp (lags, coupling: up to ~2x)
    assert np.all(err <= 2.5 * pred + 1e-4), (err, pred)
    assert np.all(err >= 0.5 * pred), (err, pred)
    assert continuous.stats["torque_saturated_fraction"] == 0.0


def test_doubling_the_stiffness_about_halves_the_error(continuous):
    """e ≈ tau / kp (plus a smaller kd-dependent lag): twice kp, ~half the error."""
    g = ArmGains()
    stiff = ArmGains(kp_nm_per_rad=tuple(2.0 * np.array(g.kp_nm_per_rad)),
                     kd_nm_s_per_rad=tuple(math.sqrt(2.0) * np.array(g.kd_nm_s_per_rad)))
    tr = track_joint_path(None, smooth_path, duration_s=4.0, gains=stiff)
    ratio = (np.abs(tr.tracking_error_rad).max(axis=0)
             / np.abs(continuous.tracking_error_rad).max(axis=0))
    assert np.all((ratio > 0.35) & (ratio < 0.8)), ratio


def test_continuous_capture_is_taken_while_moving(continuous):
    assert continuous.capture == "continuous"
    assert np.allclose(continuous.capture_time_s, np.arange(17) * 0.25)
    assert continuous.capture_flange_speed_mps.max() > 0.1
    # the actual flange lags the commanded one by up to a few mm
    d = np.linalg.norm(continuous.capture_T_world_flange[:, :3, 3]
                       - continuous.capture_T_world_flange_target[:, :3, 3], axis=1)
    assert 1e-4 < d.max() < 5e-3
    assert continuous.T_world_flange.shape == (continuous.time_s.size, 4, 4)


def test_stop_and_go_captures_after_settling(stop_and_go):
    tr = stop_and_go
    assert tr.capture == "stop_and_go"
    assert np.allclose(tr.capture_path_time_s, np.arange(9) * 0.5)
    assert tr.capture_settled.all()
    assert tr.capture_flange_speed_mps.max() < 2e-3
    d = np.linalg.norm(tr.capture_T_world_flange[:, :3, 3]
                       - tr.capture_T_world_flange_target[:, :3, 3], axis=1)
    assert d.max() < 3e-4
    # settling takes real time (5-10 Hz servos): tens of ms, well under a second
    assert 0.01 < tr.stats["settle_max_s"] < 0.5
    assert tr.capture_time_s[-1] > 4.0                # the stops add time
    assert np.all(np.diff(tr.capture_time_s) > 0)


def test_without_gravity_compensation_the_arm_sags_by_gravity_over_kp():
    import mujoco
    m, _ = build_controlled_arm(None)
    d = mujoco.MjData(m)
    d.qpos[:] = Q_HOME
    mujoco.mj_forward(m, d)
    m0, _ = build_controlled_arm(None, gravity_compensation=False)
    d0 = mujoco.MjData(m0)
    d0.qpos[:] = Q_HOME
    mujoco.mj_forward(m0, d0)
    gravity = d0.qfrc_bias.copy()                          # at rest: gravity only
    kp = np.array(ArmGains().kp_nm_per_rad)
    tr = track_joint_path(None, lambda t: Q_HOME, duration_s=2.0, capture="continuous",
                          capture_rate_hz=1.0, gravity_compensation=False)
    sag = -tr.tracking_error_rad[-1]                       # q - q_target at the end
    big = np.abs(gravity / kp) > 1e-4
    assert big.sum() >= 2
    assert np.allclose(sag[big], -gravity[big] / kp[big], rtol=0.1)
    comp = track_joint_path(None, lambda t: Q_HOME, duration_s=2.0)
    assert np.abs(comp.tracking_error_rad[-1]).max() < 1e-6


def test_speed_and_torque_limits_bind():
    fast = lambda t: Q_HOME + np.array([1.5, 0, 0, 0, 0, 0]) * np.sin(2 * np.pi * 1.0 * t)
    tr = track_joint_path(None, fast, duration_s=1.0,
                          limits=ArmLimits(max_velocity_rad_s=2.0))
    v_ref = np.abs(np.diff(tr.qpos_ref[:, 0]) / np.diff(tr.time_s))
    assert v_ref.max() <= 2.0 + 1e-9
    assert np.abs(tr.tracking_error_rad[:, 0]).max() > 0.2          # cannot keep up
    weak = track_joint_path(None, fast, duration_s=1.0,
                            limits=ArmLimits(max_torque_nm=(5.0, 150, 150, 28, 28, 28)))
    assert weak.stats["torque_saturated_fraction"] > 0.1
    assert np.abs(weak.torque_nm[:, 0]).max() <= 5.0 + 1e-9


def test_array_targets_and_determinism():
    t = np.linspace(0.0, 2.0, 201)
    Q = np.array([smooth_path(v) for v in t])
    a = track_joint_path(None, (t, Q))
    b = track_joint_path(None, (t, Q))
    assert a.stats["duration_s"] == pytest.approx(2.0)
    assert np.array_equal(a.qpos, b.qpos)
    assert np.array_equal(a.T_world_flange, b.T_world_flange)


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(ValueError, match=r"capture must be one of \['continuous', "
                                         r"'stop_and_go'\]"):
        track_joint_path(None, smooth_path, duration_s=1.0, capture="burst")
    with pytest.raises(ValueError, match="duration_s is required"):
        track_joint_path(None, smooth_path)
    with pytest.raises(ValueError, match=r"leaves joint 'elbow''s range"):
        track_joint_path(None, lambda t: Q_HOME + [0, 0, 5.5, 0, 0, 0], duration_s=1.0)
    with pytest.raises(ValueError, match="must be a number or 6 numbers"):
        track_joint_path(None, smooth_path, duration_s=1.0,
                         gains=ArmGains(kp_nm_per_rad=(1.0, 2.0)))
    with pytest.raises(ValueError, match="must be finite and in"):
        track_joint_path(None, smooth_path, duration_s=1.0,
                         limits=ArmLimits(max_torque_nm=-1.0))
    with pytest.raises(TypeError, match="pass its MjSpec"):
        import mujoco
        track_joint_path(mujoco.MjModel.from_xml_string("<mujoco/>"), smooth_path,
                         duration_s=1.0)
    with pytest.raises(ValueError, match="return 6 joint values"):
        track_joint_path(None, lambda t: np.zeros(3), duration_s=1.0)
    with pytest.raises(ValueError, match=r"timestep_s must be in \[1e-05, 0.002\]"):
        track_joint_path(None, smooth_path, duration_s=1.0, timestep_s=0.01)
    with pytest.raises(ValueError, match="site 'flange' not found"):
        track_joint_path(None, smooth_path, duration_s=1.0, site="flange")
    with pytest.raises(ValueError, match=r"'stop_and_go' needs at least two stops .*"
                                         r"received duration_s=2.0, capture_rate_hz=0.1"):
        track_joint_path(None, smooth_path, duration_s=2.0, capture="stop_and_go",
                         capture_rate_hz=0.1)
