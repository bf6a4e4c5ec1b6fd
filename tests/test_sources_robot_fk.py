"""Issue 10 §2-§4: robot error (robot_fk), per-stream sources, injected outliers, clocks,
the handeye / scara scenarios and determinism."""

import dataclasses
import json

import numpy as np
import pytest

from simcalib.errors import ConfigError
from simcalib.pipeline.scenario import load_config
from simcalib.geometry import invert_transform, rotation_error_rad, translation_error_m
from simcalib.targets.markers import MarkerField
from simcalib.sources import build_truth, camera_sources, get_source
from simcalib.sources.corruption import (OutliersConfig, flipped_marker_poses,
                                         inject_outliers)
from simcalib.streams import PoseStream
from simcalib.world.robot_error import (UR5E_DH, EncoderConfig, KinematicErrorConfig,
                                        dh_fk, draw_dh_error, encoder_readings, true_dh)

SMALL_ANY_DURATION = ["world.fps=5", "progress=false", "workers=1",
         "recording.enabled=false", "camera.width=320", "camera.height=240",
         "pairing.max_translation_m=5", "pairing.max_rotation_deg=90"]
SMALL = ["world.duration_s=2", *SMALL_ANY_DURATION]


def _rngs(seed=0):
    from simcalib.pipeline.state import run_rngs
    return run_rngs(seed)


def _fk_stream(cfg, seed=0):
    rngs = _rngs(seed)
    truth = build_truth(cfg, rngs)
    out = get_source("robot_fk", "sim").measure(truth, cfg, rngs[get_source("robot_fk").info.rng_stream], ("cam_a",))
    return truth, out.streams["cam_a"]


# ------------------------------------------------------------------------ kinematics
def test_dh_fk_is_batched_and_matches_a_hand_computed_pose():
    q = np.zeros(6)
    T = dh_fk(q)
    # UR5e at zero: flange at x = a2 + a3, y = -(d4 + d6), z = d1 - d5
    np.testing.assert_allclose(T[:3, 3], [-0.425 - 0.3922, -(0.1333 + 0.0996),
                                          0.1625 - 0.0997], atol=1e-12)
    Q = np.random.default_rng(0).uniform(-3, 3, (5, 3, 6))
    TT = dh_fk(Q)
    assert TT.shape == (5, 3, 4, 4)
    np.testing.assert_allclose(TT[2, 1], dh_fk(Q[2, 1]), atol=1e-14)
    with pytest.raises(ValueError, match="6 joint angles"):
        dh_fk(np.zeros(5))


def test_robot_fk_equals_truth_with_zero_error_and_ideal_encoders():
    cfg = load_config("handeye", SMALL)
    cfg = dataclasses.replace(cfg, robot=type(cfg.robot)())       # ideal robot
    truth, s = _fk_stream(cfg)
    assert truth.world.config.arm_dh_error is None
    gt = truth.streams["cam_a"]
    assert np.array_equal(s.frame_index, gt.frame_index)
    assert np.abs(s.T_world_cam - gt.T_world_cam).max() < 1e-9


def test_robot_fk_differs_from_truth_by_the_set_dh_error():
    cfg = load_config("handeye", SMALL + ["robot.encoder.counts_per_rev=0",
                                          "robot.encoder.noise_rad=0",
                                          "robot.encoder.backlash_rad=0"])
    truth, s = _fk_stream(cfg, seed=3)
    world = truth.world
    err = np.asarray(world.config.arm_dh_error)
    # the drawn deviation: the configured sigmas (1 mm / 1 mrad), from the 'robot' stream
    np.testing.assert_allclose(err, draw_dh_error(cfg.robot.kinematic_error,
                                                  _rngs(3)["robot"]), atol=0)
    assert 1e-4 < np.abs(err).max() < 5e-3
    # the world moves the TRUE arm: true-DH FK of the joints == MuJoCo's camera pose
    from simcalib.world.robot_error import arm_state
    adr, T_wb = arm_state(world)
    fr = world.frames("cam_a")
    q = fr.qpos[:, adr]
    T_true = T_wb @ dh_fk(q, true_dh(err))
    assert np.abs(T_true - fr.T_world_cam).max() < 1e-9
    # robot_fk reports the NOMINAL FK of the same joints: exactly the DH error's effect
    T_nom = T_wb @ dh_fk(q, UR5E_DH)
    np.testing.assert_allclose(s.T_world_cam, T_nom[s.frame_index], atol=1e-12)
    dt = translation_error_m(s.T_world_cam, fr.T_world_cam[s.frame_index])
    assert 5e-4 < np.median(dt) < 2e-2                 # mm-level flange error
    assert (rotation_error_rad(s.T_world_cam, fr.T_world_cam[s.frame_index]) > 1e-4).all()


