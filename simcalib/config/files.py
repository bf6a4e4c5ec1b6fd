"""Named YAML files in a folder (scenarios, sweeps): find one by name, describe them all,
and a YAML syntax error as ``line L, column C: problem``. Knows no schema."""

from __future__ import annotations

import os
from pathlib import Path

from simcalib.errors import ConfigError, unknown_choice

__all__ = ["describe_yaml_files", "find_yaml", "output_folder"]


def output_folder(path, key: str = "output") -> Path:
    """The folder ``path`` of config key ``key``, created if missing; a folder that cannot
    be created or written is a ConfigError naming the key, the path and the reason."""
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"{key}={str(path)!r}: cannot create the folder "
                          f"({exc.strerror or exc}); choose a writable folder") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise ConfigError(f"{key}={str(path)!r}: the folder is not writable; choose a "
                          "writable folder")
    return out


def describe_yaml_files(folder: Path) -> dict[str, str]:
    """``{stem: one-line description}`` of the YAML files in ``folder``, sorted (scenarios,
    sweeps); a broken file is listed with its problem."""
    import yaml
    out = {}
    if not folder.is_dir():
        return out
    for p in sorted(folder.glob("*.yaml")):
        try:
            data = yaml.safe_load(p.read_text()) or {}
            desc = str(data.get("description", "")).strip().splitlines()
            out[p.stem] = desc[0] if desc else ""
        except Exception as exc:  # a broken file is listed with its problem
            out[p.stem] = f"(unreadable: {exc})"
    return out


def find_yaml(name: str, folder: Path, kind: str) -> Path:
    """The YAML file of ``kind`` (``"scenario"``, ``"sweep"``) called ``name`` in
    ``folder``, or ``name`` itself when it is a YAML path; unknown names list the valid
    ones with the closest match."""
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{kind} must be a non-empty name; received {name!r}")
    if name.endswith((".yaml", ".yml")) or os.sep in name:
        p = Path(name)
        if not p.is_file():
            raise ConfigError(f"{kind} file {name!r} does not exist")
        return p
    p = folder / f"{name}.yaml"
    if p.is_file():
        return p
    names = list(describe_yaml_files(folder))
    if not names:
        raise ConfigError(f"unknown {kind} {name!r}; no {kind} files found in {folder}"
                          + (" (set SIMCALIB_SCENARIOS)" if kind == "scenario" else ""),
                          key=kind, value=name)
    raise unknown_choice(kind, name, names)


def _yaml_error_text(exc) -> str:
    """``"line 3, column 7: mapping values are not allowed here"`` from a YAML error."""
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    problem = getattr(exc, "problem", None) or str(exc).strip().splitlines()[0]
    if mark is not None:
        return f"line {mark.line + 1}, column {mark.column + 1}: {problem}"
    return str(problem)
