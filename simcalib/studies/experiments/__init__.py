"""Experiments: the paper's (Dekel et al., CVPR 2020) ``table1``, ``table2``, ``figure3``,
``figure6``; ``streams``, the validation of the stream calibration; ``recordings``, the
benchmark recordings of ``calibrate``; and ``real_data``, the regression table on public
real recordings. Each is one module of this folder that registers its ``run`` in
:data:`EXPERIMENTS` (``@experiment(name, config=..., description=...)``), found on the
first lookup with no list to edit.

Command line::

    python -m simcalib experiment NAME [key=value ...] [output=DIR]
    python -m simcalib.studies.experiments NAME [key=value ...]          # same, standalone

Library::

    from simcalib.studies.experiments import run_experiment
    result = run_experiment("table2", samples=100, output="out/table2")
    result.files["csv"], result.rows

Each experiment writes CSV + markdown + PNG files and a rerun recording ``NAME.rrd`` into
its output directory. Keys are the fields of its config dataclass (``Table1Config``,
``Table2Config``, ...: ``config_class(name)``), parsed by the same config engine
as ``run``: lists in brackets (``scenarios=[line,circle]``), YAML numbers and booleans;
unknown keys are rejected naming the closest and the valid ones.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, is_dataclass
from typing import Callable

from simcalib.errors import ConfigTypeError
from simcalib.registry import Registry

__all__ = ["EXPERIMENTS", "Experiment", "experiment", "run_experiment", "config_class",
           "main"]


@dataclass(frozen=True)
class Experiment:
    """A registered experiment: ``run(config) -> ExperimentResult`` and its ``config``
    dataclass (the keys of ``experiment NAME key=value``)."""
    name: str
    run: Callable
    config: type
    description: str


def _experiment_info(name: str, run: Callable, *, config: type,
                     description: str) -> Experiment:
    if not callable(run) or not (isinstance(config, type) and is_dataclass(config)):
        raise TypeError(f"experiment {name!r} needs a run(config) function and a config "
                        f"dataclass; received {run!r}, {config!r}")
    return Experiment(name, run, config, description)


#: name -> run function (info: :class:`Experiment`); every module of this folder is
#: imported on the first lookup, and an experiment module registers its ``run`` with
#: :func:`experiment`, so a new experiment is one new file.
EXPERIMENTS: Registry = Registry("experiment", package="simcalib.studies.experiments",
                                 info=_experiment_info)


def experiment(name: str, *, config: type, description: str):
    """Decorator registering ``run(config)`` as experiment ``name`` with its config
    dataclass."""
    return EXPERIMENTS.register(name, config=config, description=description)


def _lookup(name: str) -> Experiment:
    if not isinstance(name, str):
        raise ConfigTypeError(f"experiment name must be a string; received "
                              f"{type(name).__name__}")
    EXPERIMENTS.get(name)           # unknown: did you mean ..., available: ...
    return EXPERIMENTS.info(name)


def config_class(name: str):
    """The config dataclass of experiment ``name``."""
    return _lookup(name).config


def run_experiment(name: str, config=None, **overrides):
    """Run experiment ``name`` with a config object or keyword overrides (Python values, or
    strings parsed like command-line values: ``scenarios="[line,circle]"``). Returns an
    ``ExperimentResult``."""
    from simcalib.studies.experiments.common import build_config
    exp = _lookup(name)
    cls = exp.config
    if config is None:
        config = build_config(cls, overrides)
    elif overrides:
        raise ConfigTypeError("pass either a config object or keyword overrides, not both")
    elif not isinstance(config, cls):
        raise ConfigTypeError(f"config for {name!r} must be a {cls.__name__}; received "
                              f"{type(config).__name__}")
    return exp.run(config)


def _usage() -> str:
    import dataclasses
    lines = ["usage: python -m simcalib experiment NAME [key=value ...] [output=DIR]", "",
             "Lists are written in brackets: scenarios=[line,circle] algorithms=[dqopt,daniilidis]",
             "", "experiments and their keys (defaults):"]
    for name in EXPERIMENTS:
        exp = EXPERIMENTS.info(name)
        cls = exp.config
        lines.append(f"  {name}: {exp.description}")
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
        exp = _lookup(name)
        config = build_config(exp.config, parse_overrides(rest))
    except ConfigError as exc:
        print(f"simcalib: error: {exc}", file=sys.stderr)
        return 2
    result = exp.run(config)
    print(f"{result.name}: wrote {len(result.files)} files to {result.output_dir} "
          f"in {result.runtime_s:.1f} s")
    for key, path in result.files.items():
        print(f"  {key:<11} {path}")
    md = result.files.get("md")
    if md is not None:
        print()
        print(open(md).read())
    return 0
