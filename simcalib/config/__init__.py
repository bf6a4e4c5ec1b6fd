"""Configuration: a generic engine that knows no schema.

- :mod:`simcalib.config.engine` — dataclass trees from nested mappings / YAML, ``key=value``
  overrides, unknown keys with the closest match, aliases passed in, :func:`to_dict`.
- :mod:`simcalib.config.checks` — the range/type checks every section's ``__post_init__``
  uses; :mod:`simcalib.config.files` — YAML files in a folder; :mod:`simcalib.config.resources`
  — where built-in files live.

The scenario schema, assembled from the sections that each extension owns, is
:mod:`simcalib.pipeline.scenario`: this package imports nothing of simcalib but its errors
and geometry, so every section can use it without a circle.
"""
