"""The error hierarchy of simcalib and the command line's exit codes (docs/cli.md).

Every error the library raises on purpose is a :class:`SimcalibError`; each subclass also
derives from the built-in exception callers used to catch before (``ValueError``,
``RuntimeError``), so ``except ValueError`` keeps working::

    SimcalibError
    ├── UsageError            bad command line                       exit 2
    ├── ConfigError (ValueError)   unknown key, bad value             exit 2
    │   └── ConfigTypeError (TypeError)  value of the wrong type     exit 2
    ├── InputError (ValueError)    bad input data (arrays, poses)     exit 3
    │   └── DataError              unreadable / inconsistent files    exit 3
    ├── BackendError (RuntimeError)  rendering backend unavailable    exit 4
    └── SolverError (RuntimeError)   a solver could not produce X     exit 5
        └── DegenerateResultError     motion does not determine X     exit 6

Exit codes: 0 ok, 1 unexpected failure, 2 usage/config, 3 input/data, 4 backend, 5 solver,
6 degenerate result, 130 interrupted (Ctrl-C). :func:`exit_code` maps any exception.

:func:`did_you_mean` / :func:`unknown_choice` are the one "closest match" helper every
registry and config lookup uses. This module imports nothing heavy (stdlib only).
"""

from __future__ import annotations

import difflib
from typing import Any, Iterable

__all__ = [
    "EXIT_OK", "EXIT_FAILURE", "EXIT_USAGE", "EXIT_CONFIG", "EXIT_INPUT", "EXIT_BACKEND",
    "EXIT_SOLVER", "EXIT_DEGENERATE", "EXIT_INTERRUPTED", "EXIT_CODES",
    "SimcalibError", "UsageError", "ConfigError", "ConfigTypeError", "InputError",
    "DataError", "BackendError", "SolverError", "DegenerateResultError",
    "did_you_mean", "closest", "unknown_choice", "exit_code",
]

EXIT_OK = 0
EXIT_FAILURE = 1          # an unexpected error (a bug or an unclassified failure)
EXIT_USAGE = 2            # bad command line
EXIT_CONFIG = 2           # bad configuration (same code as usage: nothing was run)
EXIT_INPUT = 3            # bad input data / pose files
EXIT_BACKEND = 4          # rendering backend (OpenGL / MuJoCo) unavailable
EXIT_SOLVER = 5           # a solver failed
EXIT_DEGENERATE = 6       # the result is degenerate (motion does not determine X)
EXIT_INTERRUPTED = 130    # Ctrl-C

#: code -> meaning (docs/cli.md and the README table are written from this)
EXIT_CODES = {
    EXIT_OK: "success",
    EXIT_FAILURE: "unexpected failure (a bug, or an error simcalib did not classify)",
    EXIT_USAGE: "usage or configuration error (reported before any work)",
    EXIT_INPUT: "input or data error (bad arrays, unreadable or inconsistent pose files)",
    EXIT_BACKEND: "rendering backend unavailable (OpenGL / MuJoCo)",
    EXIT_SOLVER: "a solver failed to produce an estimate",
    EXIT_DEGENERATE: "degenerate result: the motion does not determine the extrinsic",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C); partial outputs are kept",
}

_MISSING = object()


class SimcalibError(Exception):
    """Base of every error simcalib raises on purpose; ``exit_code`` is the CLI status."""
    exit_code = EXIT_FAILURE


class UsageError(SimcalibError):
    """Bad command line (unknown command or option, missing argument)."""
    exit_code = EXIT_USAGE


