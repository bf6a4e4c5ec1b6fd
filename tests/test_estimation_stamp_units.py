"""The stamps' unit told from both streams (simcalib.estimation.stamp_units)."""

import dataclasses

import numpy as np
import pytest

from simcalib.errors import DataError
from simcalib.estimation.sampling import is_sample_numbers
from simcalib.estimation.stamp_units import motion_units, stamps_to_seconds
from simcalib.studies.experiments.recording_kinds import generate


def _in(s, factor, relative=True):
    """The stream with its stamps written in a unit ``factor`` per second (from its first
    pose when ``relative``), read as they are."""
    t = np.asarray(s.timestamps_s, dtype=np.float64)
    return dataclasses.replace(s, timestamps_s=((t - t[0]) if relative else t) * factor)


@pytest.fixture(scope="module")
def offset_rec():
    return generate("offset", 1)          # 100 / 30 Hz, 20 s, offset and 30..100 ppm drift


@pytest.fixture(scope="module")
def station_rec():
    return generate("stations", 1)        # 10..40 stations, stamps seconds apart


@pytest.mark.parametrize("fa,fb,ua,ub", [(1e3, 1, "ms", ""), (1, 1e3, "", "ms"),
                                         (1e3, 1e3, "ms", "ms"), (1e6, 1, "us", ""),
                                         (1, 1e9, "", "ns"), (1e6, 1e6, "us", "us")])
def test_relative_stamps_in_ms_us_ns_are_rescaled_and_counted(offset_rec, fa, fb, ua, ub):
    a, b = stamps_to_seconds(_in(offset_rec.stream_a, fa), _in(offset_rec.stream_b, fb))
    for s, src, f, u in ((a, offset_rec.stream_a, fa, ua), (b, offset_rec.stream_b, fb, ub)):
        t0 = src.timestamps_s[0]
        np.testing.assert_allclose(s.timestamps_s, src.timestamps_s - t0, atol=1e-9)
        assert s.stamps_unit == u
        assert s.repairs == ({f"stamps_{u}_to_s": src.n} if u else {})
        assert (f"stamps read as {u} relative" in s.detection) == bool(u)


def test_stamps_in_seconds_are_left_alone_on_every_kind():
    for kind in ("continuous", "offset", "gaps", "outliers", "stop_and_go", "bursts",
                 "low_rate_camera", "stations", "stations_short", "scara", "planar"):
        for seed in (0, 1):
            rec = generate(kind, seed)
            a, b = stamps_to_seconds(rec.stream_a, rec.stream_b)
            assert a is rec.stream_a and b is rec.stream_b, (kind, seed)


def test_a_dense_motion_stepping_by_seconds_tells_its_unit(offset_rec):
    # a at 100 Hz in ms steps by 10: a motion sampled every 10 s read as seconds
    units, why = motion_units(_in(offset_rec.stream_a, 1e3))
    assert units == ["ms"] and "move densely" in why
    assert motion_units(_in(offset_rec.stream_a, 1e6))[0] == ["us"]
    assert motion_units(offset_rec.stream_a) is None             # 10 ms steps: not asked


def test_stations_tell_nothing_by_their_motion_and_keep_a_shared_unit(station_rec):
    for f in (1.0, 1e3):
        sa, sb = _in(station_rec.stream_a, f), _in(station_rec.stream_b, f)
        assert motion_units(sa) is None
        a, b = stamps_to_seconds(sa, sb)      # paired by stamp: the unit changes nothing
        assert a is sa and b is sb


def test_stations_a_unit_apart_are_told_by_their_spans_and_steps(station_rec):
    sa, sb = _in(station_rec.stream_a, 1e3), _in(station_rec.stream_b, 1.0)
    a, b = stamps_to_seconds(sa, sb)
    assert a.stamps_unit == "ms" and b is sb
    np.testing.assert_allclose(a.timestamps_s, b.timestamps_s, atol=1e-9)


def test_sample_numbers_are_never_rescaled():
    rec = generate("stations", 0)            # stamped with the station index
    a, b = stamps_to_seconds(rec.stream_a, rec.stream_b)
    assert a is rec.stream_a and b is rec.stream_b


