"""Command line: help, list, dispatch, exit codes and one-line error messages."""

import json

import pytest

from simcalib.cli import main


def test_top_level_help(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for cmd in ("run scenario=NAME", "list", "bench", "experiment", "bench-vision"):
        assert cmd in out
    assert main([]) == 2  # no command: usage, non-zero


def test_run_help_lists_keys_and_scenarios(capsys):
    assert main(["run", "--help"]) == 0
    out = capsys.readouterr().out
    for key in ("noise.sigma_r_deg", "pairing.max_translation_m", "prior.enabled",
                "world.cam_a.width", "synthetic.motion", "alpha"):
        assert key in out
    for name in ("planar", "3d", "random", "circle"):
        assert name in out


def test_list_shows_scenarios_with_descriptions_and_solvers(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("3d", "planar", "linear", "circular", "rotation", "random", "line", "circle"):
        assert any(line.strip().startswith(name + " ") for line in out.splitlines()), name
    assert "dqopt" in out and "daniilidis" in out
    assert main(["list", "--help"]) == 0


@pytest.mark.parametrize("argv, fragment", [
    (["frobnicate"], "unknown command 'frobnicate'"),
    (["rn"], "did you mean 'run'"),
    (["run"], "run needs scenario=NAME"),
    (["run", "scenario=plnar"], "did you mean 'planar'"),
    (["run", "scenario=random", "sed=1"], "did you mean 'seed'"),
    (["run", "scenario=random", "noise.sigma_r_deg=abc"], "expected a number"),
    (["run", "scenario=random", "solvers=[dqopt,foo]"], "unknown method 'foo'"),
    (["run", "scenario=random", "--bogus"], "unknown option '--bogus'"),
    (["run", "scenario=random", "stray"], "expected key=value"),
    (["run", "scenario=random", "camera.widht=3"], "did you mean 'camera.width'"),
])
def test_bad_command_lines_fail_before_work_with_one_line(capsys, tmp_path, argv, fragment):
    status = main(argv + [f"output={tmp_path / 'out'}"] if argv[:1] == ["run"] and len(argv) > 1
                  else argv)
    assert status == 2
    err = capsys.readouterr().err
    assert err.startswith("simcalib: error: ")
    assert len(err.strip().splitlines()) == 1
    assert fragment in err, err
    assert not (tmp_path / "out").exists()  # no work was done


def test_dry_run_prints_resolved_config(capsys):
    import yaml
    assert main(["run", "scenario=circle", "seed=9", "camera.width=320", "--dry-run"]) == 0
    cfg = yaml.safe_load(capsys.readouterr().out)
    assert cfg["seed"] == 9 and cfg["scenario"] == "circle"
    # the camera.* alias sets both cameras
    assert cfg["world"]["cam_a"]["width"] == 320 and cfg["world"]["cam_b"]["width"] == 320


def test_positional_scenario_and_runtime_failure_exit_1(capsys, tmp_path):
    # too few frames for any motion pair: fails at run time with exit 1, one line
    status = main(["run", "planar", "source=noisy", "world.duration_s=0.2", "world.fps=10",
                   "progress=false", "recording.enabled=false", f"output={tmp_path}"])
    assert status == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("simcalib: error: run failed:") and len(err.splitlines()) == 1
    assert "relative motion" in err


def test_dispatch_passes_argv_and_returns_status(monkeypatch):
    import sys
    import types
    seen = {}
    fake = types.ModuleType("simcalib.bench")
    fake.main = lambda argv: seen.setdefault("argv", argv) and 3
    monkeypatch.setitem(sys.modules, "simcalib.bench", fake)
    assert main(["bench", "n=10", "--quick"]) == 3
    assert seen["argv"] == ["n=10", "--quick"]


def test_dispatch_missing_module_is_a_clear_error(monkeypatch, capsys):
    import sys
    monkeypatch.setitem(sys.modules, "simcalib.vision_bench", None)  # import fails
    status = main(["bench-vision"])
    err = capsys.readouterr().err
    assert status == 2 and "bench-vision" in err and "not available" in err


def test_run_synthetic_end_to_end_via_cli(capsys, tmp_path):
    out = tmp_path / "run"
    assert main(["run", "scenario=random", "solvers=[dqopt,daniilidis]", "progress=false",
                 "recording.enabled=false", "seed=4", f"output={out}"]) == 0
    stdout = capsys.readouterr().out
    assert "dqopt" in stdout and "rot err [deg]" in stdout
    res = json.loads((out / "results.json").read_text())
    assert res["seed"] == 4 and set(res["solvers"]) == {"dqopt", "daniilidis"}
