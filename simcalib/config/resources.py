"""Where simcalib's data files are (the MJCF models and the scenario YAML files), and which
version of simcalib this is.

The repository keeps them at its top level (``models/``, ``scenarios/``); a wheel ships them
inside the package as ``simcalib/models`` and ``simcalib/scenarios`` (package data, see
``setup.py``). Both layouts are found from this file's location, so a checkout, an editable
install and a regular install behave the same, whatever the working directory.

``SIMCALIB_SCENARIOS=/path/to/folder`` replaces the scenario folder with a user's own (every
``*.yaml`` in it is a scenario name for ``run`` and ``list``); a single file can always be
given as ``scenario=path/to/file.yaml`` instead.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["models_dir", "scenarios_dir", "model_path", "package_version", "SCENARIOS_ENV"]

#: Environment variable naming a user's own scenario folder.
SCENARIOS_ENV = "SIMCALIB_SCENARIOS"

_PACKAGE_DIR = Path(__file__).resolve().parents[1]   # simcalib/


def _data_dir(name: str) -> Path:
    """``simcalib/<name>`` (installed wheel), else ``<repo>/<name>`` (checkout, editable)."""
    for candidate in (_PACKAGE_DIR / name, _PACKAGE_DIR.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f"simcalib's {name}/ folder was found neither in the installed package "
        f"({_PACKAGE_DIR / name}) nor beside it ({_PACKAGE_DIR.parent / name}); "
        "reinstall simcalib (`pip install .` ships it as package data)")


def models_dir() -> Path:
    """Folder of the MJCF files (``room.xml``, ``cart.xml``, ``ur5e.xml``, ``rig.xml``)."""
    return _data_dir("models")


def scenarios_dir() -> Path:
    """Folder of the scenario files: ``$SIMCALIB_SCENARIOS`` if set, else the built-in one."""
    env = os.environ.get(SCENARIOS_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    return _data_dir("scenarios")


def model_path(name: str) -> Path:
    """Path of the built-in MJCF model ``name`` (``"rig"`` or ``"rig.xml"``)."""
    if not isinstance(name, str) or not name:
        raise TypeError(f"model name must be a non-empty str; received {name!r}")
    d = models_dir()
    p = d / (name if name.endswith(".xml") else f"{name}.xml")
    if not p.is_file():
        names = sorted(q.stem for q in d.glob("*.xml"))
        raise ValueError(f"unknown model {name!r}; available in {d}: {', '.join(names)}")
    return p


def package_version() -> str:
    """simcalib's version as installed (``pyproject.toml`` is the one place it is written);
    ``"0+unknown"`` for a checkout that was never installed."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("simcalib")
    except PackageNotFoundError:
        return "0+unknown"