def test_a_unit_given_wins_over_the_data(offset_rec):
    sa, sb = _in(offset_rec.stream_a, 1e3), offset_rec.stream_b
    a, _ = stamps_to_seconds(sa, sb, unit_a="ms")
    assert a.stamps_unit == "ms" and not a.repairs and "(given)" in a.detection
    a, _ = stamps_to_seconds(sa, sb, unit_a="s")
    np.testing.assert_array_equal(a.timestamps_s, sa.timestamps_s)


def test_stamps_whose_unit_cannot_be_told_are_refused_naming_the_keys(station_rec):
    # stations in ns in both files: steps of 3e9 that no motion or span can place
    sa, sb = _in(station_rec.stream_a, 1e9), _in(station_rec.stream_b, 1e9)
    with pytest.raises(DataError, match=r"stream a .*step by 3\.3\d*e\+09 .*unit cannot be "
                                        r"told.*stamps_unit_a=ms"):
        stamps_to_seconds(sa, sb)


def test_a_dense_motion_no_unit_fits_is_refused(offset_rec):
    # a motion sampled every 10 units while turning 1e-7 deg per unit: no unit makes it a
    # pose sensor of a moving rig (ms: 1e-4 deg/s, us: 0.1, ns: 10 ns a step)
    s = offset_rec.stream_a
    R = s.T_world_sensor.copy()
    from simcalib.geometry import matrix_from_rotvec
    ang = np.radians(1e-6) * np.arange(s.n) * 10      # 1e-6 deg a step of 10 units
    R[:, :3, :3] = matrix_from_rotvec(np.outer(ang, [0.0, 0.0, 1.0]))
    slow = dataclasses.replace(_in(s, 1e3), T_world_sensor=R)
    units, _ = motion_units(slow)
    assert units == []
    with pytest.raises(DataError, match=r"stream a .*move densely.*no unit makes it a pose "
                                        r"sensor.*stamps_unit_a=ms .*stamps_unit_a=s"):
        stamps_to_seconds(slow, _in(offset_rec.stream_b, 1e3), unit_b="s")
    # b's unit told by its motion (ms): a's span then 1000x b's, against a's own motion
    with pytest.raises(DataError, match=r"stamps disagree: a spans 1998\d\.\d .*b spans "
                                        r"19\.9\d* .*a's motion says no unit"):
        stamps_to_seconds(slow, _in(offset_rec.stream_b, 1e3))


@pytest.fixture(scope="module")
def khz_rec():
    return generate("offset", 0, rate_a_hz=1000.0, duration_s=6.0)   # a at 1 kHz


def _whole_ms(s, t0):
    """The stream stamped in whole ms from ``t0`` (what a 1 kHz logger writes)."""
    t = np.round((np.asarray(s.timestamps_s) - t0) * 1e3)
    keep = np.concatenate([[True], np.diff(t) > 0])             # rounding repeats a stamp
    return dataclasses.replace(s, timestamps_s=t[keep], T_world_sensor=s.T_world_sensor[keep])


@pytest.mark.parametrize("b_unit", [1.0, 1e3])
def test_a_1khz_stream_in_whole_ms_is_told_from_sample_numbers_by_the_pair(khz_rec, b_unit):
    t0 = khz_rec.stream_a.timestamps_s[0]
    sa = _whole_ms(khz_rec.stream_a, t0)
    assert is_sample_numbers(np.asarray(sa.timestamps_s))       # alone it counts by 1
    sb = dataclasses.replace(khz_rec.stream_b, timestamps_s=(
        np.asarray(khz_rec.stream_b.timestamps_s) - t0) * b_unit)
    a, b = stamps_to_seconds(sa, sb)
    assert a.stamps_unit == "ms" and a.repairs["stamps_ms_to_s"] == sa.n
    assert "count by 1 like sample numbers" in a.detection and "1 kHz" in a.detection
    np.testing.assert_allclose(a.timestamps_s, sa.timestamps_s / 1e3)
    assert b.stamps_unit == ("ms" if b_unit == 1e3 else "")
    # two streams that count by 1 stay sample numbers (paired by index)
    a2, b2 = stamps_to_seconds(sa, _whole_ms(khz_rec.stream_a, t0))
    assert a2.stamps_unit == "" and b2.stamps_unit == ""
