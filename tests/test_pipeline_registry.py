"""The pipeline's extension points and failure paths: every registered pose source builds
and measures a small world, failed runs and failed solvers are reported as failures,
recordings get unique ids, overlays sit on their own frame."""

import dataclasses
import json

import numpy as np
import pytest

from simcalib.cli import main
from simcalib.pipeline.scenario import SOURCES, load_config
from simcalib.sources import (CAMERAS, GroundTruth, PoseSource, SourceOutput,
                              available_sources, build_truth, camera_sources, get_source,
                              sources_for_kind)
from simcalib.streams import PoseStream

SMALL_SIM = ["world.duration_s=2", "world.fps=5", "progress=false", "workers=1",
             "pairing.max_translation_m=5", "pairing.max_rotation_deg=90"]


#: small versions of a source's example (SourceInfo.example), by the kind it measures
SMALL = {"sim": [*SMALL_SIM, "camera.width=320", "camera.height=240"],
         "synthetic": ["synthetic.num_motions=40", "pairing.n_pairs=20", "progress=false"]}


def _small_cfg(source):
    """A small run of the source's own example scenario."""
    info = available_sources()[source]
    scenario, overrides = info.run_example
    return load_config(scenario, [*overrides, *SMALL[info.kinds[0]]])


def _rngs(seed=0):
    from simcalib.pipeline.state import run_rngs
    return run_rngs(seed)


def test_registry_finds_the_source_files_and_rejects_unknown_names():
    from simcalib.sources import SOURCES as REGISTRY
    infos = available_sources()
    assert infos and list(infos) == sorted(infos)
    for name, info in infos.items():      # each one found by discovery of the folder
        src = REGISTRY.get(name)
        assert info is src.info and info.name == name and isinstance(src, PoseSource)
        assert type(src).__module__.startswith("simcalib.sources.")
    with pytest.raises(TypeError, match="SourceInfo"):
        REGISTRY.register("not_a_source", object())
    assert set(sources_for_kind("sim")) == set(SOURCES)  # the config's names are served
    with pytest.raises(ValueError, match=r"unknown pose source 'nosy'.*did you mean 'noisy'"
                                         r".*available: aruco, .*ground_truth"):
        get_source("nosy")
    with pytest.raises(ValueError, match=r"'aruco' cannot measure kind='synthetic'.*"
                                         r"synthetic: \['synthetic'\]"):
        get_source("aruco", "synthetic")
    for name, info in infos.items():     # its example scenario runs it, on cameras it has
        scenario, overrides = info.run_example
        cfg = load_config(scenario, list(overrides))
        assert name in camera_sources(cfg, info.kinds[0]).values()
        section = getattr(cfg, name, None) if info.config is not None else None
        assert info.config is None or isinstance(section, info.config)


def test_a_stream_names_a_source_for_a_camera_it_cannot_measure():
    only = [(n, i) for n, i in available_sources().items() if set(i.cameras) != set(CAMERAS)]
    for name, info in only:
        other = next(c for c in CAMERAS if c not in info.cameras).removeprefix("cam_")
        scenario, overrides = info.run_example
        with pytest.raises(ValueError, match=rf"'{name}' measures .* only; cam_{other} "
                                             rf"needs another source"):
            load_config(scenario, [*overrides, f"streams.{other}.source={name}"])


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(available_sources()))
def test_every_source_builds_and_measures_a_small_world(name):
    cfg = _small_cfg(name)
    src = get_source(name)
    assert isinstance(src, PoseSource)
    kind = src.info.kinds[0]
    rngs = _rngs()
    truth = build_truth(cfg, rngs)
    assert isinstance(truth, GroundTruth) and truth.kind == kind
    cams = tuple(c for c, n in camera_sources(cfg, kind).items() if n == name)
    assert cams and set(cams) <= set(src.info.cameras)   # its example uses it
    out = src.measure(truth, cfg, rngs[src.info.rng_stream], cams)
    assert isinstance(out, SourceOutput)
    if out.motions is not None:      # a source of relative motions
        assert out.motions.C.shape == out.motions.H.shape and out.motions.n >= 2
        assert set(out.pose_errors) == set(CAMERAS)
        return
    for cam in cams:
        s = out.streams[cam]
        assert isinstance(s, PoseStream) and s.camera == cam and s.n_used >= 2
        assert s.T_world_cam.shape == (s.n_used, 4, 4) and np.isfinite(s.T_world_cam).all()
        assert np.all(np.diff(s.timestamp_s) > 0)
        gt = truth.streams[cam]
        common = np.intersect1d(s.frame_index, gt.frame_index)
        assert common.size == s.n_used
        err = np.linalg.norm(s.T_world_cam[:, :3, 3] - gt.T_world_cam[
            np.searchsorted(gt.frame_index, s.frame_index), :3, 3], axis=-1)
        if src.info.exact:
            assert err.max() == 0.0
        else:
            assert 0.0 < np.median(err) < 0.05      # measured, not copied, and near truth
    # only one camera requested: only that one measured (per-stream selection)
    one = src.measure(build_truth(cfg, _rngs()), cfg, _rngs()[src.info.rng_stream],
                      cams[-1:])
    assert set(one.streams) == set(cams[-1:])


