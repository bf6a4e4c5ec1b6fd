"""Does a stream move (simcalib.estimation.stillness), whatever the file's length unit."""

import numpy as np
import pytest

from simcalib.errors import DataError
from simcalib.estimation.stillness import white_positions
from simcalib.geometry import matrix_from_rotvec, transform_from_rotation_translation
from simcalib.importers import stream_from_arrays
from simcalib.studies.experiments.recording_kinds import generate


def _still(rng, n=600, rate_hz=30.0, sigma_m=0.001, sigma_deg=0.1, unit=1.0, name="s"):
    """A rig standing still, sampled at ``rate_hz`` with pose noise; positions written in a
    unit ``unit`` per metre (1e3: a file in mm)."""
    t = 100.0 + np.arange(n) / rate_hz
    R = matrix_from_rotvec(np.radians(sigma_deg) * rng.standard_normal((n, 3))
                           + [0.3, -0.2, 1.0])
    p = np.array([0.4, -0.1, 0.8]) + sigma_m * rng.standard_normal((n, 3))
    return stream_from_arrays(t, transform_from_rotation_translation(R, unit * p),
                              source=f"<{name}>", name=name)


def _in_mm(s):
    T = np.array(s.T_world_sensor)
    T[:, :3, 3] *= 1e3
    return stream_from_arrays(s.timestamps_s, T, source=s.source + " (mm)", name=s.name)


@pytest.mark.parametrize("unit", [1.0, 1e3, 1e6])
def test_noise_around_one_place_is_white_in_any_unit(unit):
    why = white_positions(_still(np.random.default_rng(0), unit=unit))
    assert why is not None and "white noise around one place" in why


def test_a_path_and_stations_are_not_white():
    rec = generate("translation", 0)                        # a stage, 100 / 30 Hz
    for s in (rec.stream_a, rec.stream_b, _in_mm(rec.stream_b)):
        assert white_positions(s) is None
    st = generate("stations", 1)                            # stations seconds apart
    assert white_positions(st.stream_a) is None


@pytest.mark.parametrize("ua,ub", [(1.0, 1.0), (1.0, 1e3), (1e3, 1e3)])
def test_a_still_rig_is_nothing_moves_whatever_the_unit(ua, ub):
    from simcalib.estimation.path import calibrate_streams
    rng = np.random.default_rng(3)
    a = _still(rng, n=2000, rate_hz=100.0, sigma_m=2e-4, sigma_deg=0.02, unit=ua, name="a")
    b = _still(rng, unit=ub, name="b")
    with pytest.raises(DataError, match="nothing moves: neither stream rotates"):
        calibrate_streams(a, b)


def test_a_translating_rig_in_mm_still_calibrates_its_rotation():
    from simcalib.estimation.stillness import check_streams_move
    rec = generate("translation", 0)
    assert check_streams_move(_in_mm(rec.stream_a), _in_mm(rec.stream_b)) == "translation"
    # a still stream in mm beside a translating one in m: that stream does not move
    still = _still(np.random.default_rng(4), unit=1e3, name="b")
    with pytest.raises(DataError, match="stream b .* does not move.*white noise"):
        check_streams_move(rec.stream_a, still)


def test_the_same_poses_given_twice_are_bad_input():
    from simcalib.estimation.path import calibrate_streams
    rec = generate("stations", 1)
    with pytest.raises(DataError, match="hold the same .* poses, row for row at the same"):
        calibrate_streams(rec.stream_a, rec.stream_a)
    a = rec.stream_a                        # a copy stamped anew is the same input
    late = stream_from_arrays(a.timestamps_s + 0.5, a.T_world_sensor, source="<late>",
                              name="b")
    with pytest.raises(DataError, match="row for row: the same file or topic given twice"):
        calibrate_streams(a, late)
    from simcalib.estimation.stillness import check_distinct
    assert check_distinct(rec.stream_a, rec.stream_b) is None


def test_a_world_reset_of_a_rig_that_does_not_turn_is_no_rotation():
    """A SLAM map reset half-way in b of a stage that only translates: the jump's rotation
    made b "rotate" while a did not, and the data were refused; each world stretch is
    measured from its own first pose."""
    from simcalib.estimation.path import calibrate_streams
    from simcalib.geometry import matrix_from_rotvec, rotation_error_rad
    rec = generate("translation", 0)
    b = rec.stream_b
    G = np.eye(4)
    G[:3, :3], G[:3, 3] = matrix_from_rotvec([0.4, -0.3, 0.5]), [0.3, -0.2, 0.1]
    T = np.array(b.T_world_sensor)
    k = len(T) // 2
    T[k:] = G @ T[k:]
    reset = stream_from_arrays(b.timestamps_s, T, source="<reset>", name="b")
    base = calibrate_streams(rec.stream_a, rec.stream_b, seed=0)
    r = calibrate_streams(rec.stream_a, reset, seed=0)
    assert r.signal == "translation"
    assert np.degrees(rotation_error_rad(r.X, base.X)) < 0.05
