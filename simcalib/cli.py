"""Command line: ``python -m simcalib <command> ...`` (also the ``simcalib`` console script).

A thin layer over the library. Each command is a function ``(args: list[str]) -> int`` in
its own module, named in the :data:`COMMANDS` table as ``"module:function"`` and imported
only when the command runs (``list`` imports neither MuJoCo, rerun nor OpenCV). To add a
command, add one row to the table (or call :func:`register_command`)::

    COMMANDS["calibrate"] = Command("simcalib.commands.calibrate:main",
                                    "calibrate from recorded pose files",
                                    "calibrate FILE_A FILE_B [key=value ...]")

:func:`main` never raises for a user error: every typed error
(:mod:`simcalib.errors`) becomes a one-line message on stderr and its exit code (0 ok, 1
unexpected failure, 2 usage/config, 3 input/data, 4 rendering backend, 5 solver, 6
degenerate result, 130 interrupted; docs/cli.md). ``--debug`` (anywhere on the command
line, or ``SIMCALIB_DEBUG=1``) adds the Python traceback.
"""

from __future__ import annotations

import importlib
import os
import sys
from dataclasses import dataclass
from typing import Callable, Sequence

from simcalib.errors import (EXIT_CODES, EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK,
                             EXIT_USAGE, SimcalibError, UsageError, exit_code,
                             unknown_choice)

__all__ = ["COMMANDS", "Command", "UsageError", "main", "register_command"]

PROG = "simcalib"

#: flags understood by every command (removed before the command sees its arguments)
DEBUG_FLAGS = ("--debug", "--traceback")


@dataclass(frozen=True)
class Command:
    """A sub-command: ``target`` is ``"module:function"`` (the function takes the remaining
    arguments and returns the exit code), imported when the command runs."""
    target: str
    summary: str
    usage: str = ""

    def load(self) -> Callable[[list[str]], int]:
        module, _, func = self.target.partition(":")
        mod = importlib.import_module(module)
        fn = getattr(mod, func or "main", None)
        if fn is None:
            raise UsageError(f"{module} has no {func or 'main'}(args)")
        return fn


#: name -> command, in the order of the help text
COMMANDS: dict[str, Command] = {
    "run": Command("simcalib.commands.run:main",
                   "simulate, pair, solve and evaluate one scenario",
                   "run scenario=NAME [key=value ...] [--dry-run]"),
    "list": Command("simcalib.commands.list:main", "list scenarios and solvers", "list"),
    "calibrate": Command("simcalib.commands.calibrate:main",
                         "calibrate X from two recorded pose files (offset, outliers)",
                         "calibrate a=PATH b=PATH output=DIR [key=value ...]"),
    "experiment": Command("simcalib.studies.experiments:main", "reproduce the paper's experiments",
                          "experiment NAME [key=value ...]"),
    "sweep": Command("simcalib.commands.sweep:main",
                     "run a study of many runs (grid / zip / random axes x seeds)",
                     "sweep FILE [key=value ...] output=DIR | sweep report|status DIR"),
    "advise": Command("simcalib.commands.advise:main",
                      "which motions to record next (verified in simulation)",
                      "advise scenario=NAME|a=PATH b=PATH platform=P [k=5] output=DIR"),
    "bench": Command("simcalib.studies.bench.solvers:main", "solver benchmark (Table-1-like timings)",
                     "bench [...]"),
    "bench-vision": Command("simcalib.studies.bench.vision:main",
                            "visual pose accuracy and throughput benchmark",
                            "bench-vision [...]"),
}


def register_command(name: str, target: str, summary: str, usage: str = "") -> None:
    """Add (or replace) a sub-command: ``target`` is ``"module:function"``."""
    if not name or name.startswith("-"):
        raise ValueError(f"command name must be a word; received {name!r}")
    COMMANDS[name] = Command(target, summary, usage or name)


def usage() -> str:
    width = max(len(c.usage or n) for n, c in COMMANDS.items())
    lines = [f"usage: python -m {PROG} [--debug] <command> [args]   "
             f"(or: {PROG} <command> [args])", "", "commands:"]
    for name, cmd in COMMANDS.items():
        lines.append(f"  {cmd.usage or name:<{width}}  {cmd.summary}")
    lines += ["", f"Run '{PROG} <command> --help' for a command's options.",
              "--debug (or SIMCALIB_DEBUG=1) shows the Python traceback of an error.",
              "", "exit codes:"]
    lines += [f"  {code:>3}  {meaning}" for code, meaning in EXIT_CODES.items()]
    return "\n".join(lines) + "\n"


def _err(msg) -> None:
    text = str(msg).strip()
    first = next((ln for ln in text.splitlines() if ln.strip()), "unknown error")
    print(f"{PROG}: error: {first}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the process exit status (never raises for user errors)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = any(a in DEBUG_FLAGS for a in argv) or \
        os.environ.get("SIMCALIB_DEBUG") == "1" or os.environ.get("SIMCALIB_TRACEBACK") == "1"
    argv = [a for a in argv if a not in DEBUG_FLAGS]
    if not argv or argv[0] in ("-h", "--help", "help"):
        if len(argv) >= 2 and argv[0] == "help" and argv[1] in COMMANDS:
            argv = [argv[1], "--help"]
        else:
            print(usage(), end="")
            return EXIT_OK if argv else EXIT_USAGE
    cmd, rest = argv[0], argv[1:]
    try:
        return _run_command(cmd, rest)
    except BrokenPipeError:  # stdout closed early (e.g. piped into `head`): not an error
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return EXIT_OK
    except KeyboardInterrupt as exc:   # also pipeline.RunInterrupted (says what was kept)
        _debug_traceback(debug)
        _err(f"{cmd}: {exc}" if str(exc).strip() else f"{cmd} interrupted")
        return EXIT_INTERRUPTED
    except SystemExit as exc:  # argparse inside a sub-command
        code = exc.code
        return code if isinstance(code, int) else (EXIT_OK if code is None else EXIT_FAILURE)
    except Exception as exc:  # noqa: BLE001 - every error becomes one line and a code
        _debug_traceback(debug)
        code = exit_code(exc)
        if isinstance(exc, SimcalibError) or code == EXIT_INTERRUPTED:
            _err(exc)
        else:
            hint = "" if debug else " (run with --debug for the traceback)"
            _err(f"{cmd} failed: {type(exc).__name__}: {_first_line(exc)}{hint}")
        return code


def _first_line(exc) -> str:
    text = str(exc).strip()
    return next((ln for ln in text.splitlines() if ln.strip()), "")


def _debug_traceback(debug: bool) -> None:
    if debug:
        import traceback
        traceback.print_exc(file=sys.stderr)


def _run_command(cmd: str, rest: list[str]) -> int:
    if cmd not in COMMANDS:
        raise unknown_choice("command", cmd, COMMANDS, error=UsageError)
    command = COMMANDS[cmd]
    module = command.target.partition(":")[0]
    try:
        fn = command.load()
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            raise UsageError(f"command {cmd!r} is not available in this installation "
                             f"({module} is missing)") from None
        raise
    except ImportError as exc:
        if module in sys.modules and sys.modules[module] is None:
            raise UsageError(f"command {cmd!r} is not available in this installation "
                             f"({module} is missing)") from None
        raise
    status = fn(rest)
    return EXIT_OK if status is None else int(status)
