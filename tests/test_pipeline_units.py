"""Evaluation and report helpers of the pipeline, on poses made with simcalib.geometry."""

import numpy as np
import pytest

from simcalib.evaluation import estimate_errors, pose_source_errors, summary_stats
from simcalib.geometry import (matrix_from_rotvec, perturb_transforms, quat_from_matrix,
                               random_rotation_matrices, transform_from_rotation_translation)
from simcalib.report.results import strip_timing, write_tum
from simcalib.streams import PoseStream


def _T(rotvec_deg, t):
    return transform_from_rotation_translation(matrix_from_rotvec(np.deg2rad(rotvec_deg)), t)


def test_estimate_errors_exact_numbers():
    X = _T([0, 0, 30], [0.1, 0.2, 0.3])
    E = _T([0, 0, 32], [0.1, 0.2, 0.3 + 0.05]) @ np.eye(4)
    E[:3, 3] = [0.13, 0.2, 0.35]  # 3 cm along x, 5 cm along z
    err = estimate_errors(E, X)
    assert err["rotation_error_deg"] == pytest.approx(2.0, abs=1e-10)
    assert err["translation_error_m"] == pytest.approx(np.hypot(0.03, 0.05), abs=1e-12)
    # z undetermined: only the x part of the error counts as "determined"
    err_z = estimate_errors(E, X, np.array([[0.0, 0.0, 2.0]]))
    assert err_z["translation_error_determined_m"] == pytest.approx(0.03, abs=1e-12)
    assert err_z["translation_error_m"] == err["translation_error_m"]


def test_estimate_errors_rejects_bad_input():
    with pytest.raises(ValueError, match="X estimate"):
        estimate_errors(np.full((4, 4), np.nan), np.eye(4))


def test_pose_source_errors_match_by_frame(rng):
    n = 50
    T = transform_from_rotation_translation(random_rotation_matrices(rng, (n,)),
                                            rng.normal(size=(n, 3)))
    noisy = perturb_transforms(T, np.deg2rad(0.5), 0.01, rng)
    keep = np.sort(rng.choice(n, 40, replace=False))
    truth = PoseStream("cam_a", "ground_truth", np.arange(n), np.arange(n) * 0.1, T, n)
    src = PoseStream("cam_a", "noisy", keep, keep * 0.1, noisy[keep], n)
    e = pose_source_errors(src, truth)
    assert e.n == 40 and np.array_equal(e.frame_index, keep)
    assert 0.2 < np.median(e.rotation_deg) < 0.9
    assert 0.005 < np.median(e.translation_m) < 0.03
    s = e.summary()
    assert s["rotation_deg"]["median"] == pytest.approx(float(np.median(e.rotation_deg)))
    assert s["translation_m"]["p95"] == pytest.approx(float(np.percentile(e.translation_m, 95)))
    with pytest.raises(ValueError, match="different cameras"):
        pose_source_errors(PoseStream("cam_b", "noisy", keep, keep * 0.1, noisy[keep], n), truth)


def test_summary_stats_empty_and_values():
    assert summary_stats([]) == {"median": None, "p95": None, "mean": None, "max": None}
    s = summary_stats(np.arange(101.0))
    assert s["median"] == 50.0 and s["p95"] == 95.0 and s["max"] == 100.0


def test_tum_file_round_trip(tmp_path, rng):
    T = transform_from_rotation_translation(random_rotation_matrices(rng, (5,)),
                                            rng.normal(size=(5, 3)))
    t = np.linspace(0, 1, 5)
    p = write_tum(tmp_path / "x.tum", t, T)
    lines = p.read_text().splitlines()
    assert lines[:2] == ["# simcalib TUM trajectory", "# timestamp tx ty tz qx qy qz qw"]
    assert len(lines) == 7
    rows = np.loadtxt(p)
    np.testing.assert_allclose(rows[:, 0], t, atol=1e-9)
    np.testing.assert_allclose(rows[:, 1:4], T[:, :3, 3], atol=1e-9)
    np.testing.assert_allclose(rows[:, 4:], quat_from_matrix(T[:, :3, :3]), atol=1e-9)
    with pytest.raises(ValueError, match="timestamps"):
        write_tum(tmp_path / "y.tum", t[:3], T)


def test_strip_timing_removes_only_timing_fields():
    d = {"timing_s": {"a": 1}, "solvers": {"x": {"runtime_s": 3, "cost": 1.0,
                                                  "sweep": [{"runtime_s": 1, "alpha": 1}]}}}
    assert strip_timing(d) == {"solvers": {"x": {"cost": 1.0, "sweep": [{"alpha": 1}]}}}


def test_default_output_dir_never_lands_on_an_earlier_run(tmp_path, monkeypatch):
    import dataclasses
    from simcalib.pipeline.scenario import load_config
    from simcalib.pipeline.stages import _output_dir
    import datetime
    from pathlib import Path
    from types import SimpleNamespace
    import simcalib.pipeline.stages as pipeline
    monkeypatch.chdir(tmp_path)
    fixed = datetime.datetime(2026, 12, 2, 18, 0, 0)
    monkeypatch.setattr(pipeline, "_dt", SimpleNamespace(datetime=SimpleNamespace(
        now=lambda: fixed)))
    cfg = load_config("random", [])
    first = _output_dir(cfg)
    assert first == Path("runs") / "random-20261202-180000"
    first.mkdir(parents=True)
    assert _output_dir(cfg) == first                       # empty: still usable
    (first / "results.json").write_text("{}")
    assert _output_dir(cfg) == Path("runs") / "random-20261202-180000-2"
    from simcalib.errors import UsageError
    with pytest.raises(UsageError, match="overwrite=true"):
        _output_dir(dataclasses.replace(cfg, output=str(first)))
    assert _output_dir(dataclasses.replace(cfg, output=str(first), overwrite=True)) == first
