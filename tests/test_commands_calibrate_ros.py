"""`calibrate bag=... a=SPEC b=SPEC export=[...]` and `calibrate list_bag=FILE` end to end
(docs/ros.md). Skipped until the command has the `bag` key (the wiring in
simcalib/commands/calibrate.py)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

pytest.importorskip("rosbags")

from simcalib.cli import main  # noqa: E402
from simcalib.pipeline.calibrate import CalibrateOptions  # noqa: E402
from simcalib.ros.exports import (parse_easy_handeye2, parse_kalibr, parse_launch_file,  # noqa: E402
                              parse_static_transform_publisher, parse_urdf_joint)
from simcalib.geometry import invert_transform  # noqa: E402

pytestmark = pytest.mark.skipif(
    "bag" not in {f.name for f in dataclasses.fields(CalibrateOptions)},
    reason="calibrate has no bag= key yet (ROS wiring not in simcalib/commands/calibrate.py)")

from test_ros_bag import BagBuilder, Rig, _random_T  # noqa: E402


@pytest.fixture(scope="module")
def eih_bag(tmp_path_factory):
    """Eye in hand: tf base_link -> link1 -> tool0 (moving) and camera_link -> board
    (the tracker's T_cam_board), all at the same stamps; X = T_tool0_camera_link."""
    rig = Rig(seed=5, n=40)
    rng = np.random.default_rng(17)
    X, T_base_board = _random_T(rng, scale=0.3), _random_T(rng, scale=0.3)
    b = BagBuilder("ros1")
    for k, ns in enumerate(rig.hand_ns):
        T_cam_board = invert_transform(rig.T_base_hand[k] @ X) @ T_base_board
        b.tf("/tf", int(ns), [(int(ns), "base_link", "link1", rig.T_base_link1[k]),
                              (int(ns), "link1", "tool0", rig.T_link1_tool0[k]),
                              (int(ns), "camera_link", "board", T_cam_board)])
    return b.write(tmp_path_factory.mktemp("cli") / "eih"), X


def test_list_bag(eih_bag, capsys):
    assert main(["calibrate", f"list_bag={eih_bag[0]}"]) == 0
    out = capsys.readouterr().out
    assert "camera_link -> board  (moving, 40 stamps" in out
    assert "tf2_msgs/TFMessage" in out


def test_calibrate_a_bag_and_export_everything(eih_bag, tmp_path):
    path, X = eih_bag
    out = tmp_path / "eih_calib"
    code = main(["calibrate", f"bag={path}", "a=/tf:base_link->tool0",
                 "b=/tf:camera_link->board", f"output={out}", "time_offset=0",
                 "recording=false", "eye=in_hand",
                 "export=[urdf,static_tf,launch,easy_handeye2,kalibr]"])
    assert code == 0
    rep = json.loads((out / "calibration.json").read_text())
    assert np.abs(np.array(rep["X"]["T_a_b"]) - X).max() < 1e-8
    files = rep["files"]["exports"]
    assert set(files) == {"urdf", "static_tf", "launch", "easy_handeye2", "kalibr"}
    parsers = {"urdf": parse_urdf_joint, "launch": parse_launch_file,
               "easy_handeye2": parse_easy_handeye2, "kalibr": parse_kalibr,
               "static_tf": lambda t: parse_static_transform_publisher(t.splitlines()[-1])}
    for kind, name in files.items():
        p = parsers[kind]((out / name).read_text())
        assert np.abs(p.X - X).max() < 1e-8, kind
        if kind != "kalibr":
            assert (p.parent, p.child) == ("tool0", "camera_link"), kind
    eh = parse_easy_handeye2((out / files["easy_handeye2"]).read_text())
    assert eh.details["parameters"]["robot_base_frame"] == "base_link"
    assert eh.details["parameters"]["tracking_marker_frame"] == "board"


@pytest.mark.parametrize("args, code, needle", [
    (["b=/tf:camera_link->bord"], 3, "did you mean 'board'"),
    (["b=/tf:camera_link->board", "export=[easy_handeye2]"], 2, "eye must be"),
    (["b=/tf:camera_link->board", "export=[urfd]"], 2, "did you mean 'urdf'"),
])
def test_bad_bag_options(eih_bag, tmp_path, capsys, args, code, needle):
    got = main(["calibrate", f"bag={eih_bag[0]}", "a=/tf:base_link->tool0",
                f"output={tmp_path / 'o'}", "time_offset=0", "recording=false", *args])
    assert got == code
    assert needle in capsys.readouterr().err
