"""Eye-to-hand on the arm (simcalib.world.eyetohand): a fixed camera on a stand sees a
board on the flange; X = T_flange_board, T_base_cam is the by-product."""

import json

import numpy as np
import pytest

from simcalib.cli import main
from simcalib.pipeline.scenario import load_config
from simcalib.errors import ConfigError
from simcalib.geometry import invert_transform, rotation_error_rad, translation_error_m
from simcalib.pipeline.eye_to_hand import base_camera_estimate
from simcalib.world.eyetohand import FIXED_CAMERA, MOUNTS, T_world_fixed_camera

SHORT = ["world.duration_s=6", "world.fps=10", "pairing.step=1", "progress=false"]


@pytest.fixture(scope="module")
def gt_state():
    from simcalib.pipeline.stages import state_through_pairs
    cfg = load_config("eyetohand", ["source=ground_truth", "streams.a.source=ground_truth",
                                    "streams.b.source=ground_truth", *SHORT])
    return state_through_pairs(cfg)


def test_truth_streams_satisfy_cx_equals_xh(gt_state):
    X = gt_state.X_true
    C, H = gt_state.pairs.C, gt_state.pairs.H
    assert C.shape[0] >= 50
    np.testing.assert_allclose(C @ X, X @ H, atol=1e-9)
    # the board stream's world is the fixed camera: the board is in front of it
    b = gt_state.truth.streams["cam_b"]
    assert b.info["world"] == FIXED_CAMERA
    assert np.all(np.asarray(b.T_world_cam)[:, 2, 3] > 0.3)


def test_fixed_camera_in_the_scene_matches_its_pose(gt_state):
    import mujoco
    from simcalib.world.render import T_world_cv_from_mujoco
    world = gt_state.truth.world
    m = world.model
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_camlight(m, d)
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, FIXED_CAMERA)
    assert i >= 0
    T = T_world_cv_from_mujoco(d.cam_xpos[i], d.cam_xmat[i])
    np.testing.assert_allclose(T, T_world_fixed_camera(world.config), atol=1e-9)


def test_base_camera_by_product_is_exact_on_truth(gt_state):
    from simcalib.world.robot_error import arm_state
    world = gt_state.truth.world
    _, T_world_base = arm_state(world)
    s = gt_state.truth.streams
    T = base_camera_estimate(s["cam_a"], s["cam_b"], gt_state.X_true, T_world_base)
    T_true = invert_transform(T_world_base) @ T_world_fixed_camera(world.config)
    assert rotation_error_rad(T, T_true) < 1e-9
    assert translation_error_m(T, T_true) < 1e-9
    # a wrong X gives a wrong T_base_cam
    X_bad = gt_state.X_true.copy()
    X_bad[:3, 3] += 0.01
    T_bad = base_camera_estimate(s["cam_a"], s["cam_b"], X_bad, T_world_base)
    assert translation_error_m(T_bad, T_true) > 0.005


def test_scenario_runs_and_determines_x_and_the_camera(tmp_path):
    out = tmp_path / "run"
    # the noise of the rendered board's poses (p95 ~0.3 deg / ~1.3 mm, docs/world.md)
    assert main(["run", "scenario=eyetohand", f"output={out}", "streams.b.source=noisy",
                 "noise.sigma_r_deg=0.2", "noise.sigma_t_m=0.002",
                 "solvers=[dqopt,daniilidis]", "recording.enabled=false",
                 "progress=false"]) == 0
    res = json.loads((out / "results.json").read_text())
    for label in ("dqopt", "daniilidis"):
        sol = res["solvers"][label]
        assert sol["rotation_error_deg"] < 1.0 and sol["translation_error_m"] < 0.01, sol
        cam = res["eye_to_hand"]["solvers"][label]
        assert cam["rotation_error_deg"] < 1.0 and cam["translation_error_m"] < 0.02, cam
    e2h = res["eye_to_hand"]
    assert e2h["X"] == "T_flange_board" and np.asarray(e2h["T_base_cam_true"]).shape == (4, 4)
    assert e2h["board_visibility"]["fraction_in_view"] >= 0.95


@pytest.mark.slow
def test_rendered_board_run_determines_x_and_the_camera(tmp_path):
    """The scenario's default: the stand camera's images, realistic preset (~15 s)."""
    out = tmp_path / "run"
    assert main(["run", "scenario=eyetohand", f"output={out}", "solvers=[dqopt,daniilidis]",
                 "recording.enabled=false", "progress=false"]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["config"]["vision"]["preset"] == "realistic"
    assert res["stream_sources"]["cam_b"] == "fixed_board"
    assert res["frames"]["cam_b"]["used"] >= 190
    for label in ("dqopt", "daniilidis"):
        sol = res["solvers"][label]
        assert sol["rotation_error_deg"] < 1.0 and sol["translation_error_m"] < 0.01, sol
        cam = res["eye_to_hand"]["solvers"][label]
        assert cam["rotation_error_deg"] < 1.0 and cam["translation_error_m"] < 0.01, cam


def test_fixed_board_source_needs_eye_to_hand(tmp_path):
    out = tmp_path / "run"
    status = main(["run", "scenario=handeye", f"output={out}", "streams.b.source=fixed_board",
                   "world.duration_s=2", "progress=false", "recording.enabled=false"])
    assert status != 0


def test_bad_mount_lists_the_valid_ones():
    with pytest.raises(ConfigError) as err:
        load_config("eyetohand", ["world.arm.mount=eye_on_base"])
    msg = str(err.value)
    assert "eye_on_base" in msg and all(m in msg for m in MOUNTS)


def test_eye_in_hand_scene_has_no_fixed_camera():
    import mujoco
    from simcalib.world.scene import build_scene
    cfg = load_config("handeye", ["source=ground_truth", "streams.b.source=ground_truth",
                                  "world.target=marker_wall", *SHORT])
    assert cfg.world.arm.mount == "eye_in_hand"
    scene = build_scene(cfg.world)
    assert mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_CAMERA, FIXED_CAMERA) < 0