def test_encoder_noise_quantisation_and_backlash():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 201)
    q = np.column_stack([np.sin(2 * np.pi * t), 0.3 * t, np.zeros_like(t)])
    res = 2 * np.pi / 4096
    r = encoder_readings(q, EncoderConfig(counts_per_rev=4096), rng)
    np.testing.assert_allclose(r / res, np.round(r / res), atol=1e-9)
    assert np.abs(r - q).max() <= 0.5 * res + 1e-12
    b = 0.01
    r = encoder_readings(q, EncoderConfig(backlash_rad=b), rng)
    d = r - q
    up = np.diff(q[:, 0], prepend=q[0, 0] - 1) > 0
    np.testing.assert_allclose(d[1:, 0][up[1:]], 0.5 * b)
    np.testing.assert_allclose(d[1:, 0][~up[1:]], -0.5 * b)
    np.testing.assert_allclose(d[:, 1], 0.5 * b)              # always moving up
    np.testing.assert_allclose(d[:, 2], 0.5 * b)              # never moves: +b/2
    r = encoder_readings(np.zeros((20000, 2)), EncoderConfig(noise_rad=1e-4), rng)
    assert abs(r.std() - 1e-4) < 5e-6
    with pytest.raises(ValueError, match="counts_per_rev"):
        EncoderConfig(counts_per_rev=-1)
    with pytest.raises(ValueError, match="sigma_d_m"):
        KinematicErrorConfig(sigma_d_m=-1.0)


def test_robot_fk_needs_the_builtin_arm():
    cfg = load_config("planar", ["source=ground_truth", "streams.a.source=robot_fk", *SMALL])
    rngs = _rngs()
    truth = build_truth(cfg, rngs)
    with pytest.raises(ValueError, match="robot_fk needs world.platform='arm'"):
        get_source("robot_fk").measure(truth, cfg, rngs[get_source("robot_fk").info.rng_stream], ("cam_a",))


# -------------------------------------------------------------------- stream sources
def test_per_stream_source_selection():
    cfg = load_config("handeye", SMALL)
    assert camera_sources(cfg, "sim") == {"cam_a": "robot_fk", "cam_b": "aruco"}
    cfg = load_config("3d", ["streams.b.source=noisy"])
    assert camera_sources(cfg, "sim") == {"cam_a": "aruco", "cam_b": "noisy"}
    with pytest.raises(ConfigError, match=r"streams.a.source must be one of .*"
                                          r"did you mean 'robot_fk'.*received 'robotfk'"):
        load_config("3d", ["streams.a.source=robotfk"])
    with pytest.raises(ConfigError, match="streams.a.source must be null in a synthetic scenario"):
        load_config("random", ["streams.a.source=noisy"])


# --------------------------------------------------------------------------- outliers
def _stream(n=50, seed=0):
    rng = np.random.default_rng(seed)
    from simcalib.geometry import random_rotation_matrices
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = random_rotation_matrices(rng, (n,))
    T[:, :3, 3] = rng.uniform(-1, 1, (n, 3))
    idx = np.arange(0, 2 * n, 2)
    return PoseStream(camera="cam_a", source="noisy", frame_index=idx,
                      timestamp_s=idx / 10.0, T_world_cam=T, n_frames=2 * n)


@pytest.mark.parametrize("kind", ["random_pose", "swapped_frames", "mixed"])
def test_injected_outliers_counts_and_labels(kind):
    s = _stream()
    cfg = OutliersConfig(fraction=0.2, kind=kind, apply_to=("a",))
    out, rep = inject_outliers({"cam_a": s}, cfg, np.random.default_rng(1))
    o = out["cam_a"]
    lab = rep["cam_a"]
    assert lab["n_poses"] == 50 and lab["n_outliers"] in (10, 11)   # +1: a swap partner
    changed = np.any(np.abs(o.T_world_cam - s.T_world_cam) > 0, axis=(1, 2))
    labelled = np.isin(s.frame_index, [d["frame_index"] for d in lab["labels"]])
    assert np.array_equal(changed, labelled)                 # labels = exactly the changes
    assert np.array_equal(o.info["outlier"], labelled)
    assert sum(lab["by_kind"].values()) == lab["n_outliers"]
    assert all(d["kind"] in ("random_pose", "swapped_frames", "flipped_marker")
               for d in lab["labels"])
    if kind != "mixed":
        assert lab["by_kind"][kind] == lab["n_outliers"]
    sw = [d["frame_index"] for d in lab["labels"] if d["kind"] == "swapped_frames"]
    for f in sw:          # a swapped frame carries another (swapped) frame's clean pose
        k = int(np.flatnonzero(s.frame_index == f)[0])
        src = [j for j in np.flatnonzero(np.isin(s.frame_index, sw))
               if np.array_equal(o.T_world_cam[k], s.T_world_cam[j])]
        assert src and src[0] != k
    for d in lab["labels"]:
        k = int(np.flatnonzero(s.frame_index == d["frame_index"])[0])
        assert d["timestamp_s"] == s.timestamp_s[k]
        assert d["rotation_deg"] > 0 or d["translation_m"] > 0
    assert np.array_equal(o.timestamp_s, s.timestamp_s)
    off, rep0 = inject_outliers({"cam_a": s}, OutliersConfig(), np.random.default_rng(1))
    assert off["cam_a"] is s and rep0["enabled"] is False


