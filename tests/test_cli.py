"""Command line: help, list, dispatch, exit codes and one-line error messages."""

import json

import pytest

from simcalib.cli import main


def test_top_level_help(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    from simcalib.cli import COMMANDS
    for name in COMMANDS.names():         # every registered command, with its usage
        cmd = COMMANDS.info(name)
        assert any(line.strip().startswith(cmd.usage) and cmd.summary in line
                   for line in out.splitlines()), name
    assert "run scenario=NAME" in out
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


def test_list_shows_every_registered_extension(capsys):
    from simcalib.executors import available as executors
    from simcalib.importers import available as formats
    from simcalib.sources import available_sources
    from simcalib.studies.experiments import EXPERIMENTS
    from simcalib.world.platforms import available_platforms
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for names in (available_sources(), available_platforms(), formats(), executors(),
                  EXPERIMENTS.names()):
        assert names
        for name in names:
            assert any(line.strip().startswith(name + " ") for line in lines), name


@pytest.mark.parametrize("argv, fragment", [
    (["frobnicate"], "unknown command 'frobnicate'"),
    (["rn"], "did you mean 'run'"),
    (["run"], "run needs scenario=NAME"),
    (["run", "scenario=plnar"], "did you mean 'planar'"),
    (["run", "scenario=random", "sed=1"], "did you mean 'seed'"),
    (["run", "scenario=random", "noise.sigma_r_deg=abc"], "noise.sigma_r_deg must be a number; received 'abc'"),
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


@pytest.mark.slow
def test_positional_scenario_and_runtime_failure_exit_1(capsys, tmp_path):
    # cam_b's clock 100 s off: no frames match by timestamp, found only at run time
    status = main(["run", "planar", "source=noisy", "world.duration_s=6",
                   "world.cam_b.clock_offset_s=100", "progress=false",
                   "recording.enabled=false", f"output={tmp_path}"])
    assert status == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("simcalib: error: run failed:") and len(err.splitlines()) == 1
    assert "relative motion" in err and "--debug" in err


def test_compressed_path_rejected_before_any_work(capsys, tmp_path):
    # paths are defined in cycles per run: 3 s of the 3d path moves too far between frames
    status = main(["run", "3d", "world.duration_s=3", f"output={tmp_path / 'out'}"])
    assert status == 2
    err = capsys.readouterr().err
    assert "world.duration_s=3" in err and "cycles per run" in err
    assert "world.duration_s >= 4" in err
    assert not (tmp_path / "out").exists()


def test_empty_alpha_list_rejected_before_any_work(capsys, tmp_path):
    assert main(["run", "random", "alpha=[]", f"output={tmp_path / 'out'}"]) == 2
    err = capsys.readouterr().err
    assert "alpha must be a number > 0 or a non-empty list of them; received []" in err
    assert not (tmp_path / "out").exists()


def test_yaml_syntax_error_keeps_line_and_column(capsys, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("kind: synthetic\nsource: noisy\nseed: [1, 2\n")
    assert main(["run", f"scenario={bad}"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert "is not valid YAML: line 4, column 1" in err, err


def test_debug_flag_shows_traceback(capsys, tmp_path):
    assert main(["--debug", "run", "random", "sed=1"]) == 2
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err
    assert err.strip().splitlines()[-1].startswith("simcalib: error: unknown config key 'sed'")


@pytest.mark.parametrize("exc, code", [
    ("ConfigError('bad key')", 2),
    ("UsageError('bad usage')", 2),
    ("InputError('bad input')", 3),
    ("DataError('bad pose file')", 3),
    ("BackendError('no OpenGL')", 4),
    ("SolverError('no estimate')", 5),
    ("DegenerateResultError('planar motion')", 6),
    ("KeyboardInterrupt()", 130),
    ("RuntimeError('boom')", 1),
])
def test_typed_errors_map_to_exit_codes(monkeypatch, capsys, exc, code):
    import types

    from simcalib import errors
    from simcalib.cli import COMMANDS, register_command

    def boom(args):
        raise eval(exc, vars(errors))

    mod = types.ModuleType("simcalib_test_boom")
    mod.main = boom
    monkeypatch.setitem(__import__("sys").modules, "simcalib_test_boom", mod)
    register_command("boom", "simcalib_test_boom:main", "test")
    try:
        assert main(["boom"]) == code
    finally:
        COMMANDS.unregister("boom")
    err = capsys.readouterr().err.strip()
    assert err.startswith("simcalib: error: ") and len(err.splitlines()) == 1
    if code == 1:
        assert "boom failed: RuntimeError: boom" in err
    elif code == 130:
        assert "interrupted" in err
    else:
        assert eval(exc, vars(errors)).args[0] in err


def test_exit_codes_documented():
    from pathlib import Path

    from simcalib.errors import EXIT_CODES
    doc = (Path(__file__).resolve().parent.parent / "docs" / "cli.md").read_text()
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    for code in EXIT_CODES:
        assert f"| {code} |" in doc, code
        assert f"| {code} |" in readme, code


def test_register_command_and_help_lists_it(capsys):
    from simcalib.cli import COMMANDS, register_command
    register_command("hello", "simcalib_test_hello:main", "say hello", "hello [NAME]")
    try:
        assert main(["--help"]) == 0
        assert "hello [NAME]" in capsys.readouterr().out
        assert main(["hello"]) == 2
        assert "not available" in capsys.readouterr().err
        with pytest.raises(ValueError, match="command 'hello' is already registered"):
            register_command("hello", "elsewhere:main", "again")
    finally:
        COMMANDS.unregister("hello")
    assert "hello" not in COMMANDS
    with pytest.raises(ValueError, match="one word"):
        register_command("two words", "m:main", "x")
    with pytest.raises(TypeError, match="'module:function'"):
        register_command("nofunc", "just_a_module", "x")


def _commands():
    from simcalib.cli import COMMANDS
    return sorted(COMMANDS.names())


def test_registry_finds_every_command_file():
    """Each command registered itself from a file of simcalib/commands/ (discovered: no
    list), with a summary and a usage that starts with its name."""
    from simcalib.cli import COMMANDS
    assert _commands()
    for name in _commands():
        cmd = COMMANDS.info(name)
        assert cmd.name == name and cmd.summary and cmd.usage.split()[0] == name
        module = COMMANDS.get(name)
        origin = module.__module__ if callable(module) else None
        assert origin is None or origin.startswith("simcalib.commands."), (name, origin)


@pytest.mark.parametrize("name", _commands())
def test_every_command_has_help(name, capsys):
    status = main([name, "--help"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "usage" in (captured.out + captured.err).lower()
    assert main(["help", name]) == 0


def test_list_imports_no_heavy_module():
    import subprocess
    import sys
    code = ("import sys; from simcalib.cli import main; rc = main(['list']); "
            "heavy = [m for m in ('mujoco', 'rerun', 'cv2', 'matplotlib') if m in sys.modules]; "
            "print('HEAVY', heavy); raise SystemExit(rc)")
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent   # this checkout's simcalib
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, cwd=root)
    assert out.returncode == 0, out.stderr
    assert "HEAVY []" in out.stdout, out.stdout


def test_dispatch_passes_argv_and_returns_status(monkeypatch):
    import sys
    import types
    seen = {}
    fake = types.ModuleType("simcalib.studies.bench.solvers")
    fake.main = lambda argv: seen.setdefault("argv", argv) and 3
    monkeypatch.setitem(sys.modules, "simcalib.studies.bench.solvers", fake)
    assert main(["bench", "n=10", "--quick"]) == 3
    assert seen["argv"] == ["n=10", "--quick"]


def test_dispatch_missing_module_is_a_clear_error(monkeypatch, capsys):
    import sys
    monkeypatch.setitem(sys.modules, "simcalib.studies.bench.vision", None)  # import fails
    status = main(["bench-vision"])
    err = capsys.readouterr().err
    assert status == 2 and "bench-vision" in err and "not available" in err


def test_run_synthetic_end_to_end_via_cli(capsys, tmp_path):
    out = tmp_path / "run"
    assert main(["run", "scenario=random", "solvers=[dqopt,daniilidis]", "progress=false",
                 "recording.enabled=false", "seed=4", f"output={out}"]) == 0
    stdout = capsys.readouterr().out
    assert "dqopt" in stdout and "rot err ± σ [deg]" in stdout and "verdict" in stdout
    res = json.loads((out / "results.json").read_text())
    assert res["seed"] == 4 and set(res["solvers"]) == {"dqopt", "daniilidis"}


RANDOM_SMALL = ["scenario=random", "synthetic.num_motions=40", "pairing.n_pairs=20",
                "solvers=[dqopt]", "progress=false", "recording.enabled=false"]


def test_output_naming_a_file_is_a_usage_error(tmp_path, capsys):
    taken = tmp_path / "taken.txt"
    taken.write_text("keep me")
    assert main(["run", *RANDOM_SMALL, f"output={taken}"]) == 2
    err = capsys.readouterr().err
    assert str(taken) in err and "existing file" in err and "FileExistsError" not in err
    assert taken.read_text() == "keep me"


def test_run_refuses_an_earlier_run_unless_overwrite(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", *RANDOM_SMALL, f"output={out}"]) == 0
    first = (out / "results.json").read_text()
    capsys.readouterr()
    assert main(["run", *RANDOM_SMALL, "seed=1", f"output={out}"]) == 2
    err = capsys.readouterr().err
    assert "earlier run's results" in err and "overwrite=true" in err and str(out) in err
    assert (out / "results.json").read_text() == first     # untouched
    assert main(["run", *RANDOM_SMALL, "seed=1", "overwrite=true", f"output={out}"]) == 0
    assert (out / "results.json").read_text() != first


_QUICK_EXIT_CODE = """
import atexit, sys, threading, time
from pathlib import Path
from simcalib.cli import command, main, run
out, mode = Path(sys.argv[1]), sys.argv[2]

class Teardown:                       # freed by the interpreter's teardown only
    def __del__(self):
        (out / "teardown").write_text("ran")

keep = Teardown()

@command("quick-test", summary="test", quick_exit=mode != "normal")
def quick(args):
    atexit.register(lambda: (out / "atexit").write_text("ran"))
    def late():
        time.sleep(0.3)
        (out / "thread").write_text("joined")
    threading.Thread(target=late).start()        # not a daemon: joined at exit
    print("no newline", end="")
    sys.stderr.write("stderr, no newline")
    return 6

@command("outer-test", summary="test")           # runs quick-test in-process
def outer(args):
    return main(["quick-test"])

run(["outer-test" if mode == "nested" else "quick-test"])
"""


@pytest.mark.parametrize("mode", ["quick", "normal", "nested"])
def test_run_ends_the_process_as_a_normal_exit_does(tmp_path, mode):
    """``cli.run`` (the process's entry) ends with the command's status, its output
    flushed, its non-daemon threads joined and the exit handlers run; after a command
    registered with ``quick_exit`` without the interpreter's teardown, and only when that
    command is the outermost (not one that another command ran in-process)."""
    import os
    import subprocess
    import sys
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent
    env = dict(os.environ, PYTHONPATH=str(root))
    p = subprocess.run([sys.executable, "-c", _QUICK_EXIT_CODE, str(tmp_path), mode],
                       capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert p.returncode == 6, p.stderr
    assert p.stdout == "no newline" and p.stderr == "stderr, no newline"
    assert (tmp_path / "atexit").read_text() == "ran"
    assert (tmp_path / "thread").read_text() == "joined"
    assert (tmp_path / "teardown").exists() is (mode != "quick")


def test_calibrate_is_registered_for_a_quick_exit():
    from simcalib.cli import COMMANDS
    assert COMMANDS.info("calibrate").quick_exit
    assert not COMMANDS.info("run").quick_exit
