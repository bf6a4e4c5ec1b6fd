"""Visual pose streams end to end on a small self-built world, rendering backend selection,
and VisionConfig validation. Rendering tests skip only when no OpenGL backend exists."""

import os
import subprocess
import sys
import dataclasses
from types import SimpleNamespace

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from simcalib import geometry as g  # noqa: E402
from simcalib.targets.markers import MarkerField, marker_png  # noqa: E402
from simcalib.streams import CameraFrames, CameraIntrinsics, Trajectory  # noqa: E402
from simcalib.sources.vision.config import VisionConfig  # noqa: E402
from simcalib.sources.vision.stream import visual_streams  # noqa: E402

W, H, FOVY = 640, 480, 60.0


def _mini_world(n_frames=12, look_away=(3,), delivered=None, stamps=None):
    """Wall of 3x4 markers (10 cm) in the plane z=0 facing +z; a mocap rig with cam_a and
    cam_b (10 cm apart, 11 deg apart) moving about 1 m above it; frames in ``look_away``
    point the rig at the empty sky (no marker in view)."""
    import mujoco
    side, pix, quiet = 0.1, 240, 40
    half = side / 2 * (pix + 2 * quiet) / pix
    assets, mats, geoms, Ts, ids = {}, [], [], [], []
    for i in range(3):
        for j in range(4):
            mid = 20 + 4 * i + j
            pos = np.array([0.3 * (j - 1.5), 0.3 * (i - 1), 0.0])
            assets[f"m{mid}.png"] = marker_png(mid, pix, quiet_zone_px=quiet)
            mats.append(f'<texture name="t{mid}" type="2d" file="m{mid}.png"/><material '
                        f'name="mat{mid}" texture="t{mid}" specular="0" shininess="0" '
                        f'emission="0.3"/>')
            geoms.append(f'<geom type="plane" size="{half} {half} 0.01" pos="{pos[0]} {pos[1]} '
                         f'0" material="mat{mid}"/>')
            T = np.eye(4)
            T[:3, 3] = pos
            Ts.append(T)
            ids.append(mid)
    xml = f"""<mujoco><statistic extent="2" center="0 0 0"/>
      <visual><global offwidth="{W}" offheight="{H}"/></visual>
      <asset>{''.join(mats)}</asset>
      <worldbody><light pos="0 0 3" dir="0 0 -1" directional="true"/>{''.join(geoms)}
        <body name="rig" mocap="true"><camera name="cam_a" fovy="{FOVY}"/>
          <camera name="cam_b" fovy="{FOVY}" pos="0.1 0 0" euler="0 0.2 0"/></body>
      </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml, assets)
    data = mujoco.MjData(model)
    t = np.arange(n_frames) / 10.0
    pos = np.stack([0.2 * np.sin(t), 0.15 * np.cos(0.7 * t), 1.0 + 0.2 * np.sin(0.5 * t)], -1)
    rv = np.stack([0.2 * np.sin(0.8 * t), 0.15 * np.cos(0.6 * t), 0.3 * np.sin(0.3 * t)], -1)
    rv[list(look_away)] = [np.pi, 0.0, 0.0]
    q = g.quat_wxyz_from_xyzw(g.quat_from_matrix(g.matrix_from_rotvec(rv)))
    T_w = {c: [] for c in ("cam_a", "cam_b")}
    for k in range(n_frames):
        data.mocap_pos[0], data.mocap_quat[0] = pos[k], q[k]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        for c in T_w:
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, c)
            T_w[c].append(g.transform_from_rotation_translation(
                data.cam_xmat[i].reshape(3, 3) @ np.diag([1.0, -1.0, -1.0]), data.cam_xpos[i]))

    class Frames(CameraFrames):  # the world's SimCameraFrames carries these two records
        pass

    frames = {}
    for c in T_w:
        fr = Frames(c, t.copy(), np.stack(T_w[c]), np.zeros((n_frames, 0)),
                    pos[:, None].copy(), q[:, None].copy())
        if delivered is not None:
            object.__setattr__(fr, "delivered", np.asarray(delivered, bool))
        if stamps is not None:
            object.__setattr__(fr, "stamp_s", np.asarray(stamps, float))
        frames[c] = fr
    traj = Trajectory(frames["cam_a"], frames["cam_b"],
                      g.invert_transform(frames["cam_a"].T_world_cam[0])
                      @ frames["cam_b"].T_world_cam[0])
    return SimpleNamespace(
        model=model, camera_names=("cam_a", "cam_b"),
        intrinsics={c: CameraIntrinsics.from_fovy(W, H, FOVY) for c in T_w},
        marker_field=MarkerField("DICT_4X4_250", np.array(ids), side, np.stack(Ts)),
        trajectory=traj)


@pytest.fixture(scope="module")
def world(gl):
    return _mini_world()


@pytest.fixture(scope="module")
def run_1(world):
    cfg = VisionConfig(noise_std=3.0, blur_sigma_px=0.6, log_every=4)
    return visual_streams(world, cfg, np.random.default_rng(7), workers=1)


@pytest.mark.slow
def test_visual_poses_match_ground_truth_and_drop_is_counted(world, run_1):
    streams, log = run_1
    for cam in world.camera_names:
        st = streams[cam]
        fr = getattr(world.trajectory, cam)
        assert st.source == "visual" and st.n_frames == 12
        assert 3 not in st.frame_index.tolist()             # looking at the sky: dropped
        assert st.n_used == 11 and st.n_dropped == 1
        assert st.drop_reasons == {"no_markers": 1}
        T_true = fr.T_world_cam[st.frame_index]
        assert np.median(g.translation_error_m(st.T_world_cam, T_true)) < 1e-3
        assert np.rad2deg(g.rotation_error_rad(st.T_world_cam, T_true)).max() < 0.1
        np.testing.assert_array_equal(st.timestamp_s, fr.time_s[st.frame_index])
        assert (st.info["n_markers"] >= 4).all() and (st.info["reproj_rmse_px"] < 0.5).all()
        assert st.info["n_markers"].shape == st.frame_index.shape


@pytest.mark.slow
def test_visual_log_is_plain_reviewable_data(world, run_1):
    streams, log = run_1
    rec = log.frames["cam_a"]
    assert len(rec) == 12 and [f.frame_index for f in rec] == list(range(12))
    assert rec[3].status == "no_markers" and rec[3].T_world_cam is None and rec[3].ids.size == 0
    ok = rec[0]
    assert ok.status == "ok" and ok.corners_px.shape == (ok.ids.size, 4, 2)
    assert set(ok.ids_used.tolist()) <= set(ok.ids.tolist())
    assert sorted(log.images_jpeg["cam_b"]) == [0, 4, 8]
    img = log.image("cam_b", 4)
    assert img.shape == (H, W) and img.dtype == np.uint8
    assert isinstance(log.images_jpeg["cam_b"][4], bytes)
    with pytest.raises(KeyError, match="no logged image"):
        log.image("cam_b", 5)
    s = log.summary()
    assert s["cam_a"]["n_used"] == 11 and s["cam_a"]["drop_reasons"] == {"no_markers": 1}
    np.testing.assert_allclose(log.reproj_rmse_px("cam_a"), streams["cam_a"].info["reproj_rmse_px"])


@pytest.mark.slow
def test_same_seed_same_streams_and_seed_matters(world, run_1):
    cfg = VisionConfig(noise_std=3.0, blur_sigma_px=0.6, log_every=4)
    again, _ = visual_streams(world, cfg, np.random.default_rng(7), workers=1)
    other, _ = visual_streams(world, cfg, np.random.default_rng(8), workers=1)
    for cam in world.camera_names:
        np.testing.assert_array_equal(again[cam].T_world_cam, run_1[0][cam].T_world_cam)
        np.testing.assert_array_equal(again[cam].frame_index, run_1[0][cam].frame_index)
        assert not np.array_equal(other[cam].T_world_cam, run_1[0][cam].T_world_cam)


@pytest.mark.slow
def test_worker_count_does_not_change_results(world, run_1):
    cfg = VisionConfig(noise_std=3.0, blur_sigma_px=0.6, log_every=4)
    par, log = visual_streams(world, cfg, np.random.default_rng(7), workers=2)
    assert log.timing["workers"] == 2 and log.timing["processes"] == 2  # both rendered
    for cam in world.camera_names:
        np.testing.assert_array_equal(par[cam].T_world_cam, run_1[0][cam].T_world_cam)
        np.testing.assert_array_equal(par[cam].info["reproj_rmse_px"],
                                      run_1[0][cam].info["reproj_rmse_px"])
        assert par[cam].drop_reasons == run_1[0][cam].drop_reasons
        assert log.images_jpeg[cam] == run_1[1].images_jpeg[cam]


@pytest.mark.slow
def test_worker_processes_render_identical_images(world):
    """Spawned worker processes (this process not rendering) give the same pixels."""
    from simcalib.world.render import RenderSettings
    from simcalib.world.render_map import FrameJob, render_map
    fr = world.trajectory.cam_b
    jobs = [FrameJob("cam_b", k, None, fr.mocap_pos[k], fr.mocap_quat_wxyz[k])
            for k in range(6)]
    here, _ = render_map(world.model, RenderSettings(), jobs, None, workers=1)
    there, _ = render_map(world.model, RenderSettings(), jobs, None, workers=2, chunk_size=2,
                          use_this_process=False)
    assert len(there) == 6 and all(np.array_equal(a, b) for a, b in zip(here, there))
    assert here[0].shape == (H, W, 3) and here[0].dtype == np.uint8


@pytest.mark.slow
def test_coarse_meshes_do_not_move_marker_corners(world):
    from simcalib.targets.markers import detect_markers
    from simcalib.world.render import CameraRenderer, RenderSettings
    fr = world.trajectory.cam_a
    corners = []
    for coarse in (True, False):
        with CameraRenderer(world.model, RenderSettings(coarse_meshes=coarse)) as r:
            det = detect_markers(r.render("cam_a", None, fr.mocap_pos[5], fr.mocap_quat_wxyz[5]))
        corners.append(det.corners_px[np.argsort(det.ids)])
    assert corners[0].shape[0] >= 6
    np.testing.assert_allclose(corners[0], corners[1], atol=0.02)


def test_undelivered_frames_are_not_rendered_and_counted(gl):
    delivered = np.ones(6, bool)
    delivered[[1, 4]] = False
    stamps = np.arange(6) * 0.1 + 0.05
    w = _mini_world(6, look_away=(), delivered=delivered, stamps=stamps)
    streams, log = visual_streams(w, VisionConfig(log_every=0), np.random.default_rng(0),
                                  workers=1)
    st = streams["cam_a"]
    assert st.frame_index.tolist() == [0, 2, 3, 5]
    assert st.drop_reasons == {"frame_dropped": 2} and st.n_dropped == 2
    np.testing.assert_allclose(st.timestamp_s, stamps[[0, 2, 3, 5]])
    assert log.frames["cam_a"][1].status == "frame_dropped" and log.images_jpeg["cam_a"] == {}


@pytest.mark.slow
def test_image_knobs_degrade_but_keep_poses(world):
    """Strong blur and noise: still a pose on every marker frame, larger reprojection error."""
    sharp, _ = visual_streams(world, VisionConfig(log_every=0), np.random.default_rng(1),
                              workers=1)
    rough, _ = visual_streams(world, VisionConfig(noise_std=8.0, blur_sigma_px=1.5,
                                                  log_every=0),
                              np.random.default_rng(1), workers=1)
    a, b = sharp["cam_a"], rough["cam_a"]
    assert b.n_used >= a.n_used - 1
    assert np.median(b.info["reproj_rmse_px"]) > 1.5 * np.median(a.info["reproj_rmse_px"])
    T_true = world.trajectory.cam_a.T_world_cam[b.frame_index]
    assert np.median(g.translation_error_m(b.T_world_cam, T_true)) < 3e-3


def test_resolution_and_fovy_override(world):
    cfg = VisionConfig(width=320, height=240, fovy_deg=70.0, log_every=6)
    streams, log = visual_streams(world, cfg, np.random.default_rng(0), workers=1)
    assert log.intrinsics["cam_a"] == CameraIntrinsics.from_fovy(320, 240, 70.0)
    assert log.image("cam_a", 0).shape == (240, 320)
    st = streams["cam_a"]
    assert st.n_used >= 10
    T_true = world.trajectory.cam_a.T_world_cam[st.frame_index]
    assert np.median(g.translation_error_m(st.T_world_cam, T_true)) < 3e-3


# ---------------------------------------------------------------------- config / input
def test_vision_config_validation():
    with pytest.raises(ValueError, match="noise_std"):
        VisionConfig(noise_std=-1.0)
    with pytest.raises(ValueError, match="blur_sigma_px"):
        VisionConfig(blur_sigma_px=float("nan"))
    with pytest.raises(ValueError, match="width"):
        VisionConfig(width=0)
    with pytest.raises(ValueError, match="corner_refinement"):
        VisionConfig(corner_refinement="magic")
    with pytest.raises(ValueError, match="min_markers"):
        VisionConfig(min_markers=0)
    with pytest.raises(TypeError, match="refine"):
        VisionConfig(refine="yes")
    with pytest.raises(ValueError, match=r"unknown VisionConfig keys \['nosie_std'\]"):
        VisionConfig.from_dict({"nosie_std": 1.0})
    assert VisionConfig.from_dict({"noise_std": 2.0}).noise_std == 2.0
    with pytest.raises(TypeError):
        VisionConfig(nosie_std=1.0)


def test_visual_streams_input_errors(world):
    with pytest.raises(TypeError, match="rng"):
        visual_streams(world, VisionConfig(), rng=42)
    with pytest.raises(TypeError, match="VisionConfig"):
        visual_streams(world, {"noise_std": 1}, np.random.default_rng(0))
    with pytest.raises(TypeError, match="marker_field"):
        visual_streams(SimpleNamespace(model=None, camera_names=(), intrinsics={},
                                       trajectory=None), VisionConfig(), np.random.default_rng(0))
    with pytest.raises(ValueError, match="workers"):
        visual_streams(world, VisionConfig(), np.random.default_rng(0), workers=0)


def test_state_that_misses_ground_truth_is_rejected(world):
    """Rendering a state that does not reproduce the trajectory's pose is an error."""
    import dataclasses
    fr = world.trajectory.cam_b
    T = fr.T_world_cam.copy()
    T[2, 0, 3] += 0.01
    bad = SimpleNamespace(**vars(world))
    bad.trajectory = dataclasses.replace(world.trajectory,
                                         cam_b=dataclasses.replace(fr, T_world_cam=T))
    with pytest.raises(ValueError, match="cam_b frame 2 puts the camera 0.01 m"):
        visual_streams(bad, VisionConfig(log_every=0), np.random.default_rng(0), workers=1)


