"""The plausibility check of calibrate's answer (simcalib.estimation.plausibility): the
both-inverted twin of a reading fits exactly alike; an answer many times longer than its
twin is flagged (exit 6 through the command), a plausible one is not."""

import json

import numpy as np
import pytest

from simcalib.cli import main
from simcalib.errors import EXIT_DEGENERATE, EXIT_OK
from simcalib.estimation.plausibility import check_plausibility
from simcalib.estimation.readings import ConventionReport
from simcalib.geometry import invert_transform, matrix_from_rotvec, rotation_error_rad, \
    transform_from_rotation_translation
from simcalib.report.results import write_tum
from simcalib.world.stream_sim import rig_streams


def _pair(rng, n=20, lever_m=0.1, worlds_m=2.0):
    """Poses of a rigid pair: a random trajectory of a, X of ``lever_m``, world b
    ``worlds_m`` away from world a."""
    X = transform_from_rotation_translation(matrix_from_rotvec(rng.normal(size=3)),
                                            lever_m * np.array([1.0, 0.0, 0.0]))
    T_wa_wb = transform_from_rotation_translation(matrix_from_rotvec(rng.normal(size=3)),
                                                  worlds_m * np.array([0.0, 0.6, 0.8]))
    T_wa_a = transform_from_rotation_translation(
        matrix_from_rotvec(rng.normal(size=(n, 3))), rng.uniform(-0.5, 0.5, (n, 3)))
    T_wb_b = invert_transform(T_wa_wb) @ T_wa_a @ X
    return X, T_wa_wb, T_wa_a, T_wb_b


AS_WRITTEN = ConventionReport(False, False, False, False)


def test_plausible_answer_and_its_twin_is_flagged():
    X, T_wa_wb, T_wa_a, T_wb_b = _pair(np.random.default_rng(0))
    p = check_plausibility(X, T_wa_a, T_wb_b, AS_WRITTEN)
    assert p.plausible and p.warnings == ()
    assert p.translation_m == pytest.approx(0.1) and p.twin_translation_m == pytest.approx(2.0)
    # the twin: both streams read inverted; its answer is T_wa_wb, and its twin is X
    twin = check_plausibility(T_wa_wb, invert_transform(T_wa_a), invert_transform(T_wb_b),
                              AS_WRITTEN)
    assert not twin.plausible and twin.twin_translation_m == pytest.approx(0.1)
    assert "invert_a=true invert_b=true" in twin.warnings[0]
    # the twin's answer is given whole: T_wa_wb for X, and X back for the twin
    np.testing.assert_allclose(p.twin_X, T_wa_wb, atol=1e-9)
    np.testing.assert_allclose(twin.twin_X, X, atol=1e-9)
    assert np.asarray(p.to_dict()["twin_T_a_b"]).shape == (4, 4)


def test_an_undetermined_translation_is_not_judged_by_its_length():
    """A rig that only translates leaves X's translation undetermined on every axis: its
    length (whatever the solver returned) and the twin's say nothing, so a long X is not
    flagged; a note says why."""
    X, T_wa_wb, T_wa_a, T_wb_b = _pair(np.random.default_rng(0))
    Ti_a, Ti_b = invert_transform(T_wa_a), invert_transform(T_wb_b)
    assert not check_plausibility(T_wa_wb, Ti_a, Ti_b, AS_WRITTEN).plausible
    p = check_plausibility(T_wa_wb, Ti_a, Ti_b, AS_WRITTEN, translation_undetermined=True)
    assert p.plausible and "undetermined on every axis" in p.notes[0]


def test_a_reading_the_caller_chose_keeps_the_twin_as_a_note():
    """Forced invert_a / invert_b (the absolute reading is the caller's) or eye=on_base (X
    is the camera in the robot base, long by nature): the long X is the answer asked for,
    so the twin is a note, not a flag; the same X unforced is still flagged."""
    X, T_wa_wb, T_wa_a, T_wb_b = _pair(np.random.default_rng(4))
    Ti_a, Ti_b = invert_transform(T_wa_a), invert_transform(T_wb_b)
    assert not check_plausibility(T_wa_wb, Ti_a, Ti_b, AS_WRITTEN).plausible
    for forced in (("invert_a",), ("invert_b",), ("invert_a", "invert_b")):
        conv = ConventionReport(True, True, False, False, forced=forced)
        p = check_plausibility(T_wa_wb, Ti_a, Ti_b, conv)
        assert p.plausible and p.warnings == () and len(p.notes) == 1, forced
        assert p.chosen_by == ", ".join(forced) and p.to_dict()["notes"] == list(p.notes)
        np.testing.assert_allclose(p.twin_X, X, atol=1e-9)    # the twin is still given
    p = check_plausibility(T_wa_wb, Ti_a, Ti_b, AS_WRITTEN, eye="on_base")
    assert p.plausible and "eye=on_base" in p.notes[0]
    # a forced quaternion order is not a chosen inversion: still flagged
    conv = ConventionReport(True, True, False, False, forced=("scalar_first_b",))
    assert not check_plausibility(T_wa_wb, Ti_a, Ti_b, conv).plausible
    assert not check_plausibility(T_wa_wb, Ti_a, Ti_b, AS_WRITTEN, eye="in_hand").plausible


