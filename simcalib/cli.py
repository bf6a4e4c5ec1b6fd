"""Command line: ``python -m simcalib <command> ...`` (also the ``simcalib`` console script).

Commands::

    run scenario=NAME [key=value ...]   one end-to-end run (see ``run --help`` for keys)
    list                                 scenarios (with a one-line description) and solvers
    bench ...                            solver benchmark          (simcalib.bench)
    experiment NAME ...                  paper experiments         (simcalib.experiments)
    bench-vision ...                     visual pose benchmark     (simcalib.vision_bench)

Exit status: 0 on success; 2 for a usage or configuration error (reported before any
work); 1 when the run fails; 130 when interrupted (Ctrl-C) — the partial outputs are kept
and the message says which stages finished.
"""

from __future__ import annotations

import importlib
import os
import sys
from typing import Sequence

__all__ = ["main"]

PROG = "simcalib"

USAGE = f"""usage: python -m {PROG} <command> [args]   (or: {PROG} <command> [args])

commands:
  run scenario=NAME [key=value ...]   simulate, pair, solve and evaluate one scenario
  list                                 list scenarios and solvers
  bench [...]                          solver benchmark (Table-1-like timings)
  experiment NAME [key=value ...]      reproduce the paper's experiments
  bench-vision [...]                   visual pose accuracy and throughput benchmark

Run '{PROG} <command> --help' for a command's options.
"""

RUN_USAGE = f"""usage: python -m {PROG} run scenario=NAME [key=value ...] [--dry-run] [--traceback]

Runs one scenario end to end: world -> pose streams -> relative motions (pairing,
appendix D.1 pre-filter) -> every solver -> errors against the true extrinsic X. Writes
into the run directory (output=DIR, default runs/<scenario>-<timestamp>): results.json,
config.yaml, extrinsics.json, TUM trajectories (tum/), recording.rrd (open with
`rerun recording.rrd`), and prints a summary table.

Overrides are dotted keys with typed values (YAML syntax for numbers, booleans, lists):
  seed=3 output=runs/x noise.sigma_r_deg=1.0 solvers=[dqopt,daniilidis] source=noisy
  alpha=0.5 alpha=[0.1,1,10] camera.width=1280
A key may be shortened to a unique suffix of its full path (camera.width).

options:
  --dry-run     resolve and print the configuration, run nothing
  --traceback   on failure, show the full Python traceback

scenarios: {{scenarios}}

keys (type = default):
{{keys}}
"""


class UsageError(Exception):
    """Bad command line (exit status 2)."""


