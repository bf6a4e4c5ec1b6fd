"""The run recording read back: expected entities per scenario kind, every position within
the scene bounds, the close-up's off-scale / failed / uncertainty handling, the summary,
the layouts; and (where the viewer can run) screenshots checked."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from rrd_reading import chunks, points, solver_stub

from simcalib.cli import main
from simcalib.report.rerun.run_closeup import closeup_bound_m

SIM_SHORT = ("world.duration_s=4", "pairing.step=1", "progress=false",
             "solvers=[dqopt,daniilidis,dq2steps]")


def _world_positions(ents: dict) -> np.ndarray:
    """Positions of everything drawn in world coordinates (children of platform bodies
    and camera images are in their parent's frame and excluded)."""
    pts = []
    for e, cols in ents.items():
        if not e.startswith("/world/") or "/geoms" in e or "/image" in e or e.endswith("/axes"):
            continue
        for c in ("Transform3D:translation", "Points3D:positions", "LineStrips3D:strips",
                  "Boxes3D:centers", "Mesh3D:vertex_positions"):
            if c in cols:
                pts.append(points(cols[c]))
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def _run(tmp_path, scenario, *args):
    out = tmp_path / scenario
    assert main(["run", f"scenario={scenario}", f"output={out}", *args]) == 0
    return out, json.loads((out / "results.json").read_text())


def test_sim_recording_entities_and_bounds(tmp_path):
    out, res = _run(tmp_path, "planar", "source=noisy", *SIM_SHORT)
    ents = chunks(out / "recording.rrd")
    names = set(ents)
    assert {"/world/room/floor", "/world/room/wall_px", "/summary", "/closeup/cam_a",
            "/closeup/true_cam_b", "/pose_error/rotation_deg/cam_a",
            "/pose_error/translation_mm/cam_b"} <= names
    bodies = {e.split("/")[3] for e in names if e.startswith("/world/platform/")}
    cart_body = next(b for b in bodies if b.endswith("cart"))   # MjSpec prefixes: cart_cart
    assert any(b.startswith("rig") for b in bodies), bodies
    cart = ents[f"/world/platform/{cart_body}"]
    assert len(points(cart["Transform3D:translation"])) == res["frames"]["rendered"]
    assert any(e.startswith(f"/world/platform/{cart_body}/geoms/") for e in names)
    assert sum(e.startswith("/world/markers/") for e in names) > 10
    # no image panes' data for a source without images
    assert not any("EncodedImage:blob" in c for c in ents.values())
    # every position in the scene lies in the room (a wild estimate never zooms it out)
    room = res["config"]["world"]["room"]["size_m"]
    p = _world_positions(ents)
    assert p.shape[0] > 100
    assert (np.abs(p[:, 0]) <= room[0] / 2 + 0.1).all() and (np.abs(p[:, 1]) <= room[1] / 2 + 0.1).all()
    assert (p[:, 2] >= -0.1).all() and (p[:, 2] <= room[2] + 0.1).all()
    # the close-up stays within its bound (labels stack a little beyond the estimates)
    bound = closeup_bound_m(np.linalg.norm(np.asarray(res["X_true"])[:3, 3]))
    q = np.concatenate([points(v) for e, cols in ents.items() if e.startswith("/closeup/")
                        for k, v in cols.items() if k in ("Transform3D:translation",
                                                          "Points3D:positions")])
    assert np.linalg.norm(q, axis=1).max() <= 1.5 * bound
    for label, s in res["solvers"].items():
        name = label.replace("+", "_")
        drawn = f"/closeup/estimates/{name}" in names
        far = s["X"] is not None and np.linalg.norm(np.asarray(s["X"])[:3, 3]) > bound
        assert drawn == (s["X"] is not None and not far), label
    view = json.loads((out / "recording_view.json").read_text())
    assert view["kind"] == "sim" and view["images"] is False
    lo, hi = np.array(view["room"])
    assert ((lo <= view["eye"]["position"]) & (view["eye"]["position"] <= hi)).all()
    from rerun.chunk import RrdReader
    assert RrdReader(str(out / "recording.rrd")).blueprints()


def test_synthetic_recording_has_no_room_or_images(tmp_path):
    out, res = _run(tmp_path, "line", "progress=false", "synthetic.num_motions=100",
                    "pairing.n_pairs=30", "solvers=[dqopt,daniilidis]")
    ents = chunks(out / "recording.rrd")
    assert not any(e.startswith(("/world/room", "/world/platform", "/world/markers"))
                   for e in ents)
    assert not any(e.endswith("/image") for e in ents)
    assert {"/world/trajectories/cam_a/ground_truth", "/closeup/true_cam_b",
            "/summary"} <= set(ents)
    text = str(ents["/summary"]["TextDocument:text"])
    assert "| method |" in text and "dqopt" in text
    from simcalib.report.rerun.run import summary_of
    md = summary_of(out / "recording.rrd")
    assert md.startswith("**line**") and "- verdict [" in md
    assert json.loads((out / "recording_view.json").read_text())["kind"] == "synthetic"


@pytest.mark.slow
def test_arm_recording_draws_the_arm_links_and_images(tmp_path):
    out, res = _run(tmp_path, "3d", "world.duration_s=4", "progress=false",
                    "solvers=[dqopt]")
    ents = chunks(out / "recording.rrd")
    links = {e.split("/")[3] for e in ents if e.startswith("/world/platform/")}
    assert {f"link{i}" for i in range(1, 7)} <= {b.split("_")[-1] for b in links}, links
    link2 = next(b for b in links if b.endswith("link2"))
    assert any(k.startswith("Capsules3D") for e, c in ents.items() for k in c
               if e.startswith(f"/world/platform/{link2}/"))
    assert any("EncodedImage:blob" in c for e, c in ents.items() if e == "/world/cam_a/image")
    assert json.loads((out / "recording_view.json").read_text())["images"] is True


def test_closeup_offscale_failed_and_uncertainty(tmp_path):
    from simcalib.report.rerun.run import RunRecorder
    cfg = SimpleNamespace(kind="synthetic", recording=SimpleNamespace(max_images=0,
                                                                      jpeg_quality=70))
    X = np.eye(4)
    X[:3, 3] = [0.0, 0.2, 0.0]
    near = X.copy()
    near[:3, 3] += [0.01, 0.0, 0.0]
    far = X.copy()
    far[:3, 3] = [0.0, 1.7e5, 0.0]
    cov = np.diag([1e-6, 1e-6, 1e-6, 4e-4, 1e-4, np.inf])
    cov[3, 4] = cov[4, 3] = 0.0
    rec = RunRecorder(tmp_path / "r.rrd", cfg)
    rec.log_estimates([solver_stub("good", near, cov=cov), solver_stub("wild", far, trans=1.7e5),
                       solver_stub("broken", None)], X)
    rec.close()
    ents = chunks(tmp_path / "r.rrd")
    assert "/closeup/estimates/good" in ents and "/closeup/estimates/wild" not in ents
    assert not any("broken" in e for e in ents)
    bound = closeup_bound_m(0.2)
    off = [c for e, c in ents.items() if e.startswith("/closeup/offscale/")]
    pos = np.concatenate([points(c["Points3D:positions"]) for c in off])
    np.testing.assert_allclose(np.linalg.norm(pos, axis=1), bound, rtol=1e-6)
    labels = " ".join(str(c.get("Points3D:labels")) for e, c in ents.items()
                      if e.startswith("/closeup/labels/offscale"))
    assert "wild" in labels and "1.7e+07 cm" in labels
    cam_label = str(ents["/closeup/labels/cam_a"]["Points3D:labels"])
    assert "FAILED" in cam_label and "broken" in cam_label
    half = np.sort(points(ents["/closeup/uncertainty/good"]["Ellipsoids3D:half_sizes"])[0])
    # 3 sigma of 1 cm and 2 cm; the undetermined (infinite) axis is no part of the ellipsoid
    np.testing.assert_allclose(half, [1e-4, 0.03, 0.06], rtol=1e-6)
    # ... but an off-scale marker: red arrows along z through the estimate, and a label note
    arrows = ents["/closeup/uncertainty/good/offscale"]
    v = points(arrows["Arrows3D:vectors"])
    assert len(v) == 2 and np.allclose(np.abs(v[:, :2]), 0.0) and (np.abs(v[:, 2]) > 0).all()
    o = points(arrows["Arrows3D:origins"])
    assert (np.linalg.norm(o + v, axis=1) <= bound).all()
    assert any("σ = ∞ along z" in str(c.get("Points3D:labels")) for e, c in ents.items()
               if e.startswith("/closeup/labels/"))


def test_closeup_clips_huge_ellipsoids_inside_the_bound(tmp_path):
    from simcalib.report.rerun.run import RunRecorder
    cfg = SimpleNamespace(kind="synthetic", recording=SimpleNamespace(max_images=0,
                                                                      jpeg_quality=70))
    X = np.eye(4)
    X[:3, 3] = [0.0, 0.2, 0.0]
    # sigma_y = 0.5 m: the 3 sigma half-axis (1.5 m) exceeds the 1 m close-up bound
    cov = np.diag([1e-6, 1e-6, 1e-6, 1e-4, 0.25, 1e-4])
    allinf = np.full((6, 6), np.inf)
    rec = RunRecorder(tmp_path / "r.rrd", cfg)
    rec.log_estimates([solver_stub("wide", X, cov=cov), solver_stub("nothing", X, cov=allinf)], X)
    rec.close()
    ents = chunks(tmp_path / "r.rrd")
    bound = closeup_bound_m(0.2)
    half = points(ents["/closeup/uncertainty/wide"]["Ellipsoids3D:half_sizes"])[0]
    assert np.isclose(half.max(), bound - 0.2) and np.isclose(np.sort(half)[0], 0.03)
    assert "/closeup/uncertainty/wide/offscale" in ents
    # all axes undetermined: no ellipsoid at all, only the off-scale marker
    assert "Ellipsoids3D:half_sizes" not in ents.get("/closeup/uncertainty/nothing", {})
    assert len(points(ents["/closeup/uncertainty/nothing/offscale"]["Arrows3D:vectors"])) == 6
    text = " ".join(str(c.get("Points3D:labels")) for e, c in ents.items()
                    if e.startswith("/closeup/labels/"))
    assert "3σ 1.5 m along y: off-scale" in text and "σ = ∞ along" in text
    # one label for the two estimates on top of each other
    assert text.count("wide") == 2 and "wide, nothing" in text


def test_summary_markdown_rows():
    from simcalib.report.rerun.run_summary import summary_markdown
    res = SimpleNamespace(
        config=SimpleNamespace(scenario="x", kind="sim", source="aruco", seed=0),
        pairing={"used": 5}, frames={}, pose_errors={}, camera_names=("cam_a", "cam_b"),
        solvers=[solver_stub("a", np.eye(4), rot=0.01, trans=0.001),
                 solver_stub("b", np.eye(4), rot=100.0, trans=1e5), solver_stub("c", None)])
    b = res.solvers[1]
    b.degenerate, b.verdict, b.sigma_translation_m = True, "undetermined", float("inf")
    b.undetermined_directions = ({
        "kind": "translation", "reason": "undetermined", "description": "translation of X "
        "along y", "rotation_axis_a": [0, 0, 0], "translation_dir_a": [0, 1, 0],
        "std_deg": 0.0, "std_m": float("inf"), "determined_by_prior": False},)
    md = summary_markdown(res)
    assert "| **c** | **FAILED** |" in md and "**c FAILED**: boom" in md
    row_b = next(ln for ln in md.splitlines() if ln.startswith("| b |"))
    row_a = next(ln for ln in md.splitlines() if ln.startswith("| a |"))
    assert row_b.count("█") > row_a.count("█")
    assert "± —" in row_b and "- verdict [b]: **undetermined: translation y**" in md
    assert "- verdict [a]: **determined**" in md
    assert ("translation of X along y: undetermined (no finite 1-sigma: the motions do not "
            "constrain it)") in md


def test_scene_geometry_poses_the_cart():
    from simcalib.world import WorldConfig, build_world
    from simcalib.world.visual import scene_geometry
    w = build_world(WorldConfig(path="planar", duration_s=1.0, fps=5.0),
                    np.random.default_rng(0))
    f = w.frames("cam_a")
    geo = scene_geometry(w.model, f.qpos, f.mocap_pos, f.mocap_quat_wxyz)
    cart = next(b for b in geo.bodies if b.name.endswith("cart"))
    np.testing.assert_allclose(cart.T_world_body[:, :3, 3], f.mocap_pos[:, 0], atol=1e-12)
    assert {g.kind for g in cart.geoms} >= {"box", "cylinder"}
    assert {g.name for g in geo.static} >= {"floor", "wall_px"}
    assert not any(g.name.startswith("marker_") for g in geo.static)


def test_ocr_match_tolerates_one_misread_letter():
    from simcalib.tools.screenshots import text_contains
    assert text_contains("x dgopt+prior y", "dqopt+prior")
    assert text_contains("opencv_daniilidis: 0.3", "opencv_daniilidis")
    assert not text_contains("dq2steps daniilidis", "dqconvrlx")
    assert text_contains("dqopt, dq2ndord, dqconvr|x", "dqconvrlx")   # "l" read as "|"
    assert not text_contains("dqconvr x", "dqconvrlx")
    assert not text_contains("", "dqopt")


@pytest.mark.slow
def test_screenshots_of_a_short_planar_run(tmp_path):
    """The real viewer under Xvfb: no 'No data available', every successful estimate
    labelled in the close-up, the scene filled (framed on the room)."""
    from simcalib.tools.screenshots import check_recording, missing_prerequisites
    missing = missing_prerequisites()
    if missing:
        pytest.skip("viewer screenshots need: " + "; ".join(missing))
    out, res = _run(tmp_path, "planar", "world.duration_s=6", "progress=false")
    rep = check_recording(out, tmp_path / "shots")
    assert rep.ok, rep.problems
    for p in rep.shots.values():
        assert Path(p).stat().st_size > 10_000


def _view_origins(bp) -> set:
    out, stack = set(), [bp.root_container]
    while stack:
        c = stack.pop()
        if hasattr(c, "contents") and not hasattr(c, "origin"):
            stack.extend(c.contents)
        else:
            out.add(str(c.origin))
    return out


def test_blueprint_per_kind_shows_only_views_with_data():
    from simcalib.report.rerun.run_layout import default_blueprint
    full = {"scene", "closeup", "pose_error", "summary"}
    aruco = _view_origins(default_blueprint("sim", images=True, present=full))
    assert {"world/cam_a/image", "world/cam_b/image", "world", "closeup", "summary"} <= aruco
    for kind, images in (("sim", False), ("synthetic", False)):
        got = _view_origins(default_blueprint(kind, images=images, present=full))
        assert not any(o.endswith("/image") for o in got)
        assert {"world", "closeup", "pose_error/rotation_deg", "summary"} <= got
    # an interrupted run (no solvers, no evaluation): no empty panes
    partial = _view_origins(default_blueprint("sim", images=True, present={"scene"}))
    assert "closeup" not in partial and "summary" not in partial
    assert not any(o.startswith("pose_error") for o in partial)


def test_only_cameras_that_logged_images_get_an_image_pane(tmp_path):
    """handeye / scara: cam_a is the flange pose from forward kinematics and logs no image,
    so its pane must not be in the layout (it said "No data available")."""
    import cv2

    from simcalib.report.rerun.run import RunRecorder
    from simcalib.streams import CameraIntrinsics
    cfg = SimpleNamespace(kind="sim", recording=SimpleNamespace(max_images=2,
                                                                jpeg_quality=70))
    jpeg = cv2.imencode(".jpg", np.zeros((48, 64, 3), np.uint8))[1].tobytes()
    log = SimpleNamespace(frames={"cam_b": [{"frame_index": 0, "corners_px": None,
                                              "ids": None}]},
                          images_jpeg={"cam_b": {0: jpeg}}, intrinsics=None)
    K = CameraIntrinsics.from_fovy(64, 48, 60.0)
    rec = RunRecorder(tmp_path / "r.rrd", cfg, background=False)
    rec.log_cameras({"cam_a": K, "cam_b": K}, {}, log)
    origins = _view_origins(rec.blueprint())
    rec.close()
    assert "world/cam_b/image" in origins and "world/cam_a/image" not in origins


def test_recording_cost_tool_rejects_unknown_variants(tmp_path, capsys):
    from simcalib.tools import recording_cost
    with pytest.raises(SystemExit) as e:
        recording_cost.main(["--variants", "worker,nope", "--output", str(tmp_path)])
    assert e.value.code == 2 and "nope" in capsys.readouterr().err
    with pytest.raises(ValueError, match="unknown variant 'x'"):
        recording_cost.run_once("line", "x", tmp_path)