def test_inconsistent_world_intrinsics_are_rejected(world):
    bad = SimpleNamespace(**vars(world))
    bad.intrinsics = dict(world.intrinsics, cam_b=CameraIntrinsics.from_fovy(W, H, 50.0))
    with pytest.raises(ValueError, match="not the pinhole MuJoCo renders"):
        visual_streams(bad, VisionConfig(), np.random.default_rng(0), workers=1)


# ------------------------------------------------------------------------- rendering
def test_backend_selection_and_error_message():
    from simcalib.world.render_backend import RenderBackendError, available_backend

    def fail(*_):
        return "EGL_NOT_INITIALIZED"

    with pytest.raises(RenderBackendError) as info:
        available_backend(probe_inprocess=fail, probe_subprocess=fail)
    msg = str(info.value)
    for pkg in ("libegl1", "libgl1", "libegl-mesa0", "libgl1-mesa-dri", "libosmesa6"):
        assert pkg in msg
    assert "MUJOCO_GL=egl: EGL_NOT_INITIALIZED" in msg and "MUJOCO_GL=osmesa" in msg
    # in-process backend broken, osmesa works in a fresh interpreter -> use it in workers
    assert available_backend(probe_inprocess=fail,
                             probe_subprocess=lambda b: None if b == "osmesa" else "no") == \
        ("osmesa", False)
    assert available_backend(probe_inprocess=lambda: None, probe_subprocess=fail)[1] is True


