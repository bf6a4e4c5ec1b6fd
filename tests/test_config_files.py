"""simcalib/config/files.py: output folders that cannot be made are a ConfigError naming
the key, the path and the reason (exit 2 on the command line)."""

from __future__ import annotations

import pytest

from simcalib.cli import main
from simcalib.config.files import output_folder
from simcalib.errors import ConfigError


def test_output_folder_is_made_and_returned(tmp_path):
    out = output_folder(tmp_path / "a" / "b")
    assert out.is_dir()


def test_a_file_in_the_way_is_a_config_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ConfigError, match=r"output=.*file/sub.*cannot create the folder"):
        output_folder(blocker / "sub")


def test_the_run_command_says_so_with_exit_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["run", "scenario=line", f"output={blocker / 'sub'}"]) == 2
    assert "cannot be written" in capsys.readouterr().err   # before any work
