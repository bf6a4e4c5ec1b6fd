"""Configuration: a generic engine and the scenario schema assembled from its sections.

- :mod:`simcalib.config.engine` — dataclass trees from nested mappings / YAML, ``key=value``
  overrides, unknown keys with the closest match, aliases passed in, :func:`to_dict`; it
  knows no scenario.
- :mod:`simcalib.config.scenario` — :class:`ScenarioConfig` and the scenario files.
- :mod:`simcalib.config.checks` — the range/type checks every section's ``__post_init__``
  uses; :mod:`simcalib.config.resources` — where built-in files live.

This package is a face: the names below are looked up in their module at first use
(PEP 562), so ``import simcalib.config`` (or a section importing ``simcalib.config.checks``)
loads neither the schema nor the world, and no import runs back up through here.
"""

from __future__ import annotations

import importlib

#: public name -> the module that defines it
_FACE = {
    **{name: "engine" for name in (
        "build", "leaf_paths", "parse_override", "parse_overrides", "resolve_key",
        "to_dict", "_parse_value")},
    **{name: "files" for name in ("describe_yaml_files", "find_yaml", "_yaml_error_text")},
    **{name: "scenario" for name in (
        "ALIASES", "KINDS", "SOURCES", "NoiseConfig", "PairingConfig", "PriorConfig",
        "RecordingConfig", "ScenarioConfig", "VerdictConfig", "apply_overrides",
        "describe_keys", "list_scenarios", "load_config", "load_configs",
        "load_scenario_data", "resolve_keys", "scenario_dir", "scenario_path")},
    "ConfigError": "simcalib.errors",
}

__all__ = sorted(n for n in _FACE if not n.startswith("_"))


def __getattr__(name: str):
    module = _FACE.get(name)
    if module is None:
        raise AttributeError(f"module 'simcalib.config' has no attribute {name!r}")
    target = importlib.import_module(module if "." in module else f"simcalib.config.{module}")
    value = getattr(target, name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_FACE))