@pytest.mark.slow
def test_headless_glfw_gives_clear_error_and_workers_fall_back(gl):
    """mujoco imported with a backend that cannot work headless (glfw, no DISPLAY): the
    renderer raises RenderBackendError naming the packages, and render_map still renders
    through a fallback backend in a worker process."""
    code = """
import numpy as np, mujoco
from simcalib.world.render import CameraRenderer, RenderSettings
from simcalib.world.render_backend import RenderBackendError, available_backend
from simcalib.world.render_map import FrameJob, render_map
m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><light pos="0 0 2"/>'
    '<geom type="box" size=".2 .2 .2" rgba="1 1 1 1"/><camera name="c" pos="0 0 1"/>'
    '</worldbody></mujoco>')
try:
    CameraRenderer(m)
    print("RENDERED")
except RenderBackendError as e:
    print("ERROR:", e)
print("BACKEND:", available_backend())
out, _ = render_map(m, RenderSettings(width=64, height=48), [FrameJob("c", 0, None, None, None)],
                    None, workers=1)
print("MEAN:", out[0].mean())
"""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "glfw"
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=180, cwd=root)
    out = proc.stdout
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "ERROR:" in out and "libegl1" in out and "libosmesa6" in out, out
    assert "BACKEND: ('egl', False)" in out or "BACKEND: ('osmesa', False)" in out, out
    mean = float(out.split("MEAN:")[1].strip())
    assert mean > 1.0  # something visible was rendered by the worker


