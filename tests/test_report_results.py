"""What the console table and results.json say about numbers that are not measurements
(simcalib.report.directions, rendered by simcalib.report.results and .console), and the TUM
files simcalib writes."""

from types import SimpleNamespace

import numpy as np
import pytest

from simcalib.report import directions
from simcalib.report import results as reports
from simcalib.report.console import summary_table
from simcalib.pipeline.state import SolverResult
from simcalib.solvers.diagnostics.uncertainty import Direction, direction_state


def _solver(**kw) -> SolverResult:
    base = dict(label="dqopt", method="dqopt", alpha=0.5, prior=None, X=np.eye(4),
                rotation_error_deg=1.0, translation_error_m=0.1,
                translation_error_determined_m=0.02, cost=1.0, runtime_s=1e-3, success=True,
                degenerate=False, verdict="determined", sigma_rotation_deg=0.5,
                sigma_translation_m=0.05, covariance=np.eye(6) * 1e-4)
    return SolverResult(**(base | kw))


def _direction(kind="translation", reason="poorly determined", axis=(0.0, 1.0, 0.0),
               by_prior=False) -> dict:
    z = [0.0, 0.0, 0.0]
    return {"kind": kind, "reason": reason, "description": f"{kind} of X",
            "rotation_axis_a": list(axis) if kind != "translation" else z,
            "translation_dir_a": list(axis) if kind != "rotation" else z,
            "std_deg": 0.0, "std_m": float("inf") if reason == "undetermined" else 0.2,
            "determined_by_prior": by_prior}


def _table(*solvers) -> str:
    result = SimpleNamespace(config=SimpleNamespace(scenario="t", source="noisy", seed=0),
                             pairing={"used": 10}, solvers=solvers, frames={},
                             camera_names=("cam_a", "cam_b"), pose_errors={})
    return summary_table(result)


def _row(table: str, label: str) -> str:
    return next(ln for ln in table.splitlines() if ln.startswith(label + " "))


def test_projected_out_translation_error_is_a_dash_with_its_reason():
    # every translation direction flagged (scenario line): what is left is rounding
    s = _solver(translation_error_determined_m=3.18e-15, degenerate=True,
                verdict="poorly determined", undetermined_translation_axes=np.eye(3),
                undetermined_directions=tuple(_direction(axis=a) for a in np.eye(3)))
    table = _table(s)
    assert "e-15" not in table
    assert f" {directions.NOT_MEASURED} " in _row(table, "dqopt")
    assert directions.REASON_ALL_PROJECTED in table
    entry = reports.solver_entry(s)
    assert entry["translation_error_determined_m"] is None
    assert entry["translation_error_determined_reason"] == directions.REASON_ALL_PROJECTED


def test_a_partly_projected_error_is_still_a_measurement():
    s = _solver(translation_error_determined_m=0.0123, degenerate=True,
                verdict="poorly determined", undetermined_translation_axes=np.eye(3)[1:2],
                undetermined_directions=(_direction(),))
    assert " 1.23 " in _row(_table(s), "dqopt")
    entry = reports.solver_entry(s)
    assert entry["translation_error_determined_m"] == 0.0123
    assert entry["translation_error_determined_reason"] is None


def test_an_infinite_sigma_is_a_dash_with_its_reason():
    cov = np.eye(6) * 1e-4
    cov[4, 4] = np.inf
    s = _solver(degenerate=True, verdict="undetermined", sigma_translation_m=float("inf"),
                covariance=cov, undetermined_directions=(_direction(reason="undetermined"),))
    table = _table(s)
    row = _row(table, "dqopt")
    assert f"± {directions.NOT_MEASURED}" in row and "inf" not in row
    assert directions.REASON_SIGMA_INFINITE in table
    entry = reports.solver_entry(s)
    assert entry["sigma_translation_m"] == float("inf")   # written as null by write_json
    assert entry["sigma_translation_reason"] == directions.REASON_SIGMA_INFINITE
    assert entry["sigma_rotation_reason"] is None


def test_prior_bounded_direction_reads_the_same_in_table_and_results():
    # planar + prior: the motions leave y free, the prior bounds it at 2.3 cm (finite
    # covariance), not within tolerance; the row's sigma is finite, so is the verdict's
    d = _direction(reason="undetermined")
    s = _solver(label="dqopt+prior", prior={"a": 1.0, "b": 1.0}, degenerate=True,
                verdict="undetermined", sigma_translation_m=0.0234,
                undetermined_directions=(d,))
    row = _row(_table(s), "dqopt+prior")
    assert "± 2.34" in row and "poorly determined (prior only): translation y" in row
    assert not row.rstrip().endswith("undetermined: translation y")
    state = reports.solver_entry(s)["undetermined_directions"][0]["state"]
    assert state == "poorly determined (prior only)"
    # the same rule as the Direction's own words
    direction = Direction("undetermined", "translation", np.zeros(3), np.eye(3)[1],
                          0.0, np.inf, 0.0, 0.0234, False, "translation of X", with_prior=True)
    assert direction.state == state == direction_state("undetermined", False, True, True)
    assert direction.summary().startswith("translation of X: " + state)


def test_fixed_by_prior_and_worst_state_first_in_the_verdict_cell():
    fixed = _direction(axis=(0.0, 0.0, 1.0), by_prior=True)
    free = _direction(reason="undetermined")
    s = _solver(prior={"a": 1.0, "b": 1.0}, degenerate=True, verdict="undetermined",
                covariance=np.diag([1e-4] * 4 + [np.inf, 1e-4]),
                undetermined_directions=(fixed, free))
    cell = directions.solver_view(s).verdict_cell()
    assert cell == "undetermined: translation y; fixed by the prior: translation z"


def test_write_tum_starts_with_the_simcalib_signature(tmp_path):
    T = np.tile(np.eye(4), (3, 1, 1))
    p = reports.write_tum(tmp_path / "x.tum", np.arange(3.0), T)
    lines = p.read_text().splitlines()
    assert lines[:2] == ["# simcalib TUM trajectory", "# timestamp tx ty tz qx qy qz qw"]
    assert np.loadtxt(p).shape == (3, 8)


@pytest.mark.parametrize("value", [None, float("nan")])
def test_missing_determined_error_stays_missing(value):
    s = _solver(translation_error_determined_m=value)
    assert directions.determined_translation(s) == (value, None)


@pytest.mark.slow
def test_progress_reports_frames_within_the_streams_stage(tmp_path, capsys, gl):
    """A rendered run with progress on says, while the streams stage renders, how many
    frames are done — throttled (a few lines, not one per frame) and before the stage ends."""
    import re

    from simcalib.cli import main
    status = main(["run", "scenario=planar", "world.duration_s=3", "world.fps=10",
                   "pairing.step=1", "pairing.max_translation_m=1.0", "pairing.max_rotation_deg=90",
                   "solvers=[dqopt]", "recording.enabled=false",
                   "workers=1", "progress=true", f"output={tmp_path / 'r'}"])
    assert status == 0
    lines = capsys.readouterr().err.splitlines()
    frame_lines = [ln for ln in lines if re.search(r"streams: frames \d+/\d+", ln)]
    done_at = next(i for i, ln in enumerate(lines) if "streams done in" in ln)
    counts = [tuple(map(int, re.search(r"frames (\d+)/(\d+)", ln).groups()))
              for ln in frame_lines]
    assert any(n < total for n, total in counts), frame_lines   # intermediate updates
    assert counts[-1][0] == counts[-1][1]
    assert len(frame_lines) <= 10 < counts[-1][1]                # throttled
    assert all(lines.index(ln) < done_at for ln in frame_lines)