def _err(msg: str) -> None:
    first = str(msg).strip().splitlines()[0] if str(msg).strip() else "unknown error"
    print(f"{PROG}: error: {first}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the process exit status (never raises for user errors)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(USAGE, end="")
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    try:
        return _main(cmd, rest)
    except BrokenPipeError:  # stdout closed early (e.g. piped into `head`): not an error
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 0


def _main(cmd: str, rest: list[str]) -> int:
    try:
        if cmd == "run":
            return _cmd_run(rest)
        if cmd == "list":
            return _cmd_list(rest)
        if cmd in _DISPATCH:
            return _dispatch(cmd, rest)
        import difflib
        names = ["run", "list", *_DISPATCH]
        close = difflib.get_close_matches(cmd, names, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise UsageError(f"unknown command {cmd!r}{hint}; commands: {', '.join(names)}")
    except UsageError as exc:
        _err(exc)
        return 2


# ------------------------------------------------------------------------- dispatch
_DISPATCH = {
    "bench": "simcalib.bench",
    "experiment": "simcalib.experiments",
    "bench-vision": "simcalib.vision_bench",
}


def _dispatch(cmd: str, rest: list[str]) -> int:
    module = _DISPATCH[cmd]
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            raise UsageError(f"command {cmd!r} is not available in this installation "
                             f"({module} is missing)") from None
        raise
    fn = getattr(mod, "main", None)
    if fn is None:
        raise UsageError(f"command {cmd!r}: {module} has no main(argv)")
    try:
        status = fn(rest)
    except SystemExit as exc:  # argparse inside the sub-command
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except KeyboardInterrupt:
        _err(f"{cmd} interrupted")
        return 130
    except (ValueError, TypeError) as exc:
        _err(f"{cmd}: {exc}")
        return 2
    return 0 if status is None else int(status)


# ----------------------------------------------------------------------------- list
def _cmd_list(rest: list[str]) -> int:
    if any(a in ("-h", "--help") for a in rest):
        print(f"usage: python -m {PROG} list\n\nLists the scenarios (scenarios/*.yaml, with "
              "their one-line description) and the registered solvers.")
        return 0
    if rest:
        raise UsageError(f"list takes no arguments; received {' '.join(rest)}")
    from simcalib.config import list_scenarios, scenario_dir
    from simcalib.solvers import registry
    scen = list_scenarios()
    print(f"scenarios ({scenario_dir()}):")
    width = max((len(n) for n in scen), default=0)
    for name, desc in scen.items():
        print(f"  {name:<{width}}  {desc}")
    if not scen:
        print("  (none)")
    print("\nsolvers:")
    infos = registry.infos()
    width = max((len(i.name) for i in infos), default=0)
    for info in infos:
        tags = [info.family]
        if info.supports_prior:
            tags.append("prior")
        if info.certified:
            tags.append("certified")
        desc = info.description.strip().splitlines()[0] if info.description else ""
        print(f"  {info.name:<{width}}  [{', '.join(tags)}] {desc}")
    if not infos:
        print("  (none registered)")
    return 0


# ------------------------------------------------------------------------------ run
def _run_help() -> str:
    from simcalib.config import describe_keys, list_scenarios
    scen = ", ".join(list_scenarios()) or "(none found)"
    return RUN_USAGE.format(scenarios=scen, keys="\n".join(describe_keys()))


def _cmd_run(rest: list[str]) -> int:
    if any(a in ("-h", "--help") for a in rest):
        print(_run_help(), end="")
        return 0
    flags = {a for a in rest if a.startswith("--")}
    unknown_flags = flags - {"--dry-run", "--traceback"}
    if unknown_flags:
        raise UsageError(f"unknown option {sorted(unknown_flags)[0]!r}; options: --dry-run, "
                         "--traceback, --help")
    args = [a for a in rest if not a.startswith("--")]
    traceback = "--traceback" in flags or os.environ.get("SIMCALIB_TRACEBACK") == "1"
    scenario = None
    overrides = []
    for i, a in enumerate(args):
        if "=" not in a:
            if i == 0:  # `run planar` is accepted as `run scenario=planar`
                scenario = a
                continue
            raise UsageError(f"expected key=value, received {a!r} (see run --help)")
        key, value = a.split("=", 1)
        if key.strip() == "scenario":
            if scenario is not None:
                raise UsageError("scenario given twice")
            scenario = value.strip()
        else:
            overrides.append(a)
    if not scenario:
        from simcalib.config import list_scenarios
        raise UsageError("run needs scenario=NAME; available: "
                         f"{', '.join(list_scenarios()) or '(none)'}")

    from simcalib.config import ConfigError, load_config, to_dict
    try:
        cfg = load_config(scenario, overrides)
    except (ConfigError, ValueError, TypeError) as exc:
        if traceback:
            raise
        raise UsageError(str(exc)) from None
    if "--dry-run" in flags:
        import yaml
        print(yaml.safe_dump(to_dict(cfg), sort_keys=False), end="")
        return 0

    from simcalib.pipeline import RunInterrupted, run
    try:
        result = run(cfg)
    except RunInterrupted as exc:
        _err(str(exc))
        return 130
    except KeyboardInterrupt:
        _err("interrupted before any output was written")
        return 130
    except BrokenPipeError:
        raise  # stdout closed by the reader: handled (quietly) in main
    except Exception as exc:  # one-line reason; --traceback for the details
        if traceback:
            raise
        _err(f"run failed: {type(exc).__name__}: {exc}")
        return 1
    print(f"results: {result.output_dir}")
    return 0