def test_renderer_does_not_modify_callers_model(world):
    from simcalib.world.render import CameraRenderer, RenderSettings
    before = (world.model.vis.quality.offsamples, float(world.model.cam_fovy[0]))
    with CameraRenderer(world.model, RenderSettings(msaa_samples=0,
                                                    fovy_deg={"cam_a": 45.0})) as r:
        assert r.model.cam_fovy[r.camera_id("cam_a")] == 45.0
        with pytest.raises(ValueError, match="cameras"):
            r.camera_id("nope")
        with pytest.raises(ValueError, match="mocap_pos"):
            r.render("cam_a", mocap_pos=np.zeros((2, 3)))
    assert (world.model.vis.quality.offsamples, float(world.model.cam_fovy[0])) == before


# ------------------------------------------------------------------------- benchmark
@pytest.mark.slow
def test_vision_bench_cli(gl, tmp_path, capsys):
    import json

    from simcalib.studies.bench.vision import main
    out = tmp_path / "bench.json"
    assert main(["--paths", "circular", "--duration", "0.3", "--fps", "10", "--workers", "1",
                 "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "circular" in text and "camera frames/s" in text
    res = json.loads(out.read_text())["results"][0]
    assert res["path"] == "circular" and res["platform"] == "cart"
    for cam in ("cam_a", "cam_b"):
        c = res["cameras"][cam]
        assert c["n_frames"] == 4 and c["n_used"] == 4
        assert c["median_mm"] < 5.0 and c["median_deg"] < 0.5
    assert res["timing"]["camera_frames"] == 8 and res["timing"]["cpu_ms_per_frame"] > 0
    assert main(["--paths", "nope"]) == 2
    assert "unknown path" in capsys.readouterr().err
    assert main(["--paths", "circular", "--noise", "-1"]) == 2
    assert "noise_std" in capsys.readouterr().err
    with pytest.raises(SystemExit) as ex:
        main(["--help"])
    assert ex.value.code == 0


def test_vision_modules_import_light():
    """Importing the vision modules loads neither mujoco nor cv2 (lazy heavy imports)."""
    code = ("import sys, simcalib.sources.vision.stream, simcalib.world.render, "
            "simcalib.world.render_map, simcalib.targets.markers, simcalib.targets.marker_pnp, "
            "simcalib.studies.bench.vision; print(sorted(m for m in ('cv2', 'mujoco') if m in sys.modules))")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=root + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120, cwd=root)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


# ------------------------------------------------------------ backend choice, Ctrl-C, progress
def _run_py(code, env_update, drop=(), timeout=180):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env.update(env_update)
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-W", "always", "-c", code], env=env,
                          capture_output=True, text=True, timeout=timeout, cwd=root)


