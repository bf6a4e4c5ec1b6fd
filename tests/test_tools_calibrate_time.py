"""simcalib.tools.calibrate_time: the README's calibrate-time command."""

import pytest

from simcalib.studies.experiments.real_sets import real_dir
from simcalib.tools.calibrate_time import main, run_env


@pytest.mark.slow
def test_times_the_command_on_a_shared_set(capsys):
    if not (real_dir() / "sthe_calib_b" / "a.txt").is_file():
        pytest.skip(f"no shared real data in {real_dir()}")
    assert main(["--sets", "sthe_calib_b", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("sthe_calib_b"))
    poses, exit_code = row.split()[1:3]
    assert int(poses) > 10 and exit_code in ("0", "6")
    assert "median over 1 sets" in out


def test_says_what_it_did_not_find(tmp_path, capsys):
    assert main(["--data", str(tmp_path / "missing")]) == 2
    assert "no data folder" in capsys.readouterr().err
    (tmp_path / "one").mkdir()
    assert main(["--data", str(tmp_path), "--sets", "nothing_here"]) == 2
    assert "nothing_here" in capsys.readouterr().err


def test_runs_use_the_bytecode_cache_as_an_installation_does(monkeypatch):
    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    env = run_env()
    assert "PYTHONDONTWRITEBYTECODE" not in env and env["MUJOCO_GL"] == "egl"
    assert "NUMBA_CACHE_DIR" not in env or env["NUMBA_CACHE_DIR"] == __import__(
        "os").environ.get("NUMBA_CACHE_DIR")
    assert run_env("/tmp/empty-cache")["NUMBA_CACHE_DIR"] == "/tmp/empty-cache"
