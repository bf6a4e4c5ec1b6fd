"""Command line: ``python -m simcalib <command> ...`` (also the ``simcalib`` console script).

A thin layer over the library. Each command is one module of ``simcalib/commands/`` that
registers itself in :data:`COMMANDS` (a :class:`simcalib.registry.Registry`: the first
lookup imports every module of that folder, so a new command is one new file and no list
to edit)::

    from simcalib.cli import command

    @command("calibrate", summary="calibrate X from two recorded pose files",
             usage="calibrate a=PATH b=PATH output=DIR [key=value ...]")
    def main(args: list[str]) -> int: ...

A command whose code lives elsewhere registers a ``"module:function"`` target, imported
only when the command runs (``register_command("bench", "simcalib.studies.bench.solvers:
main", summary=...)``). The command modules are light (their heavy imports happen inside
``main``), so ``list`` and ``--help`` import neither MuJoCo, rerun nor OpenCV.

:func:`main` never raises for a user error: every typed error
(:mod:`simcalib.errors`) becomes a one-line message on stderr and its exit code (0 ok, 1
unexpected failure, 2 usage/config, 3 input/data, 4 rendering backend, 5 solver, 6
degenerate result, 130 interrupted; docs/cli.md). ``--debug`` (anywhere on the command
line, or ``SIMCALIB_DEBUG=1``) adds the Python traceback.

:func:`run` is the process's entry (``python -m simcalib``, the console script): it calls
:func:`main` and ends the process with its status. After a command registered with
``quick_exit=True`` (one whose outputs are all closed when it returns: ``calibrate``) it
skips the interpreter's teardown (freeing numba's, scipy's and numpy's objects: 0.1-0.3 s
a user waits for); the exit handlers still run and the streams are flushed.
"""

from __future__ import annotations

import importlib
import os
import sys
from dataclasses import dataclass
from typing import Callable, Sequence

from simcalib.errors import (EXIT_CODES, EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK,
                             EXIT_USAGE, SimcalibError, UsageError, exit_code)
from simcalib.registry import Registry

__all__ = ["COMMANDS", "Command", "UsageError", "command", "main", "register_command", "run"]

PROG = "simcalib"

#: flags understood by every command (removed before the command sees its arguments)
DEBUG_FLAGS = ("--debug", "--traceback")


@dataclass(frozen=True)
class Command:
    """A registered sub-command: ``target`` is the function (it takes the remaining
    arguments and returns the exit code) or ``"module:function"``, imported when the
    command runs; ``summary`` one line of the help; ``usage`` its synopsis;
    ``quick_exit``: the process may end without the interpreter's teardown after it (every
    file it writes is closed when it returns; :func:`run`)."""
    name: str
    target: Callable[[list[str]], int] | str
    summary: str
    usage: str = ""
    quick_exit: bool = False

    def load(self) -> Callable[[list[str]], int]:
        if callable(self.target):
            return self.target
        module, _, func = self.target.partition(":")
        mod = importlib.import_module(module)
        fn = getattr(mod, func or "main", None)
        if fn is None:
            raise UsageError(f"{module} has no {func or 'main'}(args)")
        return fn

    @property
    def module(self) -> str:
        """The module that holds the command's code."""
        if callable(self.target):
            return getattr(self.target, "__module__", "")
        return self.target.partition(":")[0]


def _command_info(name: str, target, *, summary: str, usage: str = "",
                  quick_exit: bool = False) -> Command:
    if not name or name.startswith("-") or any(c.isspace() for c in name):
        raise ValueError(f"a command name must be one word; received {name!r}")
    if not (callable(target) or (isinstance(target, str) and ":" in target)):
        raise TypeError(f"command {name!r} needs a function or a 'module:function' target; "
                        f"received {target!r}")
    if not isinstance(summary, str) or not summary.strip():
        raise ValueError(f"command {name!r} needs a one-line summary")
    return Command(name, target, summary, usage or name, bool(quick_exit))


#: name -> command; the files of ``simcalib/commands/`` register themselves (help lists
#: them by name)
COMMANDS: Registry = Registry("command", package="simcalib.commands", error=UsageError,
                              info=_command_info)


def command(name: str, *, summary: str, usage: str = "", quick_exit: bool = False):
    """Decorator registering ``main(args) -> int`` as the sub-command ``name``
    (``quick_exit``: see :class:`Command`)."""
    return COMMANDS.register(name, summary=summary, usage=usage, quick_exit=quick_exit)


def register_command(name: str, target: Callable | str, summary: str,
                     usage: str = "") -> None:
    """Register the sub-command ``name``: ``target`` a function or ``"module:function"``
    (imported when the command runs)."""
    COMMANDS.register(name, target, summary=summary, usage=usage)


def commands() -> list[Command]:
    """Every registered command, by name."""
    return [COMMANDS.info(n) for n in sorted(COMMANDS.names())]


def usage() -> str:
    cmds = commands()
    width = max(len(c.usage) for c in cmds)
    lines = [f"usage: python -m {PROG} [--debug] <command> [args]   "
             f"(or: {PROG} <command> [args])", "", "commands:"]
    for cmd in cmds:
        lines.append(f"  {cmd.usage:<{width}}  {cmd.summary}")
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
    if not _RUNNING:
        _RAN.clear()
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


#: the command the outermost :func:`main` ran (for :func:`run`: a command may call
#: ``main`` for another, e.g. ``experiment streams`` runs ``calibrate``)
_RAN: list[Command] = []
_RUNNING: list[Command] = []      # the commands running now, outermost first


def run(argv: Sequence[str] | None = None):
    """The process's entry: :func:`main`, then the process ends with its status; without
    the interpreter's teardown after a ``quick_exit`` command (the non-daemon threads are
    joined, the exit handlers run, stdout and stderr are flushed, as at a normal exit)."""
    status = main(argv)
    if not (_RAN and _RAN[-1].quick_exit):
        sys.exit(status)
    from simcalib.parallel import exit_now
    exit_now(status, join_threads=True)


def _run_command(cmd: str, rest: list[str]) -> int:
    COMMANDS.get(cmd)                 # an unknown name: did you mean ..., available: ...
    command = COMMANDS.info(cmd)
    if not _RUNNING:
        _RAN.append(command)
    _RUNNING.append(command)
    try:
        return _load_and_call(cmd, command, rest)
    finally:
        _RUNNING.pop()


def _load_and_call(cmd: str, command: Command, rest: list[str]) -> int:
    module = command.module
    try:
        fn = command.load()
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            raise UsageError(f"command {cmd!r} is not available in this installation "
                             f"({module} is missing)") from None
        raise
    except ImportError:
        if module in sys.modules and sys.modules[module] is None:
            raise UsageError(f"command {cmd!r} is not available in this installation "
                             f"({module} is missing)") from None
        raise
    from simcalib.parallel import one_blas_thread
    with one_blas_thread():           # small matrices only: BLAS threads just contend
        status = fn(rest)
    return EXIT_OK if status is None else int(status)
