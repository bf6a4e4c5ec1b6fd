"""The calibration recording (``simcalib calibrate``'s recording.rrd): read back
with ``rerun.chunk.RrdReader`` (entities; outlier poses as marks, not in the trajectory
strips; residual plots on the inliers' scale) and, where the viewer can run, screenshot
checked (simcalib.tools.screenshots)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rrd_reading import chunks, points

from simcalib.report.rerun.calibration import rejected_instants, trajectory_strips


def _strips(values) -> list[np.ndarray]:
    """The polylines of a LineStrips3D:strips column (rows of lists of strips)."""
    out = []
    for row in values:
        for strip in row or []:
            out.append(np.asarray(strip, dtype=np.float64).reshape(-1, 3))
    return out


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """A 20 s synthetic rig with 15 % outlier poses in b and a 100 ms offset, calibrated
    as ``simcalib calibrate`` does (outputs and recording written)."""
    from simcalib.report.results import write_tum
    from simcalib.tools.screenshots import run_calibration
    from simcalib.world.stream_sim import rig_streams
    d = tmp_path_factory.mktemp("cal")
    s = rig_streams(offset_s=0.1, outlier_fraction=0.15, duration_s=20.0,
                    rng=np.random.default_rng(1))
    write_tum(d / "a.txt", s.t_a, s.T_a)
    write_tum(d / "b.txt", s.t_b, s.T_b)
    r, _ = run_calibration(d, d / "out")
    return s, r, d / "out"


def test_rejected_instants_are_those_only_rejected_motions_use():
    i, j = np.array([0, 1, 2, 3]), np.array([1, 2, 3, 4])
    inl = np.array([True, False, False, True])          # 1->2 and 2->3 rejected
    rej = rejected_instants(6, i, j, inl)
    assert rej.tolist() == [False, False, True, False, False, False]   # 5: in no motion


def test_trajectory_strips_join_single_rejections_and_break_at_long_runs():
    P = np.arange(12, dtype=float)[:, None] * np.array([[1.0, 0.0, 0.0]])
    keep = np.ones(12, bool)
    keep[[2, 6, 7, 8, 9]] = False                        # one alone, then a run of 4
    strips = trajectory_strips(P, keep, np.arange(12.0), max_skip=3)
    assert [s[:, 0].tolist() for s in strips] == [[0, 1, 3, 4, 5], [10, 11]]
    t = np.arange(12.0)
    t[6:] += 100.0                                       # a gap in time breaks a strip
    assert len(trajectory_strips(P, np.ones(12, bool), t)) == 2


def test_calibration_recording_entities(calibrated):
    _, r, out = calibrated
    ents = chunks(out / "recording.rrd")
    for e in ("/world/b_from_a/trajectory", "/world/b_measured/trajectory",
              "/world/rejected/poses", "/world/rig/a", "/world/rig/a/b_through_X",
              "/world/rig/a/link", "/world/rig/b_measured", "/residuals/rotation_deg/inliers",
              "/residuals/rotation_deg/rejected", "/residuals/translation_mm/inliers",
              "/residuals/translation_mm/rejected", "/time_offset/window",
              "/time_offset/peak", "/time_offset/chosen", "/summary", "/report"):
        assert e in ents, (e, sorted(ents))
    summary = " ".join(map(str, np.ravel(ents["/summary"]["TextDocument:text"])))
    for word in ("verdict", "sigma", "time offset", "margin", "rejected poses", "status"):
        assert word in summary, word


def test_outlier_poses_are_marks_not_part_of_the_trajectory_strips(calibrated):
    from simcalib.report.rerun.calibration import calibration_scene
    s, r, out = calibrated
    sc = calibration_scene(r)
    # every true outlier pose of b is a rejected instant (b is the reference: its stamps)
    t_synced = np.asarray(r.synced.time_s)
    t_out = s.t_b[s.outlier_b] - r.time_offset.offset_s
    k = np.abs(t_synced[:, None] - t_out[None]).argmin(axis=0)
    matched = np.abs(t_synced[k] - t_out) < 1e-3
    assert matched.sum() >= 0.9 * s.outlier_b.sum()
    assert sc.rejected[k[matched]].all()
    ents = chunks(out / "recording.rrd")
    strips = _strips(ents["/world/b_measured/trajectory"]["LineStrips3D:strips"])
    P = np.concatenate(strips)
    bad = sc.b_measured[sc.rejected, :3, 3]
    assert np.linalg.norm(P[:, None] - bad[None], axis=2).min() > 1e-6
    # b measured follows b through X point by point along the strips (noise: mm); at the
    # rejected instants it is off by far more (the outliers would be jumps)
    ref = _strips(ents["/world/b_from_a/trajectory"]["LineStrips3D:strips"])
    assert [p.shape for p in ref] == [p.shape for p in strips]
    assert max(np.linalg.norm(p - q, axis=1).max() for p, q in zip(strips, ref)) < 0.02
    off = np.linalg.norm(bad - sc.b_from_a[sc.rejected, :3, 3], axis=1)
    assert np.median(off) > 0.05
    marks = points(ents["/world/rejected/poses"]["Points3D:positions"])
    assert marks.shape[0] == int(sc.rejected.sum())
    # b measured and b through X agree along the kept path (mm, not cm)
    keep = ~sc.rejected
    gap = np.linalg.norm(sc.b_measured[keep, :3, 3] - sc.b_from_a[keep, :3, 3], axis=1)
    assert np.median(gap) < 0.01


def test_residual_plots_are_on_the_inliers_scale(calibrated):
    from simcalib.report.rerun.calibration import residual_caps, residuals
    _, r, out = calibrated
    ents = chunks(out / "recording.rrd")
    caps, res = residual_caps(r), residuals(r)
    inl = np.asarray(r.robust.inlier_mask)
    for q in ("rotation_deg", "translation_mm"):
        assert caps[q] == pytest.approx(1.25 * res[q][inl].max())
        assert res[q][~inl].max() > 10 * caps[q]          # outliers would flatten them
        rej = np.array(ents[f"/residuals/{q}/rejected"]["Scalars:scalars"], float).ravel()
        assert rej.size == (~inl).sum() and rej.max() <= caps[q] + 1e-9


def test_stamp_paired_calibration_has_no_correlation_pane():
    from simcalib.estimation.alignment import TimeOffset
    from simcalib.report.rerun.calibration import has_correlation
    off = TimeOffset(0.0, 0.0, 0.0, float("nan"), np.zeros(0), np.zeros(0),
                     decision="shared_stamps")
    assert not has_correlation(off)


@pytest.mark.slow
def test_calibration_screenshots(calibrated, tmp_path):
    """The real viewer under Xvfb: no empty pane, every summary line read whole, the 3D
    view framed on the trajectories."""
    from simcalib.tools.screenshots import check_calibration, missing_prerequisites
    missing = missing_prerequisites()
    if missing:
        pytest.skip("viewer screenshots need: " + "; ".join(missing))
    _, r, out = calibrated
    rep = check_calibration(out, r, tmp_path, "synthetic")
    assert rep.ok, rep.problems
    for p in rep.shots.values():
        assert Path(p).stat().st_size > 10_000
    assert json.loads((out / "calibration.json").read_text())["files"]["recording"]


def test_cut_summary_lines_are_found():
    from simcalib.tools.screenshots import cut_lines
    summary = ("- **verdict: DETERMINED** - sigma raised to the data's own consistency\n"
               "- time offset t_b - t_a: 100.08 +- 0.22 ms (estimated)\n"
               "- status: determined (exit 0)")
    whole = ("verdict: DETERMINED - sigma raised to the data's\nown consistency\n"
             "time offset t_b - t_a: 100.08 +- 0.22 ms (estimated)\nstatus: determined (exit 0)")
    assert cut_lines(whole, summary) == []
    cut = whole.replace("(estimated)", "(esti").replace("status: determined (exit 0)", "")
    assert [x[:8] for x in cut_lines(cut, summary)] == ["- time o", "- status"]


def test_pane_pixels_count_shaded_colours_and_framing_measures_the_drawing(tmp_path):
    from PIL import Image

    from simcalib.report.rerun.calibration import (
        CALIBRATION_BACKGROUND,
        CALIBRATION_COLORS,
    )
    from simcalib.tools.screenshots import framing, pane_pixels
    a = np.tile(np.array(CALIBRATION_BACKGROUND, np.uint8), (200, 300, 1))
    teal = np.array(CALIBRATION_COLORS["correlation"], float)
    a[50:60, 20:70] = (0.7 * teal).astype(np.uint8)          # a translucent bar
    a[100:110, 20:270] = (150, 150, 150)                      # grey: no pane's colour
    p = tmp_path / "shot.png"
    Image.fromarray(a).save(p)
    n = pane_pixels(p, {"corr": ("correlation",), "traj": ("b_from_a",)})
    assert n == {"corr": 500, "traj": 0}
    assert framing(p) == pytest.approx(250 / 300, abs=0.01)


def test_worker_writes_the_calibration_recording_as_in_process(calibrated, tmp_path):
    """``simcalib calibrate`` hands its recording to the worker process (rerun's import off
    its critical path): the file holds what logging in-process writes, blueprint included."""
    from rerun.chunk import RrdReader

    from simcalib.report.rerun.calibration import record_calibration
    _, r, out = calibrated
    report = json.loads((out / "calibration.json").read_text())
    got = {}
    for background in (True, False):
        p = record_calibration(tmp_path / f"{background}.rrd", r, report, "console text",
                               background=background)
        got[background] = chunks(p)
        assert RrdReader(str(p)).blueprints()
    assert set(got[True]) == set(got[False])
    for ent in ("/summary", "/report", "/world/b_from_a/trajectory",
                "/residuals/rotation_deg/inliers", "/time_offset/window"):
        assert got[True][ent] == got[False][ent], ent


@pytest.mark.slow
def test_calibrate_command_records_through_the_worker(tmp_path):
    """The command starts the recording worker before it reads the files, and its process
    never imports rerun."""
    import subprocess
    import sys
    from simcalib.report.results import write_tum
    from simcalib.world.stream_sim import rig_streams
    s = rig_streams(offset_s=0.0, outlier_fraction=0.0, duration_s=8.0,
                    rng=np.random.default_rng(2))
    write_tum(tmp_path / "a.txt", s.t_a, s.T_a)
    write_tum(tmp_path / "b.txt", s.t_b, s.T_b)
    code = ("import sys; from simcalib.cli import main; "
            f"rc = main(['calibrate', 'a={tmp_path / 'a.txt'}', 'b={tmp_path / 'b.txt'}', "
            f"'output={tmp_path / 'out'}']); "
            "print('RERUN', 'rerun' in sys.modules, 'RC', rc)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert "RERUN False" in proc.stdout, (proc.stdout, proc.stderr)
    ents = chunks(tmp_path / "out" / "recording.rrd")
    assert {"/summary", "/world/b_from_a/trajectory"} <= set(ents)
