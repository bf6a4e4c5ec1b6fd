"""The paper's experiments (Dekel et al., CVPR 2020): ``table1``, ``table2``, ``figure3``,
``figure6``; ``streams``, the validation of the stream calibration; and
``real_data``, the regression table on public real recordings.

Command line::

    python -m simcalib experiment NAME [key=value ...] [output=DIR]
    python -m simcalib.studies.experiments NAME [key=value ...]          # same, standalone

Library::

    from simcalib.studies.experiments import run_experiment
    result = run_experiment("table2", samples=100, output="out/table2")
    result.files["csv"], result.rows

Each experiment writes CSV + markdown + PNG files and a rerun recording ``NAME.rrd`` into
its output directory. Keys are the fields of its config dataclass (``Table1Config``,
``Table2Config``, ``Figure3Config``, ``Figure6Config``), parsed by the same config engine
as ``run``: lists in brackets (``scenarios=[line,circle]``), YAML numbers and booleans;
unknown keys are rejected naming the closest and the valid ones.
"""

from __future__ import annotations

import importlib
import sys

from simcalib.errors import ConfigTypeError, unknown_choice

__all__ = ["EXPERIMENTS", "run_experiment", "config_class", "main"]

# name -> (module, config class name)
EXPERIMENTS = {
    "table1": ("simcalib.studies.experiments.table1", "Table1Config"),
    "table2": ("simcalib.studies.experiments.table2", "Table2Config"),
    "figure3": ("simcalib.studies.experiments.figure3", "Figure3Config"),
    "figure6": ("simcalib.studies.experiments.figure6", "Figure6Config"),
    "streams": ("simcalib.studies.experiments.streams", "StreamsConfig"),
    "recordings": ("simcalib.studies.experiments.recordings", "RecordingsConfig"),
    "real_data": ("simcalib.studies.experiments.real_data", "RealDataConfig"),
}


def _lookup(name: str):
    if not isinstance(name, str):
        raise ConfigTypeError(f"experiment name must be a string; received "
                              f"{type(name).__name__}")
    if name not in EXPERIMENTS:
        raise unknown_choice("experiment", name, EXPERIMENTS)
    mod_name, cls_name = EXPERIMENTS[name]
    mod = importlib.import_module(mod_name)
    return mod, getattr(mod, cls_name)


def config_class(name: str):
    """The config dataclass of experiment ``name``."""
    return _lookup(name)[1]


def run_experiment(name: str, config=None, **overrides):
    """Run experiment ``name`` with a config object or keyword overrides (Python values, or
    strings parsed like command-line values: ``scenarios="[line,circle]"``). Returns an
    ``ExperimentResult``."""
    from simcalib.studies.experiments.common import build_config
    mod, cls = _lookup(name)
    if config is None:
        config = build_config(cls, overrides)
    elif overrides:
        raise ConfigTypeError("pass either a config object or keyword overrides, not both")
    elif not isinstance(config, cls):
        raise ConfigTypeError(f"config for {name!r} must be a {cls.__name__}; received "
                              f"{type(config).__name__}")
    return mod.run(config)


def _usage() -> str:
    import dataclasses
    lines = ["usage: python -m simcalib experiment NAME [key=value ...] [output=DIR]", "",
             "Lists are written in brackets: scenarios=[line,circle] algorithms=[dqopt,daniilidis]",
             "", "experiments and their keys (defaults):"]
    for name in EXPERIMENTS:
        cls = config_class(name)
        lines.append(f"  {name}:")
        for f in dataclasses.fields(cls):
            default = f.default
            if isinstance(default, tuple):
                default = "[" + ",".join(f"{v:.4g}" if isinstance(v, float) else str(v)
                                         for v in default) + "]"
            elif isinstance(default, float):
                default = f"{default:.6g}"
            lines.append(f"      {f.name}={default}")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Command-line entry: ``NAME [key=value ...]``. Returns the exit code (0 ok, 2 bad
    arguments: every key is checked before any work). Errors during the experiment
    propagate (the ``simcalib`` CLI maps them to exit codes, docs/cli.md). Prints where the
    files went and the experiment's notes."""
    from simcalib.errors import ConfigError
    from simcalib.studies.experiments.common import build_config, parse_overrides
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(_usage())
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    try:
        mod, cls = _lookup(name)
        config = build_config(cls, parse_overrides(rest))
    except ConfigError as exc:
        print(f"simcalib: error: {exc}", file=sys.stderr)
        return 2
    result = mod.run(config)
    print(f"{result.name}: wrote {len(result.files)} files to {result.output_dir} "
          f"in {result.runtime_s:.1f} s")
    for key, path in result.files.items():
        print(f"  {key:<11} {path}")
    md = result.files.get("md")
    if md is not None:
        print()
        print(open(md).read())
    return 0
