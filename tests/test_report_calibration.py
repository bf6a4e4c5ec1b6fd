"""The console report of a calibration (simcalib.report.calibration)."""

from simcalib.report.calibration import _offset_line


def test_offset_line_is_in_samples_for_sample_number_stamps():
    off = {"offset_s": -37.371, "estimated": True}
    assert _offset_line(off, 0.0014, {"motion_step": 8}) == (
        "time offset t_b - t_a: -37.371 +- 0.0014 samples")
    off = {"offset_s": 0.0374, "estimated": True}
    assert _offset_line(off, 0.0012, {"motion_step": 0}) == (
        "time offset t_b - t_a: 37.40 +- 1.20 ms")
    assert _offset_line({"offset_s": 0.0, "estimated": False}, 0.0, {}) == (
        "time offset t_b - t_a: 0.00 ms")
