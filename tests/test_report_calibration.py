"""The console report of a calibration (simcalib.report.calibration)."""

from simcalib.report.calibration import _offset_line


def _off(offset_s, sigma, decision="estimated", drift=0.0, drift_sigma=0.0):
    return {"offset_s": offset_s, "uncertainty_s": sigma, "decision": decision,
            "drift": drift, "drift_sigma": drift_sigma}


def test_offset_line_is_in_samples_for_sample_number_stamps():
    assert _offset_line(_off(-37.371, 0.0014), {"motion_step": 8}) == (
        "time offset t_b - t_a: -37.371 +- 0.0014 samples (estimated)")
    assert _offset_line(_off(0.0374, 0.0012), {"motion_step": 0}) == (
        "time offset t_b - t_a: 37.40 +- 1.20 ms (estimated)")
    assert _offset_line(_off(0.0, 0.0, "given"), {}) == "time offset t_b - t_a: 0.00 ms (given)"


def test_offset_line_gives_the_sigma_of_an_offset_kept_at_zero():
    """0 used where the data do not tell an offset (``zero``), or stamps shared by two
    continuous streams whose check kept 0 (``shared_stamps``): the sigma X's covariance
    carries is printed beside the 0, as for an estimated offset."""
    assert _offset_line(_off(0.0, 0.00457, "zero"), {}) == (
        "time offset t_b - t_a: 0.00 +- 4.57 ms (not told by the data: 0 used)")
    assert _offset_line(_off(0.0, 0.00457, "shared_stamps"), {}) == (
        "time offset t_b - t_a: 0.00 +- 4.57 ms (paired by stamp)")
    assert _offset_line(_off(0.0, None, "zero"), {}) == (
        "time offset t_b - t_a: 0.00 ms (not told by the data: 0 used)")   # unknown: null


def test_offset_line_gives_a_fitted_drift_with_its_sigma():
    assert _offset_line(_off(-0.13433, 0.00026, drift=98.5e-6, drift_sigma=3.1e-6), {}) == (
        "time offset t_b - t_a: -134.33 +- 0.26 ms (estimated), drift 98.5 +- 3.1 ppm")


def test_other_readings_lines_give_the_x_of_b_mirrored_where_the_handedness_is_not_told():
    import numpy as np
    from simcalib.report.calibration import other_readings_lines
    X = np.eye(4)
    X[:3, 3] = [0.1, -0.2, 0.3]
    assert other_readings_lines({"conventions": {"mirror_T_a_b": None}}) == []
    (line,) = other_readings_lines({"conventions": {"mirror_T_a_b": X.tolist()}})
    assert line.startswith("  read with b mirrored (z negated), the same data give X: t = ")
    assert "100.00, -200.00, 300.00" in line and "mirror_b=true" in line