def test_a_failing_stage_writes_failed_results_and_reraises(tmp_path, monkeypatch):
    import simcalib.pipeline.stages as P

    def boom(st):
        raise RuntimeError("pairing exploded")

    monkeypatch.setattr(P, "_stage_pairs", boom)
    out = tmp_path / "fail"
    cfg = load_config("random", ["synthetic.num_motions=40", "pairing.n_pairs=20",
                                 "progress=false", f"output={out}"])
    with pytest.raises(RuntimeError, match="pairing exploded"):
        P.run(cfg, echo=False)
    res = json.loads((out / "results.json").read_text())
    assert res["status"] == "failed"
    assert res["error"] == {"type": "RuntimeError", "message": "pairing exploded",
                            "stage": "pairs"}
    assert res["completed_stages"] == ["world", "streams"] and res["solvers"] == {}
    from rerun.chunk import RrdReader
    RrdReader(str(out / "recording.rrd")).store()   # the recording is closed and readable


def test_failed_solvers_are_never_estimates(tmp_path, monkeypatch, capsys):
    import simcalib.solvers.api as api
    real = api.solve

    def solve(C, H, method, **kw):
        sol = real(C, H, method=method, **kw)
        if method == "daniilidis":          # what OpenCV's Daniilidis did on `line`
            return dataclasses.replace(sol, X=np.eye(4), success=False,
                                       solver_message="degenerate motions")
        if method == "dq2ndord":
            return dataclasses.replace(sol, X=np.full((4, 4), np.nan))
        if method == "dqconvrlx":
            raise np.linalg.LinAlgError("SVD did not converge")
        return sol

    monkeypatch.setattr(api, "solve", solve)
    out = tmp_path / "run"
    assert main(["run", "scenario=line", f"output={out}", "progress=false",
                 "synthetic.num_motions=60", "pairing.n_pairs=30",
                 "solvers=[dqopt,daniilidis,dq2ndord,dqconvrlx]"]) == 0
    table = capsys.readouterr().out
    res = json.loads((out / "results.json").read_text())
    reasons = {"daniilidis": "degenerate motions", "dq2ndord": "non-finite X",
               "dqconvrlx": "LinAlgError: SVD did not converge"}
    for label, reason in reasons.items():
        s = res["solvers"][label]
        assert s["X"] is None and s["success"] is False and s["error"] == reason
        assert s["rotation_error_deg"] is None and s["translation_error_m"] is None
        assert f"FAILED: {reason}" in next(ln for ln in table.splitlines()
                                           if ln.startswith(label + " "))
    assert res["solvers"]["dqopt"]["X"] is not None and res["status"] == "complete"
    ext = json.loads((out / "extrinsics.json").read_text())
    assert set(ext["estimates"]) == {"dqopt"}
    from rerun.chunk import RrdReader
    ents = {str(p) for p in RrdReader(str(out / "recording.rrd")).store().schema()
            .entity_paths()}
    est = {e for e in ents if e.startswith(("/closeup/estimates/", "/closeup/offscale/"))}
    assert est and all(e.startswith("/closeup/estimates/dqopt") for e in est)


def test_each_run_gets_its_own_recording_id(tmp_path):
    from rerun.chunk import RrdReader
    ids = []
    for sub in ("a", "b"):
        out = tmp_path / sub
        assert main(["run", "scenario=random", f"output={out}", "progress=false",
                     "synthetic.num_motions=40", "pairing.n_pairs=20",
                     "solvers=[dqopt]"]) == 0
        (entry,) = RrdReader(str(out / "recording.rrd")).recordings()
        assert entry.application_id == "simcalib"
        ids.append(entry.recording_id)
    assert ids[0] != ids[1]


def test_overlays_are_logged_only_with_the_image_of_their_own_frame():
    from types import SimpleNamespace

    from simcalib.report.rerun.run_scene import iter_visual_log
    frames = [SimpleNamespace(frame_index=k, ids=np.array([k]),
                              corners_px=np.full((1, 4, 2), float(k))) for k in range(10)]
    log = SimpleNamespace(frames={"cam_a": frames},
                          images_jpeg={"cam_a": {k: b"jpeg%d" % k for k in (0, 4, 8)}})
    got = list(iter_visual_log(log, SimpleNamespace(max_images=150)))
    assert [g[1] for g in got] == [0, 4, 8]
    for cam, frame, image, corners, ids in got:
        assert image == b"jpeg%d" % frame and np.all(corners == frame) and ids[0] == frame
    got = list(iter_visual_log(log, SimpleNamespace(max_images=2)))
    assert [g[1] for g in got] == [0, 8]


def test_stage_progress_lines_when_stderr_is_not_a_terminal(tmp_path, capsys):
    assert main(["run", "scenario=random", f"output={tmp_path / 'r'}", "progress=true",
                 "synthetic.num_motions=40", "pairing.n_pairs=20", "solvers=[dqopt]",
                 "recording.enabled=false"]) == 0
    err = capsys.readouterr().err
    for k, stage in enumerate(("world", "streams", "pairs", "solvers", "evaluation",
                               "reports"), start=1):
        assert f"[simcalib] {stage} done in" in err and f"({k}/6)" in err