@pytest.mark.slow
def test_mujoco_gl_is_decided_by_render_not_at_import():
    """No simcalib module sets MUJOCO_GL at import; import_mujoco decides it (egl)."""
    code = ("import os, simcalib, simcalib.world, simcalib.sources.vision.stream, simcalib.pipeline.stages, "
            "simcalib.cli, simcalib.world.render, simcalib.world.render_map, simcalib.targets.markers\n"
            "print('SET' if 'MUJOCO_GL' in os.environ else 'UNSET')\n"
            "from simcalib.world.render_backend import import_mujoco; import_mujoco()\n"
            "print(os.environ['MUJOCO_GL'])")
    out = _run_py(code, {}, drop=("MUJOCO_GL", "PYOPENGL_PLATFORM"))
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["UNSET", "egl"]


def test_mujoco_gl_bogus_lists_valid_values():
    code = ("from simcalib.world.render_backend import import_mujoco, RenderBackendError\n"
            "try:\n    import_mujoco()\nexcept RenderBackendError as e:\n    print('ERR', e)")
    out = _run_py(code, {"MUJOCO_GL": "bogus"})
    assert out.returncode == 0, out.stderr
    assert "ERR" in out.stdout and "'bogus'" in out.stdout
    for name in ("egl", "osmesa", "glfw"):
        assert name in out.stdout