def test_flipped_marker_mirrors_the_tilt_about_the_line_of_sight():
    Tm = np.eye(4)
    Tm[:3, :3] = np.column_stack([[0, -1, 0], [0, 0, 1], [-1, 0, 0]])   # faces -x (its z)
    Tm[:3, 3] = [2.0, 0.0, 1.0]
    field = MarkerField("DICT_4X4_50", np.array([0]), 0.2, Tm[None])
    from simcalib.geometry import matrix_from_rotvec
    T = np.eye(4)
    T[:3, :3] = np.array([[0, -1, 0], [0, 0, -1], [1, 0, 0]]).T    # looking along +x
    T[:3, :3] = matrix_from_rotvec(np.array([0, 0, 0.3])) @ T[:3, :3]
    T[:3, 3] = Tm[:3, 3] - 1.2 * T[:3, 2]                          # marker on the axis
    T[:3, 3] += np.array([0.0, 0.8, 0.0])                          # ... seen obliquely
    F = flipped_marker_poses(T[None], field)[0]
    p_c, p_f = (invert_transform(T) @ Tm)[:3, 3], (invert_transform(F) @ Tm)[:3, 3]
    np.testing.assert_allclose(p_c, p_f, atol=1e-12)               # same place in the image
    n_c, n_f = (invert_transform(T) @ Tm)[:3, 2], (invert_transform(F) @ Tm)[:3, 2]
    r = -p_c / np.linalg.norm(p_c)
    np.testing.assert_allclose(n_f, 2 * (n_c @ r) * r - n_c, atol=1e-12)   # mirrored tilt
    assert 30 < np.rad2deg(rotation_error_rad(F, T)) < 60        # twice the ~21° tilt


def test_outlier_config_validation():
    with pytest.raises(ValueError, match=r"fraction must be <= 0.5.*received 0.7"):
        OutliersConfig(fraction=0.7)
    with pytest.raises(ValueError, match="kind must be one of"):
        OutliersConfig(kind="flip")
    with pytest.raises(ValueError, match="apply_to must be"):
        OutliersConfig(apply_to=("c",))


# ----------------------------------------------------------------------------- clocks
@pytest.mark.slow
def test_clocks_per_stream_rates_offsets_and_drift():
    from simcalib.sources.corruption import clock_report
    cfg = load_config("planar", ["source=ground_truth", *SMALL_ANY_DURATION, "world.duration_s=3",
                                 "world.cam_a.fps=30", "world.cam_b.fps=20",
                                 "world.cam_a.clock_offset_s=-0.02",
                                 "world.cam_b.clock_offset_s=0.045",
                                 "world.cam_b.clock_drift_ppm=150",
                                 "world.cam_b.capture_offset_s=0.013"])
    truth = build_truth(cfg, _rngs())
    w = truth.world
    a, b = w.frames("cam_a"), w.frames("cam_b")
    assert (a.n_frames, b.n_frames) == (91, 61)
    np.testing.assert_allclose(np.diff(a.time_s), 1 / 30, atol=1e-12)
    np.testing.assert_allclose(b.time_s, np.arange(61) / 20 + 0.013, atol=1e-12)
    # recorded stamps are the sensor's clock; the truth keeps true times
    np.testing.assert_allclose(b.stamp_s, b.time_s * (1 + 150e-6) + 0.045, atol=1e-12)
    rep = clock_report(w)
    assert rep["cam_a"]["recovered_offset_s"] == pytest.approx(-0.02, abs=1e-9)
    assert rep["cam_b"]["recovered_offset_s"] == pytest.approx(0.045, abs=1e-9)
    assert rep["cam_b"]["recovered_drift_ppm"] == pytest.approx(150, abs=1e-3)
    assert rep["cam_a"]["fps"] == 30 and rep["cam_b"]["mean_period_s"] == pytest.approx(0.05)
    # with jitter, the recovered offset still matches within the jitter's reach
    cfg = load_config("planar", ["source=ground_truth", *SMALL_ANY_DURATION, "world.duration_s=10",
                                 "world.cam_b.clock_offset_s=0.03",
                                 "world.cam_b.stamp_jitter_s=0.002"])
    rep = clock_report(build_truth(cfg, _rngs()).world)
    assert rep["cam_b"]["recovered_offset_s"] == pytest.approx(0.03, abs=1.5e-3)
    assert rep["cam_b"]["recovered_jitter_s"] == pytest.approx(0.002, rel=0.4)


