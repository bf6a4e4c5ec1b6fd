"""What ``simcalib advise`` prints (simcalib.studies.advise.console): every stop is said to be
the motion from the previous stop (the first from the reference), turns about the vertical
are named as such, undetermined axes print as inf."""

from simcalib.studies.advise.console import advice_lines, recorded_advice_lines

STD = {"wx_deg": 0.1, "wy_deg": 0.2, "wz_deg": 0.1, "vx_m": 0.002, "vy_m": None, "vz_m": 0.003}


def _stop(step, rotvec, frm):
    return {"step": step, "from": frm, "predicted_std_after": STD,
            "target_motion": {"rotvec_world_deg": rotvec, "angle_deg": 0.0,
                              "translation_world_m": [0.1, -0.05, 0.0]},
            "camera_motions": {"cam_a": {"angle_deg": 30.0, "translation_m": [0.1, 0.0, 0.0],
                                         "rotvec_deg": [0.0, 30.0, 0.0]}},
            "joint_targets_rad": {"j1": 0.5, "j2": -1.0}}


def test_each_stop_is_said_to_be_the_motion_from_the_previous_stop():
    out = {"scenario": "scara", "platform": "arm", "recorded_motions": 10,
           "candidates": {"feasible": 9, "drawn": 10}, "predicted_std_before": STD,
           "motions": [_stop(1, [0.0, 0.0, -35.0], "the reference stop"),
                       _stop(2, [10.0, 0.0, 0.0], "stop 1")],
           "cannot_help": [{"statement": "translation of X along [0, -1, 0]", "fix": "a prior"}],
           "timing_s": {"total": 1.0}}
    lines = advice_lines(out)
    text = "\n".join(lines)
    assert ("each stop is a motion from the previous stop (stop 1: from the reference, the "
            "recorded run's last pose); angles and moves are relative to it; joint targets "
            "are absolute") in text
    stop1 = next(ln for ln in lines if ln.startswith("stop 1 "))
    assert stop1.startswith("stop 1 (from the reference stop): flange turns -35.0 deg about "
                            "the vertical, moves [+10.0, -5.0, +0.0] cm (world axes)")
    assert "cameras cam_a 30.0 deg / 10.0 cm" in stop1 and "joints [deg] 28.6 -57.3" in stop1
    stop2 = next(ln for ln in lines if ln.startswith("stop 2 "))
    assert stop2.startswith("stop 2 (from stop 1): flange turns 10.0 deg about [1.00, 0.00, "
                            "0.00]")
    before = next(ln for ln in lines if ln.startswith("before"))
    assert before.split()[5] == "inf" and "(inf: undetermined)" in text
    assert "cannot help: translation of X along [0, -1, 0]. Fix: a prior" in text
    # a cart stop, and recorded pose files
    out["platform"] = "cart"
    for m in out["motions"]:
        m.pop("joint_targets_rad")
        m["cart_pose"] = {"position_m": [1.0, 2.0, 0.0], "yaw_deg": 3.0}
    assert "stop 1 (from the reference stop): cart turns -35.0 deg about the vertical" in \
        "\n".join(advice_lines(out))
    rec = {"platform": "free", "recorded_motions": 5, "candidates": {"drawn": 10},
           "predicted_std_before": STD, "cannot_help": [], "not_checked": "reach",
           "timing_s": {"total": 1.0},
           "motions": [{"step": 1, "from": "the reference",
                        "predicted_std_after": STD,
                        "sensor_motions": {"a": {"angle_deg": 20.0, "rotvec_deg": [0, 0, 20],
                                                 "translation_m": [0.0, 0.1, 0.0]}}}]}
    text = "\n".join(recorded_advice_lines(rec))
    assert "each stop is a motion from the previous stop (stop 1: from the reference, the " \
           "last recorded pose of sensor a)" in text
    assert "stop 1 (from the reference): sensor a: 20.0 deg about " \
           "[0.00, 0.00, 1.00] / 10.0 cm" in text