def test_eye_on_base_flags_the_short_answer_of_an_unforced_reading():
    """eye=on_base asks for the camera in the base: an unforced X many times shorter than
    its twin is the marker on the flange (T_ee_marker); a forced one is the caller's."""
    X, T_wa_wb, T_wa_a, T_wb_b = _pair(np.random.default_rng(5))
    p = check_plausibility(X, T_wa_a, T_wb_b, AS_WRITTEN, eye="on_base")
    assert not p.plausible and "T_ee_marker" in p.warnings[0]
    assert "invert_a=true invert_b=true" in p.warnings[0]
    assert check_plausibility(X, T_wa_a, T_wb_b, AS_WRITTEN).plausible
    forced = ConventionReport(False, False, False, False, forced=("invert_a",))
    p = check_plausibility(X, T_wa_a, T_wb_b, forced, eye="on_base")
    assert p.plausible and p.notes == ()


def test_far_apart_sensors_with_near_worlds_are_not_flagged_by_a_short_twin_margin():
    X, _, T_wa_a, T_wb_b = _pair(np.random.default_rng(1), lever_m=0.3, worlds_m=0.1)
    assert check_plausibility(X, T_wa_a, T_wb_b, AS_WRITTEN).plausible   # 0.2 m < margin


def test_bad_shapes_are_a_clear_error():
    with pytest.raises(ValueError, match=r"received \(3, 3\)"):
        check_plausibility(np.eye(3), np.zeros((2, 4, 4)), np.zeros((2, 4, 4)), AS_WRITTEN)


@pytest.mark.slow
def test_command_flags_a_hand_file_holding_the_inverse_poses(tmp_path, capsys):
    """The issue's case: the hand file holds T_tool_base. The poses fit the twin exactly, so
    calibrate answers T_wa_wb (metres); the check turns it into a warning and exit 6, and
    following its hint gives the right X."""
    rs = rig_streams(duration_s=15.0, rng=np.random.default_rng(3))
    pa = write_tum(tmp_path / "hand_inv.tum", rs.t_a, invert_transform(rs.T_a))
    pb = write_tum(tmp_path / "cam.tum", rs.t_b, rs.T_b)
    code = main(["calibrate", f"a={pa}", f"b={pb}", f"output={tmp_path / 'out'}"])
    text = capsys.readouterr().out
    rep = json.loads((tmp_path / "out" / "calibration.json").read_text())
    assert code == EXIT_DEGENERATE and rep["status"] == "implausible", text
    assert not rep["plausibility"]["plausible"] and "WARNING: X's translation" in text
    twin = np.asarray(rep["plausibility"]["twin_T_a_b"])     # the right X, printed too
    assert np.degrees(rotation_error_rad(twin, rs.X)) < 0.1
    assert "read with both streams inverted, the same data give X" in text
    hint = rep["plausibility"]["twin_hint"].split()
    code = main(["calibrate", f"a={pa}", f"b={pb}", f"output={tmp_path / 'fixed'}", *hint])
    capsys.readouterr()
    rep = json.loads((tmp_path / "fixed" / "calibration.json").read_text())
    assert code == EXIT_OK and rep["plausibility"]["plausible"]
    t = np.asarray(rep["X"]["translation_m"])
    assert np.linalg.norm(t - rs.X[:3, 3]) < 0.01


@pytest.mark.parametrize("keys", [["invert_a=false"], ["eye=on_base"],
                                  ["invert_a=false", "invert_b=true"]])
def test_command_eye_on_base_exits_on_the_verdict_alone(tmp_path, capsys, keys):
    """Eye on base: stream a given as T_ee_base (the docs/ros.md recipe) and the reading
    chosen by the caller (invert_a given, or eye=on_base): X is the long answer asked for,
    so the twin is a note under it and the exit follows the verdict, not 'implausible'."""
    rs = rig_streams(duration_s=12.0, rng=np.random.default_rng(3))
    pa = write_tum(tmp_path / "hand_inv.tum", rs.t_a, invert_transform(rs.T_a))
    pb = write_tum(tmp_path / "cam.tum", rs.t_b, rs.T_b)
    code = main(["calibrate", f"a={pa}", f"b={pb}", f"output={tmp_path / 'out'}",
                 "recording=false", *keys])
    text = capsys.readouterr().out
    rep = json.loads((tmp_path / "out" / "calibration.json").read_text())
    p = rep["plausibility"]
    assert p["plausible"] and p["warnings"] == [] and len(p["notes"]) == 1, text
    assert p["translation_m"] > 3 * p["twin_translation_m"]       # the shape once flagged
    assert rep["status"] != "implausible" and "WARNING: X's translation" not in text
    assert code == (EXIT_DEGENERATE if rep["verdict"]["degenerate"] else EXIT_OK)
    assert "note: X's translation" in text
    twin = np.asarray(p["twin_T_a_b"])             # the other answer, still printed
    assert np.degrees(rotation_error_rad(twin, rs.X)) < 0.2