def test_mujoco_gl_osmesa_without_library_falls_back_to_egl(gl):
    code = ("import simcalib.world.render_backend as r\nr._osmesa_available = lambda: False\n"
            "m = r.import_mujoco()\nimport os\nprint('GL', os.environ['MUJOCO_GL'])\n"
            "print('BACKEND', r.loaded_backend())")
    out = _run_py(code, {"MUJOCO_GL": "osmesa"})
    assert out.returncode == 0, out.stderr
    assert "GL egl" in out.stdout and "BACKEND egl" in out.stdout
    assert "libosmesa6" in out.stderr and "falling back" in out.stderr


class _InterruptAfter:
    """Per-frame function raising KeyboardInterrupt at one frame (simulated Ctrl-C)."""

    def __init__(self, k):
        self.k = k

    def __call__(self, img, job):
        if job.frame_index == self.k:
            raise KeyboardInterrupt
        return float(img.mean())


@pytest.mark.slow
def test_render_interrupt_keeps_done_frames_and_progress_reports(world):
    from simcalib.world.render import RenderSettings
    from simcalib.world.render_map import FrameJob, LineProgress, RenderInterrupted, render_map
    fr = world.trajectory.cam_a
    jobs = [FrameJob("cam_a", k, None, fr.mocap_pos[k], fr.mocap_quat_wxyz[k])
            for k in range(6)]
    seen = []
    out, tim = render_map(world.model, RenderSettings(width=64, height=48), jobs, None,
                          workers=1, progress=lambda n, t: seen.append((n, t)))
    assert seen == [(k, 6) for k in range(1, 7)] and len(out) == 6
    with pytest.raises(RenderInterrupted) as info:
        render_map(world.model, RenderSettings(width=64, height=48), jobs, _InterruptAfter(4),
                   workers=1)
    exc = info.value
    assert isinstance(exc, KeyboardInterrupt) and exc.n_done == 4
    assert all(r is not None for r in exc.results[:4]) and exc.results[4:] == [None, None]
    import io
    buf = io.StringIO()
    lp = LineProgress("render", every=2, stream=buf)
    for n in range(1, 6):
        lp(n, 5)
    assert buf.getvalue().splitlines()[0].startswith("render: 2/5") and \
        len(buf.getvalue().splitlines()) == 3
    for kw, match in ((dict(workers=True), "workers must be a positive integer"),
                      (dict(chunk_size=True), "chunk_size must be a positive integer; "
                                              "received True"),
                      (dict(chunk_size=0), "chunk_size must be a positive integer")):
        with pytest.raises(ValueError, match=match):
            render_map(world.model, RenderSettings(width=64, height=48), jobs, None, **kw)


