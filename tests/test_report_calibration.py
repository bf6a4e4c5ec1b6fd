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


def test_offset_line_gives_the_sigma_of_an_offset_kept_at_zero():
    """0 used where the data do not tell an offset (``zero``), or stamps shared by two
    continuous streams whose check kept 0 (``shared_stamps``): the sigma X's covariance
    carries is printed beside the 0, as for an estimated offset."""
    for decision in ("zero", "shared_stamps"):
        off = {"offset_s": 0.0, "estimated": False, "decision": decision}
        assert _offset_line(off, 0.00457, {}) == "time offset t_b - t_a: 0.00 +- 4.57 ms"
    assert _offset_line({"offset_s": 0.0, "estimated": False}, None, {}) == (
        "time offset t_b - t_a: 0.00 ms")                  # unknown (NaN -> null)
