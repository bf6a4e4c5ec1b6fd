"""Physics car (simcalib.world.vehicle, its model and path following): suspension roll, slip,
ground, determinism, errors."""

import numpy as np
import pytest

from simcalib.geometry import invert_transform
from simcalib.world.vehicle import simulate_vehicle
from simcalib.world.vehicle_config import VehicleConfig
from simcalib.world.vehicle_path import PlanarPath, as_planar_path, figure_eight_path

# a compact figure-eight (40 m x 16 m, tightest radius ~6 m): ~110 m, ~25 s simulated
PATH = figure_eight_path(length_m=40.0, width_m=16.0, n=3000)


def _straight(length_m=40.0, n=400):
    x = np.linspace(0.0, length_m, n)
    return PlanarPath(np.linspace(0.0, 1.0, n), x, np.zeros(n), np.zeros(n))


@pytest.fixture(scope="module")
def sprung():
    return simulate_vehicle(VehicleConfig(speed_mps=5.0), PATH, np.random.default_rng(1))


@pytest.fixture(scope="module")
def rigid():
    return simulate_vehicle(VehicleConfig(speed_mps=5.0, sprung=False), PATH,
                            np.random.default_rng(1))


@pytest.mark.slow
def test_figure_eight_rolls_the_sprung_car_and_not_the_rigid_one(sprung, rigid):
    assert sprung.stats["roll_peak_deg"] >= 0.5
    assert sprung.stats["pitch_peak_deg"] >= 0.1          # launch and braking
    assert rigid.stats["roll_peak_deg"] <= 0.05
    assert rigid.stats["pitch_peak_deg"] <= 0.05
    # the roll follows the turns: its sign flips between the two lobes
    assert np.degrees(sprung.roll_rad).max() > 0.4 and np.degrees(sprung.roll_rad).min() < -0.4


@pytest.mark.slow
def test_roll_matches_lateral_acceleration(sprung):
    """Quasi-static roll ≈ gradient × lateral acceleration (one sign, ~0.2-0.8 °/(m/s²))."""
    yaw_rate = np.gradient(sprung.yaw_rad, sprung.time_s)
    a_lat = sprung.speed_mps * yaw_rate
    m = np.abs(a_lat) > 1.0
    grad = np.degrees(sprung.roll_rad[m]) / a_lat[m]
    assert np.median(grad) * np.sign(np.median(grad)) > 0.15
    assert np.mean(np.sign(grad) == np.sign(np.median(grad))) > 0.9


@pytest.mark.slow
def test_wheel_slip_and_tracking_bounded(sprung, rigid):
    for tr in (sprung, rigid):
        assert tr.wheels == ("fl", "fr", "rl", "rr")
        assert tr.stats["slip_ratio_peak"] < 0.1
        assert tr.stats["slip_angle_peak_deg"] < 3.0
        assert tr.stats["cross_track_max_m"] < 0.5
        assert 4.5 < tr.stats["speed_max_mps"] < 5.5
        assert abs(tr.speed_mps[-1]) < 0.1                  # stopped at the end
        end = tr.T_world_base[-1, :2, 3]
        assert np.hypot(*(end - [PATH.x[-1], PATH.y[-1]])) < 3.0


def test_trajectory_frames(sprung):
    n = sprung.time_s.size
    assert sprung.T_world_base.shape == sprung.T_world_rig_mount.shape == (n, 4, 4)
    assert np.allclose(np.diff(sprung.time_s), 1.0 / sprung.config.sample_rate_hz)
    R = sprung.T_world_base[:, :3, :3]
    assert np.allclose(R @ R.transpose(0, 2, 1), np.eye(3), atol=1e-9)
    # the roof site is rigid on the chassis at mount_pos_m with the rig axes
    T_base_mount = invert_transform(sprung.T_world_base) @ sprung.T_world_rig_mount
    assert np.allclose(T_base_mount, T_base_mount[0], atol=1e-9)
    assert np.allclose(T_base_mount[0, :3, 3], sprung.config.mount_pos_m, atol=1e-9)
    assert np.allclose(T_base_mount[0, :3, 2], [1, 0, 0], atol=1e-9)   # rig z = forward
    assert np.allclose(T_base_mount[0, :3, 1], [0, 0, -1], atol=1e-9)  # rig y = down