def test_visual_streams_interrupt_returns_partial_streams(world, monkeypatch):
    from simcalib.sources.vision.frame import FrameProcessor
    from simcalib.sources.vision.stream import VisualStreamsInterrupted
    orig = FrameProcessor.__call__

    def stop_at_5(self, rgb, job):
        if job.camera == "cam_a" and job.frame_index == 5:
            raise KeyboardInterrupt
        return orig(self, rgb, job)

    monkeypatch.setattr(FrameProcessor, "__call__", stop_at_5)
    with pytest.raises(VisualStreamsInterrupted) as info:
        visual_streams(world, VisionConfig(log_every=0), np.random.default_rng(0), workers=1)
    exc = info.value
    st = exc.streams["cam_a"]
    assert exc.n_done == 5 and st.n_used >= 4 and st.drop_reasons.get("not_rendered", 0) >= 1
    # two image sizes, two render passes: interrupted in the first, the second camera's
    # frames were never rendered (not "dropped" by the sensor)
    from types import SimpleNamespace
    from simcalib.streams import CameraIntrinsics
    mixed = SimpleNamespace(**vars(world))
    mixed.intrinsics = dict(world.intrinsics,
                            cam_b=CameraIntrinsics.from_fovy(W // 2, H // 2, FOVY))
    with pytest.raises(VisualStreamsInterrupted) as info:
        visual_streams(mixed, VisionConfig(log_every=0), np.random.default_rng(0), workers=1)
    st_b = info.value.streams["cam_b"]                 # every frame of cam_b delivered
    assert st_b.drop_reasons == {"not_rendered": world.trajectory.cam_b.n_frames}


def test_visual_streams_refuses_a_non_callable_progress_before_rendering(world):
    with pytest.raises(TypeError, match="progress must be a callable .* received int"):
        visual_streams(world, VisionConfig(log_every=0), np.random.default_rng(0), workers=1,
                       progress=5)


@pytest.mark.slow
def test_ctrl_c_in_worker_pool_prints_no_worker_traceback(gl):
    """SIGINT to the whole process group while worker processes render: the parent stops
    with RenderInterrupted, the workers print nothing."""
    code = """
import os, signal, threading, time, numpy as np, mujoco
from simcalib.world.render import RenderSettings
from simcalib.world.render_map import FrameJob, RenderInterrupted, render_map
m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><light pos="0 0 2"/>'
    '<geom type="box" size=".2 .2 .2"/><camera name="c" pos="0 0 1"/></worldbody></mujoco>')
jobs = [FrameJob("c", k, None, None, None) for k in range(200000)]
threading.Timer(4.0, lambda: os.killpg(os.getpgid(0), signal.SIGINT)).start()
try:
    render_map(m, RenderSettings(width=320, height=240), jobs, None, workers=2, chunk_size=4)
    print("FINISHED")
except RenderInterrupted as e:
    print("INTERRUPTED", e.n_done)
time.sleep(1.0)
"""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=root + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=120, cwd=root, start_new_session=True)
    assert "INTERRUPTED" in proc.stdout, (proc.stdout, proc.stderr[-2000:])
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]


@pytest.mark.slow
def test_rig_entropy_keeps_the_rig_and_redraws_the_frame_noise(world):
    """``rig_entropy``: the marker map's survey error and the calibration error are the rig
    of an earlier call (its first number, :func:`rig_entropy_of`); only the per-frame noise
    is the new generator's. Without image noise the poses are then identical; without
    ``rig_entropy`` a new generator is a new rig."""
    from simcalib.sources.vision.stream import rig_entropy_of
    cfg = VisionConfig(map_position_std_m=0.0005, map_rotation_std_deg=0.1,
                       intrinsics_error=(0.01, 2.0, 0.0), log_every=0)
    first, _ = visual_streams(world, cfg, np.random.default_rng(7), workers=1)
    rig = rig_entropy_of(np.random.default_rng(7))
    same, _ = visual_streams(world, cfg, np.random.default_rng(8), workers=1, rig_entropy=rig)
    other, _ = visual_streams(world, cfg, np.random.default_rng(8), workers=1)
    noisy, _ = visual_streams(world, dataclasses.replace(cfg, noise_std=3.0),
                              np.random.default_rng(8), workers=1, rig_entropy=rig)
    for cam in world.camera_names:
        np.testing.assert_array_equal(same[cam].T_world_cam, first[cam].T_world_cam)
        assert not np.allclose(other[cam].T_world_cam, first[cam].T_world_cam, atol=1e-6)
        assert not np.array_equal(noisy[cam].T_world_cam, first[cam].T_world_cam)
        # the rig's error dominates: the noisy frames stay nearer the same rig's poses
        d_noise = g.translation_error_m(noisy[cam].T_world_cam, first[cam].T_world_cam)
        d_rig = g.translation_error_m(other[cam].T_world_cam, first[cam].T_world_cam)
        assert np.median(d_noise) < np.median(d_rig)
    gen = np.random.default_rng(7)
    assert rig_entropy_of(gen) == rig and rig_entropy_of(gen) == rig   # gen not advanced
