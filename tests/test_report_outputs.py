"""Output directories are checked before any work (simcalib.report.outputs)."""

import pytest

from simcalib.errors import EXIT_USAGE, UsageError
from simcalib.report.outputs import check_output_dir


def test_an_existing_file_is_a_usage_error_naming_it(tmp_path):
    f = tmp_path / "taken"
    f.write_text("x")
    with pytest.raises(UsageError, match="is an existing file") as exc:
        check_output_dir(f, overwrite=True)
    assert str(f) in str(exc.value) and exc.value.exit_code == EXIT_USAGE


@pytest.mark.parametrize("name", ["results.json", "extrinsics.json", "calibration.json"])
def test_earlier_results_are_refused_unless_overwrite(tmp_path, name):
    (tmp_path / name).write_text("{}")
    with pytest.raises(UsageError, match=f"earlier run's results \\({name}\\).*overwrite=true"):
        check_output_dir(tmp_path)
    assert check_output_dir(tmp_path, overwrite=True) == tmp_path


def test_new_empty_or_unrelated_directories_are_fine(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    assert check_output_dir(tmp_path) == tmp_path
    assert check_output_dir(tmp_path / "new" / "dir") == tmp_path / "new" / "dir"
    assert not (tmp_path / "new").exists()          # creates nothing


def test_an_output_below_a_file_is_refused_before_any_work(tmp_path):
    from simcalib.errors import UsageError
    from simcalib.report.outputs import check_output_dir
    blocker = tmp_path / "f"
    blocker.write_text("x")
    with pytest.raises(UsageError, match="is a file; give a writable directory"):
        check_output_dir(blocker / "a" / "b")
    assert not (tmp_path / "f" / "a").exists()