@pytest.mark.slow
def test_uneven_ground_pitches_and_lifts_the_car():
    flat = simulate_vehicle(VehicleConfig(speed_mps=4.0), _straight(), np.random.default_rng(2))
    rough = simulate_vehicle(VehicleConfig(speed_mps=4.0, ground="uneven",
                                           bump_amplitude_m=0.04, bump_wavelength_m=3.0),
                             _straight(), np.random.default_rng(2))
    def cruise_pitch_std_deg(tr):       # at constant speed: no launch/brake pitch
        m = tr.speed_ref_mps == tr.config.speed_mps
        return np.degrees(tr.pitch_rad[m].std())

    assert cruise_pitch_std_deg(rough) > 3.0 * cruise_pitch_std_deg(flat)
    assert cruise_pitch_std_deg(rough) > 0.1
    assert rough.stats["pitch_range_deg"] > 0.5
    assert rough.stats["height_range_m"] > 0.02
    assert flat.stats["height_range_m"] < 0.01
    assert rough.stats["roll_range_deg"] > 0.3 > flat.stats["roll_range_deg"]


def test_slope_tilts_the_car_with_the_ground():
    tr = simulate_vehicle(VehicleConfig(speed_mps=4.0, ground="slope", slope_deg=4.0),
                          _straight(30.0), np.random.default_rng(0))
    pitch = np.degrees(tr.pitch_rad[tr.speed_mps > 3.5])
    # climbing +x: nose up (negative pitch about +y in ZYX), about the slope angle
    assert np.allclose(np.median(pitch), -4.0, atol=0.5)
    z = tr.T_world_base[:, 2, 3]
    x = tr.T_world_base[:, 0, 3]
    assert np.allclose(np.polyfit(x, z, 1)[0], np.tan(np.radians(4.0)), atol=0.005)


@pytest.mark.slow
def test_differential_drive_follows_the_path():
    tr = simulate_vehicle(VehicleConfig(drive="differential", speed_mps=3.0), PATH,
                          np.random.default_rng(0))
    assert tr.wheels == ("rl", "rr")
    # pure pursuit (4 m lookahead) cuts the ~6 m radius turns by a few decimetres
    assert tr.stats["cross_track_max_m"] < 1.0
    assert tr.stats["slip_ratio_peak"] < 0.1
    assert np.all(tr.steer_rad == 0.0)


@pytest.mark.slow
def test_deterministic_to_1e9_and_seed_dependent_ground():
    cfg = VehicleConfig(speed_mps=4.0, ground="uneven", bump_amplitude_m=0.03)
    a = simulate_vehicle(cfg, _straight(25.0), np.random.default_rng(7))
    b = simulate_vehicle(cfg, _straight(25.0), np.random.default_rng(7))
    c = simulate_vehicle(cfg, _straight(25.0), np.random.default_rng(8))
    assert a.time_s.shape == b.time_s.shape
    assert np.max(np.abs(a.T_world_rig_mount - b.T_world_rig_mount)) <= 1e-9
    assert np.max(np.abs(a.T_world_base - b.T_world_base)) <= 1e-9
    n = min(a.time_s.size, c.time_s.size)
    assert np.max(np.abs(a.T_world_base[:n, 2, 3] - c.T_world_base[:n, 2, 3])) > 1e-3