class ConfigError(SimcalibError, ValueError):
    """A configuration problem: unknown key, bad value, unknown scenario.

    Built either from a full ``message`` or from parts: ``key`` (dotted path), ``value``
    (what was received) and ``allowed`` (what is allowed), giving
    ``"<key> must be <allowed>; received <value!r>"``. :meth:`at` re-roots the key under a
    section (``width`` -> ``world.cam_a.width``) so a check written inside a section's
    dataclass names the full key when the section is built from a scenario.
    """
    exit_code = EXIT_CONFIG

    def __init__(self, message: str | None = None, *, key: str | None = None,
                 value: Any = _MISSING, allowed: str | None = None, hint: str = ""):
        self.key = key
        self.value = value
        self.allowed = allowed
        self.hint = hint
        if message is None:
            message = self._format()
        self.message = message
        super().__init__(message)

    def _format(self) -> str:
        key = self.key or "value"
        text = f"{key} must be {self.allowed}" if self.allowed else f"{key} is invalid"
        if self.hint:
            text += f" {self.hint}"
        if self.value is not _MISSING:
            text += f"; received {self.value!r}"
        return text

    def at(self, prefix: str) -> "ConfigError":
        """The same error with its key under section ``prefix``."""
        if not prefix:
            return self
        if self.key is not None and self.allowed is not None:
            if self.key == prefix or self.key.startswith(prefix + "."):
                return self
            return type(self)(key=f"{prefix}.{self.key}", value=self.value,
                              allowed=self.allowed, hint=self.hint)
        if self.message.startswith(prefix):
            return self
        return type(self)(f"{prefix}: {self.message}", key=self.key, value=self.value)


class ConfigTypeError(ConfigError, TypeError):
    """A configuration value of the wrong type (also a ``TypeError``)."""


class InputError(SimcalibError, ValueError):
    """Bad input data given to the library (arrays of the wrong shape, non-rigid poses)."""
    exit_code = EXIT_INPUT


class DataError(InputError):
    """A data file (pose file, recording) is unreadable or inconsistent."""


class BackendError(SimcalibError, RuntimeError):
    """The rendering backend (OpenGL context, MuJoCo) is unavailable or failed."""
    exit_code = EXIT_BACKEND


class SolverError(SimcalibError, RuntimeError):
    """A solver could not produce an estimate."""
    exit_code = EXIT_SOLVER


class DegenerateResultError(SolverError):
    """The estimate is degenerate: the motion does not determine the extrinsic."""
    exit_code = EXIT_DEGENERATE


# ----------------------------------------------------------------------- closest match
def closest(name: Any, choices: Iterable[str], *, cutoff: float = 0.6) -> str | None:
    """The choice closest to ``name`` (difflib ratio >= ``cutoff``), else ``None``.

    Dotted names are also matched on their last components, so ``sigma_r_dg`` finds
    ``noise.sigma_r_deg``."""
    choices = [str(c) for c in choices]
    text = str(name)
    found = difflib.get_close_matches(text, choices, n=1, cutoff=cutoff)
    if found:
        return found[0]
    depth = text.count(".")
    tails: dict[str, str] = {}
    for c in choices:
        if c.count(".") > depth:
            tails.setdefault(c.split(".", c.count(".") - depth)[-1], c)
    found = difflib.get_close_matches(text, list(tails), n=1, cutoff=cutoff)
    return tails[found[0]] if found else None


def did_you_mean(name: Any, choices: Iterable[str], *, cutoff: float = 0.6,
                 prefix: str = "") -> str:
    """``" (did you mean 'x'?)"`` for the closest choice, or ``""``; ``prefix`` is put in
    front of the suggestion (a section path)."""
    match = closest(name, choices, cutoff=cutoff)
    return f" (did you mean {prefix + match!r}?)" if match else ""


def unknown_choice(kind: str, name: Any, choices: Iterable[str], *, key: str | None = None,
                   error: type[Exception] = ConfigError, cutoff: float = 0.6) -> Exception:
    """The error for an unknown name: ``"unknown <kind> 'x' (did you mean 'y'?);
    available: a, b"`` (prefixed with ``key:`` when given). Returned, not raised."""
    choices = [str(c) for c in choices]
    where = f"{key}: " if key else ""
    listing = ", ".join(choices) if choices else "(none)"
    msg = (f"{where}unknown {kind} {name!r}{did_you_mean(name, choices, cutoff=cutoff)}; "
           f"available: {listing}")
    if issubclass(error, ConfigError):
        return error(msg, key=key, value=name)
    return error(msg)


# --------------------------------------------------------------------------- exit codes
def exit_code(exc: BaseException) -> int:
    """The CLI exit status for an exception (``KeyboardInterrupt`` -> 130; a
    :class:`SimcalibError` -> its ``exit_code``; anything else -> 1)."""
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    code = getattr(exc, "exit_code", None)
    if isinstance(exc, SimcalibError) and isinstance(code, int):
        return code
    if type(exc).__name__ == "RunInterrupted":
        return EXIT_INTERRUPTED
    return EXIT_FAILURE