# -------------------------------------------------------------------------- scenarios
def _run(tmp_path, name, extra=()):
    import simcalib
    return simcalib.run(load_config(name, [*SMALL_ANY_DURATION, "world.duration_s=6",
                                           f"output={tmp_path / name}", *extra]),
                        echo=False)


@pytest.mark.slow
def test_handeye_runs_small_and_recovers_T_flange_cam(tmp_path):
    # the marker wall: at the small runs' 320x240 the handeye ChArUco's 5x5 markers are
    # ~2 px per cell (tests/test_targets_boards.py covers the board at the scenario's 640x480)
    r = _run(tmp_path, "handeye", ["solvers=[dqopt,daniilidis]", "world.target=marker_wall"])
    assert r.status == "complete"
    doc = json.loads(r.results_path.read_text())
    assert doc["stream_sources"] == {"cam_a": "robot_fk", "cam_b": "aruco"}
    cfg = r.config.world.rig
    np.testing.assert_allclose(r.X_true, cfg.T_a_b(), atol=1e-12)      # X = T_flange_cam
    assert np.abs(np.asarray(doc["robot"]["dh_error"])).max() > 1e-4
    fk = doc["robot"]["fk_error"]["cam_a"]
    assert 5e-4 < fk["fk_translation_error_m_median"] < 2e-2
    s = r.solver("dqopt")
    assert s.success and not s.degenerate
    assert s.rotation_error_deg < 1.0 and s.translation_error_m < 0.02


@pytest.mark.slow
def test_scara_is_flagged_degenerate_along_the_vertical(tmp_path):
    r = _run(tmp_path, "scara", ["solvers=[dqopt]"])
    s = r.solver("dqopt")
    assert s.success and s.degenerate
    axes = s.undetermined_translation_axes
    assert axes is not None and axes.shape[0] == 1
    # the vertical in the flange frame: flange y = -world z at home
    assert abs(abs(axes[0][1]) - 1.0) < 0.05
    assert s.translation_error_determined_m < 0.02


@pytest.mark.slow
def test_same_seed_same_results_with_robot_error_outliers_and_clocks(tmp_path):
    extra = ["solvers=[dqopt]", "outliers.fraction=0.15", "world.cam_b.fps=10",
             "world.target=marker_wall",           # 320x240: see the test above
             "pairing.step=1",
             "world.cam_b.clock_offset_s=0.02", "world.cam_b.stamp_jitter_s=0.001"]
    docs = []
    for i in range(2):
        r = _run(tmp_path / str(i), "handeye", extra)
        d = json.loads(r.results_path.read_text())
        for k in ("timing_s", "config"):
            d.pop(k)
        for v in d["solvers"].values():
            v.pop("runtime_s", None)
            for sw in v.get("sweep", []):
                sw.pop("runtime_s", None)
        docs.append(d)
    assert docs[0]["outliers"]["cam_a"]["n_outliers"] > 0
    assert docs[0]["outliers"]["pairs"]["n_pairs"] > 0
    assert docs[0] == docs[1]
    tum = [(tmp_path / str(i) / "handeye" / "tum" / "cam_b_aruco.tum").read_text()
           for i in range(2)]
    assert tum[0] == tum[1]
    gt = np.loadtxt(tmp_path / "0" / "handeye" / "tum" / "cam_b_ground_truth.tum")
    meas = np.loadtxt(tmp_path / "0" / "handeye" / "tum" / "cam_b_aruco.tum")
    n = min(len(gt), len(meas))
    assert abs(np.median(meas[:n, 0] - gt[:n, 0]) - 0.02) < 0.003   # stamps vs true times