def test_path_forms_are_equivalent():
    p = _straight(12.0, n=200)
    arr = np.column_stack([p.t, p.x, p.y, p.yaw])
    assert np.array_equal(as_planar_path(arr).x, p.x)
    assert np.array_equal(as_planar_path(arr.T).y, p.y)
    q = as_planar_path(lambda t: (12.0 * t, 0.0 * t, 0.0 * t), duration_s=1.0, n=200)
    assert np.allclose(q.x, p.x)
    cfg = VehicleConfig(speed_mps=3.0, settle_s=0.5)
    a = simulate_vehicle(cfg, arr, np.random.default_rng(0))
    b = simulate_vehicle(cfg, p, np.random.default_rng(0))
    assert np.array_equal(a.T_world_base, b.T_world_base)


@pytest.mark.parametrize("kwargs, match", [
    ({"drive": "tank"}, r"drive must be one of \['ackermann', 'differential'\]"),
    ({"ground": "ice"}, r"ground must be one of \['flat', 'slope', 'uneven'\]"),
    ({"timestep_s": 0.005}, r"timestep_s must be in \[1e-05, 0.002\]"),
    ({"ground": "slope"}, r"needs a non-zero slope_deg"),
    ({"slope_deg": 3.0}, r"only used with ground='slope'"),
    ({"speed_mps": float("nan")}, r"speed_mps must be finite"),
    ({"speed_mps": -1.0}, r"speed_mps must be in \(0.0, 30.0\]"),
    ({"bump_amplitude_m": 0.0}, r"bump_amplitude_m must be in \(0.0, 0.3\]"),
    ({"mount_pos_m": (0.0, 1.0)}, r"mount_pos_m must be 3 numbers"),
    ({"control_rate_hz": 300.0}, r"control_rate_hz=300.0 must divide the physics rate"),
    ({"wheel_radius_m": 0.5, "wheelbase_m": 0.9}, r"wheel_radius_m=0.5 must be < wheelbase_m"),
])
def test_bad_config_raises_clear_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        VehicleConfig(**kwargs)


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(TypeError, match="sprung must be a bool"):
        VehicleConfig(sprung="yes")
    with pytest.raises(TypeError, match="speed_mps must be a number"):
        VehicleConfig(speed_mps="fast")
    with pytest.raises(ValueError, match=r"unknown VehicleConfig field\(s\) \['speed'\]"):
        VehicleConfig().replace(speed=3.0)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        simulate_vehicle(VehicleConfig(), PATH, 0)
    with pytest.raises(TypeError, match="cfg must be a VehicleConfig"):
        simulate_vehicle({"speed_mps": 3}, PATH, np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"path array must be \(M, 4\)"):
        simulate_vehicle(VehicleConfig(), np.zeros((10, 3)), np.random.default_rng(0))
    with pytest.raises(ValueError, match="strictly increasing"):
        as_planar_path(np.zeros((10, 4)))
    with pytest.raises(ValueError, match="needs path_duration_s"):
        as_planar_path(lambda t: (t, t, t))
    with pytest.raises(ValueError, match="left the path"):
        simulate_vehicle(VehicleConfig(speed_mps=14.0), PATH, np.random.default_rng(0))


def test_translation_sensitivity_separates_planar_from_rolling(sprung, rigid):
    from simcalib.world.vehicle import translation_sensitivity
    s = translation_sensitivity(sprung)
    r = translation_sensitivity(rigid)
    assert s["n_motions"] > 20 and s["n_motions"] == r["n_motions"]
    # horizontal axes (rig x, z) are determined by the yaw alike
    assert np.all(s["amplification"][[0, 2]] < 2.0)
    assert np.all(r["amplification"][[0, 2]] < 2.0)
    # the vertical (rig y) only through roll/pitch: poorly on the sprung car, not at all
    # on the rigid one
    assert 2.0 < s["amplification"][1] < 100.0
    assert r["amplification"][1] > 30.0 * s["amplification"][1]
    assert s["tilt_rms_deg"] > 0.1 > r["tilt_rms_deg"]
    with pytest.raises(TypeError, match="traj must be a VehicleTrajectory"):
        translation_sensitivity("x")
